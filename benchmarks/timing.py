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


def interleaved_medians(fns, rounds, n, clock=time.perf_counter):
    """Median wall time (or the time of another clock, such as
    time.process_time) of each of fns over rounds x n calls, in seconds:
    round by round, n calls of each in turn after one untimed call (the
    caches and threads the others left cold), so that a busy spell of a
    shared machine falls on all of them rather than on one."""
    times = [[] for _ in fns]
    for _ in range(rounds):
        for k, fn in enumerate(fns):
            fn()
            for _ in range(n):
                t0 = clock()
                fn()
                times[k].append(clock() - t0)
    return [float(np.median(t)) for t in times]
