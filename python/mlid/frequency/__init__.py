"""The frequency domain: finite Fourier transforms of records, the recursive
frequency-domain fit, frequency responses of records and identified models,
and low-order equivalent systems (responses.py's docstring lists the
handling-qualities forms)."""
