"""The C-8 Monte Carlo of report Table 8.1 (cases/c8_monte_carlo) with many
runs: sample sigma / Cramer-Rao sigma at the truth for each unknown and
input, and the wall time.

With N runs the relative standard error of a sample sigma is
1/sqrt(2(N - 1)): 2.2% for N = 1000, so the ratios should lie within 0.9-1.1
(4.5 standard errors) where the bound is tight.

    python benchmarks/monte_carlo_c8.py [N]
"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases" / "c8_monte_carlo"))
import c8_mc  # noqa: E402


def main(runs=1000):
    t0 = time.perf_counter()
    out = c8_mc.run(runs)
    wall = time.perf_counter() - t0
    print(f"C-8 Monte Carlo, {runs} runs per input, {wall:.1f} s (with the truth search)")
    print(f"  {'':<10}" + "".join(f"{n:>10}" for n in c8_mc.NAMES))
    for name in ("optimal", "doublet"):
        s = out[name]
        ratio = s["sample sigma"] / s["CR sigma"]
        print(f"  {name:<10}" + "".join(f"{v:10.3f}" for v in ratio)
              + f"   ({s['failed']} failed; standard error {1 / np.sqrt(2 * (s['runs'] - 1)):.1%})")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
