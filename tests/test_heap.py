"""The allocator's freed memory kept for the next fit (python/mlid/heap.py):
set on import on glibc, left alone with MLID_MALLOC=system, and a repeated
fit then takes no fresh pages from the system."""

import os
import subprocess
import sys

import pytest

from conftest import REPO

DECK = REPO / "cases" / "attas_lateral" / "attas_lat.nml"
needs_data = pytest.mark.skipif(not (REPO.parent / "shared" / "data").is_dir(),
                                reason="the real flight records (../shared/data) are not there")
glibc_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")

#: In a fresh interpreter: the setting, then the page faults a fit takes
#: once three fits have warmed the heap (the mean of four).
FAULTS = f"""
import resource, mlid
case = mlid.read_deck({str(DECK)!r})[0]
data, opts = case.record(), case.options()
for _ in range(3):
    mlid.fit(case.model, data, **opts)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(4):
    mlid.fit(case.model, data, **opts)
after = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
print(mlid.KEEPS_FREED_MEMORY, (after - before) / 4)
"""


def _run(malloc=None):
    env = {k: v for k, v in os.environ.items() if k != "MLID_MALLOC"}
    env["OMP_NUM_THREADS"] = "1"
    if malloc is not None:
        env["MLID_MALLOC"] = malloc
    out = subprocess.run([sys.executable, "-c", FAULTS], env=env, capture_output=True,
                         text=True, check=True, cwd=REPO)
    kept, faults = out.stdout.split()
    return kept == "True", float(faults)


@glibc_only
@needs_data
def test_a_repeated_fit_takes_no_fresh_pages():
    """ATTAS lateral (1,502 samples, 22 parameters): about 1,850 page faults a
    fit without the setting (measured, 7.5 MB of fresh pages), none with it;
    the bound leaves room for the interpreter's own."""
    kept, faults = _run()
    assert kept
    assert faults < 50


@glibc_only
@needs_data
def test_malloc_system_leaves_the_allocator_alone():
    kept, faults = _run("system")
    assert not kept
    assert faults > 200          # what the setting saves (so the first test can fail)
