"""Monte Carlo of the M2/F3 filter-error identification (cases/m2f3_gusts):
100 seeded records with gusts, each fitted by filter-error maximum
likelihood (13 derivatives, gust pole and intensity, 5 measurement-noise
variances: 20 parameters).  Target: the sample standard deviation of each
estimate within 25% of the mean Cramer-Rao sigma.

With N = 100 runs a sample sigma has a relative standard error of
1/sqrt(2(N-1)) = 7.1%, so 25% is 3.5 standard errors.
"""

import sys
import time
from pathlib import Path

import numpy as np

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases" / "m2f3_gusts"))
import m2f3  # noqa: E402


def main(runs=100):
    data, _ = m2f3.record()
    free = list(m2f3.ELEMENT.values()) + ["f(5,5)", "q(1)"] + [f"r({i})" for i in range(1, 6)]
    truth = m2f3.model(m2f3.WT, free=free)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.1, 1.0))
    t0 = time.perf_counter()
    mc = mlid.monte_carlo(truth, start, data.t, data.u, runs=runs, seed=1000,
                          method="filter_error")
    wall = time.perf_counter() - t0
    ok = mc["status"] == 0
    est, sig = mc["estimates"][ok], mc["sigma"][ok]
    print(f"{runs} filter-error identifications in {wall:.2f} s "
          f"({1e3 * wall / runs:.1f} ms each), {ok.sum()} succeeded, "
          f"mean iterations {mc['iterations'][ok].mean():.1f}")
    print(f"{'parameter':<10}{'truth':>11}{'mean est':>11}{'sample sd':>11}{'mean CR sd':>11}"
          f"{'ratio':>8}")
    worst = 0.0
    for k, name in enumerate(mc["names"]):
        sd, cr = est[:, k].std(ddof=1), sig[:, k].mean()
        worst = max(worst, abs(sd / cr - 1))
        print(f"{name:<10}{mc['truth'][k]:11.4g}{est[:, k].mean():11.4g}{sd:11.4g}{cr:11.4g}"
              f"{sd / cr:8.3f}")
    print(f"largest |sample sd / CR sd - 1| = {worst:.3f}: "
          f"{'within' if worst < 0.25 else 'OUTSIDE'} 25%")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100)
