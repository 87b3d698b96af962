"""Flight records: FlightData (time, inputs, outputs, read by the core's
record reader) and the binary formats the Python front end reads."""
