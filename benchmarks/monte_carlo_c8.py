"""Monte Carlo of the C-8 case: 200 seeded identifications (the fit loop runs
in the Fortran core).  Checks the sample standard deviation of each estimate
against the mean Cramer-Rao sigma (target: within 20%) and reports the time.

With N = 200 runs the relative standard error of a sample standard
deviation is 1/sqrt(2(N-1)) = 5.0%, so 20% is four standard errors.
"""

import sys
import time
from pathlib import Path

import numpy as np

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import C8_STD, c8_record, c8_start, c8_truth  # noqa: E402


def main(runs=200):
    data = c8_record()
    t0 = time.perf_counter()
    mc = mlid.monte_carlo(c8_truth(), c8_start(), data.t, data.u, C8_STD, runs=runs, seed=1)
    wall = time.perf_counter() - t0
    ok = mc["status"] == 0
    est, sig = mc["estimates"][ok], mc["sigma"][ok]
    print(f"{runs} runs in {wall:.3f} s ({1e3 * wall / runs:.2f} ms per identification), "
          f"{ok.sum()} succeeded, mean iterations {mc['iterations'][ok].mean():.1f}")
    print(f"{'parameter':<10}{'truth':>10}{'mean est':>11}{'sample sd':>11}{'mean CR sd':>11}"
          f"{'ratio':>8}")
    worst = 0.0
    for k, name in enumerate(mc["names"]):
        sd, cr = est[:, k].std(ddof=1), sig[:, k].mean()
        worst = max(worst, abs(sd / cr - 1))
        print(f"{name:<10}{mc['truth'][k]:10.4f}{est[:, k].mean():11.4f}{sd:11.5f}{cr:11.5f}"
              f"{sd / cr:8.3f}")
    print(f"largest |sample sd / CR sd - 1| = {worst:.3f}: "
          f"{'within' if worst < 0.2 else 'OUTSIDE'} 20%")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
