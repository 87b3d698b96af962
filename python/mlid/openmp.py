"""The core's OpenMP threads: how long they spin waiting between parallel
regions, and how many a fit's regions use.

libgomp's default (OMP_WAIT_POLICY and GOMP_SPINCOUNT unset) keeps a thread
that has done its part of a region spinning for 300,000 rounds, about 7 ms
here, before it sleeps.  Most of the core's regions are further apart than
that (the coloured-residual correction comes once at a fit's end, the
filter error's blocks once an evaluation), so all that spinning took a
core and did nothing: an output-error fit on two threads took twice its
CPU time for no less wall time.  Passive waiting (sleep at once) costs a
wake-up at every region instead, some tens of microseconds on this
machine: a two-manoeuvre fit, whose regions come every few hundred
microseconds, took nearly 80 % more wall time.  So mlid asks libgomp to
spin SPIN_COUNT rounds (a quarter of a millisecond) and then sleep, unless
the environment chooses (WAIT_VARIABLES set); benchmarks/bench_threads.py
has the figures of each choice.  libgomp reads the variable once, when it
is loaded with the core: so it is set in os.environ before that, where
child processes inherit it too, and not at all when libgomp is in the
process already.  mlid-batch does the same
(fortran/app/mlid_wait_policy.f90).  The values computed do not depend on
it.
"""

import ctypes
import os

#: The variables by which the environment chooses how threads wait (the _ALL
#: form is newer libgomp's).
WAIT_VARIABLES = ("OMP_WAIT_POLICY", "OMP_WAIT_POLICY_ALL", "GOMP_SPINCOUNT")
#: The variables with which libgomp binds threads: mlid-batch does not start
#: again under them (fortran/app/mlid_wait_policy.f90's BINDING_VARIABLES).
BINDING_VARIABLES = ("OMP_PROC_BIND", "OMP_PROC_BIND_ALL", "OMP_PLACES", "GOMP_CPU_AFFINITY")
#: Rounds a waiting thread spins before it sleeps (mlid-batch's SPIN_COUNT
#: too; tests/test_openmp.py checks both).
SPIN_COUNT = 10000


def brief_spin():
    """GOMP_SPINCOUNT=SPIN_COUNT unless the environment chooses or libgomp
    is loaded already (too late: it has read the environment); the count
    set, or None."""
    if any(v in os.environ for v in WAIT_VARIABLES) or _libgomp_loaded():
        return None
    os.environ["GOMP_SPINCOUNT"] = str(SPIN_COUNT)
    return SPIN_COUNT


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
