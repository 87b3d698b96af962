"""How the core's OpenMP threads wait, in both front ends
(python/mlid/openmp.py, fortran/app/mlid_wait_policy.f90): a spin of
SPIN_COUNT rounds when the environment does not choose, the environment's
choice otherwise.  What libgomp took is what it displays when loaded
(OMP_DISPLAY_ENV=verbose; the last display, as mlid-batch starts itself
again): its spin count (libgomp's default 300000) and its policy (ACTIVE
only when asked; unset, it is displayed as PASSIVE)."""

import os
import re
import subprocess
import sys

import pytest

from conftest import BIN, REPO
from mlid.openmp import BINDING_VARIABLES, SPIN_COUNT, WAIT_VARIABLES

#: front end: the command that loads the core
FRONT_ENDS = {"python": [sys.executable, "-c", "import mlid; print(mlid.OPENMP_SPIN)"],
              "mlid-batch": [str(BIN / "mlid-batch"), "--help"]}


#: The dynamic loader, run as a program in one test.
LOADER = "/lib64/ld-linux-x86-64.so.2"


def _environment(**env_vars):
    """This one with env_vars added, where nothing chooses how threads wait
    or binds them."""
    env = {k: v for k, v in os.environ.items() if k not in WAIT_VARIABLES + BINDING_VARIABLES}
    env.update(env_vars)
    return env


def _loaded(front_end, command=None, **env_vars):
    """(libgomp's wait policy, its spin count, the process's output, the
    number of times libgomp was loaded) with env_vars added."""
    out = subprocess.run(command or FRONT_ENDS[front_end],
                         env=_environment(OMP_DISPLAY_ENV="verbose", **env_vars),
                         capture_output=True, text=True, check=True, cwd=REPO)
    shown = out.stderr.split("OPENMP DISPLAY ENVIRONMENT BEGIN")
    if len(shown) < 2:
        pytest.skip("the core was built without OpenMP's runtime (libgomp)")
    policy = re.search(r"OMP_WAIT_POLICY = '(\w+)'", shown[-1]).group(1)
    spin = int(re.search(r"GOMP_SPINCOUNT = '(\d+)'", shown[-1]).group(1))
    return policy, spin, out.stdout, len(shown) - 1


@pytest.mark.parametrize("front_end", FRONT_ENDS)
def test_threads_spin_briefly_when_the_environment_does_not_choose(front_end):
    policy, spin, out, loads = _loaded(front_end)
    assert (spin, loads) == (SPIN_COUNT, 1 if front_end == "python" else 2)
    if front_end == "python":
        assert out.split() == [str(SPIN_COUNT)]
    else:
        assert out.startswith("usage: mlid-batch")     # the arguments kept on starting again


@pytest.mark.parametrize("front_end", FRONT_ENDS)
def test_the_environment_chooses_first(front_end):
    """OMP_WAIT_POLICY=active spins (libgomp: 30 billion times), passive
    not at all; a spin count of its own is kept too."""
    policy, spin, out, loads = _loaded(front_end, OMP_WAIT_POLICY="active")
    assert policy == "ACTIVE" and spin > 300000 and loads == 1
    assert _loaded(front_end, OMP_WAIT_POLICY="passive")[:2] == ("PASSIVE", 0)
    assert _loaded(front_end, GOMP_SPINCOUNT="1000")[:2] == ("PASSIVE", 1000)
    if front_end == "python":
        assert out.split() == ["None"]


def test_too_late_when_libgomp_is_loaded_already():
    """Then mlid says it did not choose, and leaves the environment alone."""
    command = [sys.executable, "-c", "import ctypes, os; ctypes.CDLL('libgomp.so.1'); import mlid; "
               "print(mlid.OPENMP_SPIN, 'GOMP_SPINCOUNT' in os.environ)"]
    policy, spin, out, _ = _loaded("python", command)
    assert spin == 300000 and out.split() == ["None", "False"]


#: A value binding threads for each of BINDING_VARIABLES.
BOUND = {"OMP_PROC_BIND": "true", "OMP_PROC_BIND_ALL": "true", "OMP_PLACES": "cores",
         "GOMP_CPU_AFFINITY": "0"}


@pytest.mark.parametrize("variable", BINDING_VARIABLES)
def test_mlid_batch_stays_as_it_is_when_threads_are_bound(variable):
    """libgomp has bound the process to one CPU when it loaded: started
    again, all its threads would share that CPU (every variable of
    openmp.py's list, so that mlid-batch's own list agrees)."""
    policy, spin, _, loads = _loaded("mlid-batch", **{variable: BOUND[variable]})
    assert (spin, loads) == (300000, 1)


def test_mlid_batch_stays_as_it_is_under_valgrind():
    """valgrind's preloaded libraries say it runs (a name alone here: the
    loader only warns that it cannot preload it)."""
    policy, spin, _, loads = _loaded("mlid-batch", LD_PRELOAD="/nonexistent/vgpreload_core.so")
    assert (spin, loads) == (300000, 1)


@pytest.mark.skipif(not os.path.exists(LOADER), reason=f"no {LOADER}")
def test_mlid_batch_run_by_the_loader():
    """The loader run as a program with mlid-batch its argument: then
    /proc/self/exe names the loader, and mlid-batch must not start that."""
    policy, spin, out, loads = _loaded("mlid-batch", [LOADER, *FRONT_ENDS["mlid-batch"]])
    assert (spin, loads) == (300000, 1) and out.startswith("usage: mlid-batch")


@pytest.mark.parametrize("args", [["--json", "", "no such deck.nml"], ["no such deck.nml"],
                                  ["a b", "--json", ""]])
def test_mlid_batch_started_again_says_the_same(args, tmp_path):
    """Its arguments (empty, with blanks) arrive as they were: the exit code
    and both streams as without starting again (an empty argument dropped
    or a deck's name split would name another file or none)."""
    runs = [subprocess.run([str(BIN / "mlid-batch"), *args], env=_environment(**extra),
                           capture_output=True, text=True, cwd=tmp_path)
            for extra in ({}, {"GOMP_SPINCOUNT": str(SPIN_COUNT)})]
    again, as_is = ((r.returncode, r.stdout, r.stderr) for r in runs)
    assert again[0] != 0 and again[2]
    assert again == as_is
