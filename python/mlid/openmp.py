"""The core's OpenMP threads: how they wait between parallel regions, and
how many a fit's regions use.

OpenMP's default (libgomp's, with OMP_WAIT_POLICY unset) keeps a thread
that has finished its part of a region spinning for some milliseconds
before it sleeps.  The core's regions are short and far apart (the
coloured-residual correction at a fit's end, the filter error's blocks once
an evaluation), so that spinning takes a core and does nothing: on two
threads an HFB-320 output-error fit took 8.7 ms of CPU time for 4.6 ms of
wall time, and with passive waiting (sleep at once) 4.9 ms for 4.7 ms
(benchmarks/bench_threads.py).  So mlid asks for the passive policy unless
the environment chooses (OMP_WAIT_POLICY or GOMP_SPINCOUNT set).  It must
be in the environment before libgomp is loaded, with the core: libgomp
reads it once.  mlid-batch does the same (fortran/app/mlid_wait_policy.f90).
The values computed do not depend on it.
"""

import ctypes
import os

#: The variables by which the environment chooses how threads wait.
WAIT_VARIABLES = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")


def passive_wait():
    """OMP_WAIT_POLICY=passive unless the environment chooses; True when
    this set it.  (Too late if libgomp was loaded already: then as it was.)"""
    if any(v in os.environ for v in WAIT_VARIABLES):
        return False
    os.environ["OMP_WAIT_POLICY"] = "passive"
    return True


def team_size(n):
    """Each fit in this thread opens OpenMP teams of n threads (the OpenMP
    thread count is a per-thread setting): workers x n threads stay within
    the cores.  Results do not depend on it.  Nothing if the core was built
    without OpenMP's runtime library."""
    try:
        ctypes.CDLL("libgomp.so.1").omp_set_num_threads(ctypes.c_int(n))
    except (OSError, AttributeError):
        pass
