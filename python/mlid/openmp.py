"""The core's OpenMP threads: how they wait between parallel regions, and
how many a fit's regions use.

libgomp's default (OMP_WAIT_POLICY unset) keeps a thread that has finished
its part of a region spinning for milliseconds before it sleeps.  The
core's regions are short and far apart (the coloured-residual correction
at a fit's end, the filter error's blocks once an evaluation), so that
spinning takes a core and does nothing: an output-error fit on two threads
took nearly twice its CPU time for no less wall time (the figures:
benchmarks/bench_threads.py).  So mlid asks for the passive policy (sleep
at once) unless the environment chooses (WAIT_VARIABLES set).  libgomp
reads it once, when it is loaded, with the core: so it is set in
os.environ before that, where child processes inherit it too, and not at
all when libgomp is in the process already.  mlid-batch does the same
(fortran/app/mlid_wait_policy.f90).  The values computed do not depend on
it.
"""

import ctypes
import os

#: The variables by which the environment chooses how threads wait.
WAIT_VARIABLES = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")


def passive_wait():
    """OMP_WAIT_POLICY=passive unless the environment chooses or libgomp is
    loaded already (too late: it has read the environment); True when this
    set it."""
    if any(v in os.environ for v in WAIT_VARIABLES) or _libgomp_loaded():
        return False
    os.environ["OMP_WAIT_POLICY"] = "passive"
    return True


def _libgomp_loaded():
    """Whether libgomp is in the process already (not loaded by asking)."""
    try:
        ctypes.CDLL("libgomp.so.1", mode=os.RTLD_NOLOAD)
    except OSError:
        return False
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
