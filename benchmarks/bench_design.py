"""Speed of the optimal input design (cases/c8_input_design): the C-8
four-state model of §8.2 with five unknowns, T = 4 s, energy 58: mu_max and
the optimal input by the operator method (median of 5).  Target: under 0.5 s.
Also the amplitude-limited design (|u| <= the optimal's peak, 0.1 s cells).
"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases" / "c8_monte_carlo"))
import c8_longitudinal as c8  # noqa: E402  the model and the reading of its noise line


def main():
    d = c8.design()
    for cells in (100, 200):
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            inp = d.optimal_input(4.0, 58.0, cells=cells)
            times.append(time.perf_counter() - t0)
        wall = float(np.median(times))
        print(f"C-8 four-state, 5 unknowns, T = 4 s, {cells}+{2 * cells} cells: "
              f"{1e3 * wall:.0f} ms (target < 500 ms: {'met' if wall < 0.5 else 'NOT met'}); "
              f"mu {inp.mu:.1f}, tr M {inp.summary['trace']:.4g}")
    peak = float(np.max(np.abs(inp.u)))
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        sq = d.amplitude_limited(4.0, peak, 0.1)
        times.append(time.perf_counter() - t0)
    print(f"amplitude-limited, |u| <= {peak:.2f}, 40 cells of 0.1 s: "
          f"{1e3 * float(np.median(times)):.1f} ms; tr M {sq.summary['trace']:.4g} "
          f"(the energy-optimal input scaled to that peak: "
          f"{np.trace(d.information(4.0, inp.u)):.4g})")


if __name__ == "__main__":
    main()
