"""Speed of the HFB-320 fit on the real record (cases/hfb320): 11 coefficients,
601 samples, 7 outputs, nonlinear model.  In-process (the core called from
Python, median of 20) and end to end through mlid-batch (process start, deck,
data file, fit, report; median of 10).  Target: under 50 ms in-process; the
book's own software takes about 9 s (1.9 s per iteration) for the same fit.
"""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import mlid

REPO = Path(__file__).resolve().parent.parent
DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"


def median(fn, n):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main():
    if not DATA.is_file():
        print(f"skipped: real flight data not found at {DATA}")
        return
    case = mlid.read_deck(DECK)[0]
    data = case.record()
    wall, res = median(lambda: mlid.fit(case.model, data, **case.options()), 20)
    print(f"HFB-320 in-process: {1e3 * wall:.1f} ms total, {res.iterations} iterations, "
          f"{1e3 * wall / res.iterations:.2f} ms per iteration "
          f"(target < 50 ms: {'met' if wall < 0.05 else 'NOT met'})")
    batch = Path(sys.executable).parent / "mlid-batch"
    wall, _ = median(lambda: subprocess.run([str(batch), str(DECK)], check=True,
                                            capture_output=True), 10)
    print(f"HFB-320 through mlid-batch (whole process): {1e3 * wall:.1f} ms")


if __name__ == "__main__":
    main()
