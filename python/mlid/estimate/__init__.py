"""Estimation: the core's options by name, the likelihood at given values,
the maximum-likelihood fit, its result (report, JSON, results table) and the
coloured-residual correction; the data compatibility a flight-path fit shows.

The results table is here, not in report/: FitResult.table() and its Jupyter
view give it."""
