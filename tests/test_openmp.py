"""How the core's OpenMP threads wait, in both front ends
(python/mlid/openmp.py, fortran/app/mlid_wait_policy.f90): passive when the
environment does not choose, the environment's choice otherwise.  What
libgomp took is what it displays when loaded (OMP_DISPLAY_ENV=verbose; the
last display, as mlid-batch starts itself again): GOMP_SPINCOUNT 0 is
passive waiting, OpenMP's default spins 300000 times."""

import os
import re
import subprocess
import sys

import pytest

from conftest import BIN, REPO

#: front end: the command that loads the core
FRONT_ENDS = {"python": [sys.executable, "-c", "import mlid; print(mlid.PASSIVE_WAIT)"],
              "mlid-batch": [str(BIN / "mlid-batch"), "--help"]}


def _loaded(front_end, **env_vars):
    """(libgomp's wait policy, its spin count, the process's output) with
    env_vars added to an environment that chooses nothing."""
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    env.update(env_vars, OMP_DISPLAY_ENV="verbose")
    out = subprocess.run(FRONT_ENDS[front_end], env=env, capture_output=True, text=True,
                         check=True, cwd=REPO)
    shown = out.stderr.split("OPENMP DISPLAY ENVIRONMENT BEGIN")
    if len(shown) < 2:
        pytest.skip("the core was built without OpenMP's runtime (libgomp)")
    policy = re.search(r"OMP_WAIT_POLICY = '(\w+)'", shown[-1]).group(1)
    spin = int(re.search(r"GOMP_SPINCOUNT = '(\d+)'", shown[-1]).group(1))
    return policy, spin, out.stdout


@pytest.mark.parametrize("front_end", FRONT_ENDS)
def test_threads_sleep_when_the_environment_does_not_choose(front_end):
    policy, spin, out = _loaded(front_end)
    assert (policy, spin) == ("PASSIVE", 0)
    if front_end == "python":
        assert out.split() == ["True"]
    else:
        assert out.startswith("usage: mlid-batch")     # the arguments kept on starting again


@pytest.mark.parametrize("front_end", FRONT_ENDS)
def test_the_environment_chooses_first(front_end):
    """OMP_WAIT_POLICY=active spins (libgomp: 30 billion times); a spin count
    of its own is kept too."""
    policy, spin, out = _loaded(front_end, OMP_WAIT_POLICY="active")
    assert policy == "ACTIVE" and spin > 300000
    assert _loaded(front_end, GOMP_SPINCOUNT="1000")[:2] == ("PASSIVE", 1000)
    if front_end == "python":
        assert out.split() == ["False"]
