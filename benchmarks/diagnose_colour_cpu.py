"""CPU per diagnosis, this tree against another installation (main), side
by side: each scenario kind of tests/scenarios.py plus this branch's AR(1)
null (phi 0.8) and out-of-library records (tests/test_diagnose_colour.py),
the two runs interleaved seed by seed, medians and their ratio (issue 47:
no kind over 2x main, the gust record <= 5 s).

    python benchmarks/diagnose_colour_cpu.py OTHER_PYTHON [seeds]

OTHER_PYTHON: the other tree's interpreter (e.g. /work/main/.venv/bin/python);
both import this tree's tests/ for the records.
"""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

TESTS = Path(__file__).resolve().parent.parent / "tests"
KINDS = ("null", "bias", "derivative", "gust", "delay", "scale", "lag", "nonlinear", "two",
         "sas", "nonlinear_lateral", "state_bias", "ar1_0.8", "mode", "dead_zone")
ONE = r"""
import json, sys, time
sys.path.insert(0, {tests!r})
import mlid, scenarios, test_diagnose_colour as T
kind, seed = {kind!r}, {seed}
if kind.startswith("ar1_"):
    m, d = T.ar1_null(seed, float(kind[4:]))
elif kind == "mode":
    m, d = T.structural_mode(seed)
elif kind == "dead_zone":
    m, d = T.dead_zone(seed)
else:
    m, d = scenarios.make(kind, seed)
t0 = time.process_time()
dg = mlid.diagnose(m, d)
print(json.dumps({{"cpu": time.process_time() - t0, "verdict": dg.verdict}}))
"""


def one(python, kind, seed):
    out = subprocess.run([python, "-c", ONE.format(tests=str(TESTS), kind=kind, seed=seed)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(other, seeds=3):
    print(f"{'kind':<18} {'this CPU s':>10} {'other CPU s':>11} {'ratio':>6}")
    for kind in KINDS:
        mine, theirs = [], []
        for seed in range(1, seeds + 1):
            mine.append(one(sys.executable, kind, seed)["cpu"])
            theirs.append(one(other, kind, seed)["cpu"])
        a, b = float(np.median(mine)), float(np.median(theirs))
        print(f"{kind:<18} {a:10.2f} {b:11.2f} {a / b if b > 0 else float('nan'):6.2f}",
              flush=True)


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 3)
