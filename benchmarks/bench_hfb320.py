"""Speed of the HFB-320 fit on the real record (cases/hfb320): 11 coefficients,
601 samples, 7 outputs, nonlinear model.  In-process (the core called from
Python, median of 20) and end to end through mlid-batch (process start, deck,
data file, fit, report; median of 10).  Target: under 50 ms in-process; the
book's own software takes about 9 s (1.9 s per iteration) for the same fit.
Then the filter-error fit of the same record (extended Kalman filter, 20
parameters: case 3 of the deck), with and without the gain partials.
"""

import subprocess
import sys
import tempfile
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
    text = DECK.read_text()
    first = text[:text.index("&case", text.index("&case") + 1)]     # the output-error case
    with tempfile.TemporaryDirectory() as tmp:
        deck = Path(tmp) / "hfb320_oe.nml"
        deck.write_text(first.replace("../../../shared/data/hfb320_1_10.asc", str(DATA)))
        wall, _ = median(lambda: subprocess.run([str(batch), str(deck)], check=True,
                                                capture_output=True), 10)
    print(f"HFB-320 through mlid-batch (whole process): {1e3 * wall:.1f} ms")
    fe_case = mlid.read_deck(DECK)[2]
    wall, res = median(lambda: mlid.fit(fe_case.model, data, **fe_case.options()), 3)
    print(f"HFB-320 filter error (EKF), with gain partials, 20 parameters: {1e3 * wall:.0f} ms, "
          f"{res.iterations} iterations, {1e3 * wall / res.iterations:.1f} ms per iteration, "
          f"-J = {-res.cost:.1f}")
    # Without the partials the noise variances have no gradient: hold them at the
    # values just estimated and fit the 11 coefficients from the deck's start.
    theta = res.model.theta.copy()
    theta[:11] = fe_case.model.theta[:11]             # p = [C_D, C_L, C_m] comes first
    held = res.model.with_theta(theta).with_free(fe_case.model.free[:11])
    opts = dict(fe_case.options(), partials=False)
    opts.pop("bounds")
    for partials in (True, False):
        opts["partials"] = partials
        wall, r2 = median(lambda: mlid.fit(held, data, **opts), 3)
        print(f"  11 coefficients, noise held: {'with' if partials else 'without'} gain partials "
              f"{1e3 * wall:.0f} ms, {r2.iterations} iterations, "
              f"{1e3 * wall / r2.iterations:.1f} ms per iteration, -J = {-r2.cost:.1f}")

if __name__ == "__main__":
    main()
