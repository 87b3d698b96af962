"""Flight records: FlightData (time, inputs, outputs, read by the core's
record readers: text, MATLAB and HDF5)."""
