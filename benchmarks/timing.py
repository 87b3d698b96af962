"""Wall-clock timing shared by the benchmarks."""

import time

import numpy as np


def median(fn, n):
    """Median wall time of n calls of fn, in seconds."""
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
