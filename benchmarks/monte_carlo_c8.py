"""Monte Carlo of the C-8 case: 200 seeded identifications (the fit loop runs
in the Fortran core).  Checks the sample standard deviation of each estimate
against the mean Cramer-Rao sigma (target: within 20%) and reports the time.

With N = 200 runs the relative standard error of a sample standard
deviation is 1/sqrt(2(N-1)) = 5.0%, so 20% is four standard errors.
"""

import sys
import time
from pathlib import Path


import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mc_table import print_table  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import C8_STD, c8_record, c8_start, c8_truth  # noqa: E402


def main(runs=200):
    data = c8_record()
    t0 = time.perf_counter()
    mc = mlid.monte_carlo(c8_truth(), c8_start(), data.t, data.u, C8_STD, runs=runs, seed=1)
    wall = time.perf_counter() - t0
    print_table(mc, runs, wall, 0.2)


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
