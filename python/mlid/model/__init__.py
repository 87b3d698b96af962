"""Model objects (every kind the core has), several manoeuvres' parameters
and joined record, a model's and a record's part of every core call, and the
check of a model's Jacobians."""
