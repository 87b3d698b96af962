"""Flight-test design: optimal inputs (report §VII-VIII) and their closed
forms, standard input signals, simulation of a model, and Monte Carlo of
fits, in one process or spread over threads or a Dask cluster."""
