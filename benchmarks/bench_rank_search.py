"""Cost of the rank-deficient search (report §4.6 blocks 7-10) relative to a
plain Newton-Raphson iteration, on the 20-parameter M2/F3 filter-error fit
(cases/m2f3_gusts).  The search evaluates the cost once per candidate rank
(plus halvings); target: under 3x the time of a plain iteration.
"""

import sys
import time
from pathlib import Path

import numpy as np

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases" / "m2f3_gusts"))
import m2f3  # noqa: E402


def per_iteration(model, data, repeat=5, **opts):
    times, res = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = mlid.fit(model, data, method="filter_error", **opts)
        times.append((time.perf_counter() - t0) / max(res.iterations, 1))
    return float(np.median(times)), res


def main():
    data, _ = m2f3.record()
    free = list(m2f3.ELEMENT.values()) + ["f(5,5)", "q(1)"] + [f"r({i})" for i in range(1, 6)]
    truth = m2f3.model(m2f3.WT, free=free)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.1, 1.0))
    plain, r0 = per_iteration(start, data)
    ranked, r1 = per_iteration(start, data, rank_min=1)
    print(f"plain iteration:        {1e3 * plain:7.1f} ms ({r0.iterations} iterations)")
    print(f"rank search 1..20:      {1e3 * ranked:7.1f} ms ({r1.iterations} iterations, "
          f"final rank {r1.rank})")
    print(f"ratio {ranked / plain:.2f} (target < 3)")
    # the staged rule converges at each rank in turn: its cost is in the
    # number of iterations, each one a plain iteration with one rank
    # (iterations counts those of the accepted solution only, so time the whole fit)
    t0 = time.perf_counter()
    r2 = mlid.fit(start, data, method="filter_error", rank_min=17, rank_rule="staged")
    whole = time.perf_counter() - t0
    print(f"staged from rank 17:    whole fit {1e3 * whole:.0f} ms, accepted rank {r2.rank}; "
          f"plain whole fit {1e3 * plain * r0.iterations:.0f} ms")


if __name__ == "__main__":
    main()
