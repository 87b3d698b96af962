"""The discrepancy workflow on synthetic records with a hidden effect
(tests/scenarios.py), 20 seeds per scenario: how often the true effect is
named first and accepted, how often the null case accepts nothing, whether
the gap (cost) shrinks every time; and the time of a full diagnosis of a
20-parameter lateral case with every candidate family.  Targets: >= 90%,
>= 95%, always; under 5 s.
"""

import sys
import time
from pathlib import Path

import numpy as np

import mlid
from mlid.diagnose import FAMILIES

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import scenarios  # noqa: E402


def named_first(diag, expected):
    if not diag.effects:
        return False
    exp = expected if isinstance(expected, list) else [expected]
    first = (diag.effects[0].family, diag.effects[0].name)
    ok = any(first[0] == f and (n is None or first[1] == n) for f, n in exp)
    if isinstance(expected, list):         # two effects: both found
        found = {(e.family, e.name) for e in diag.effects}
        ok = ok and all((f, n) in found for f, n in exp)
    return ok


def main(seeds=20):
    for sc in scenarios.SCENARIOS:
        hits, shrink, times = 0, 0, []
        for seed in range(1, seeds + 1):
            model, data = scenarios.make(sc, seed)
            t0 = time.perf_counter()
            d = mlid.diagnose(model, data)
            times.append(time.perf_counter() - t0)
            if sc == "null":
                hits += not d.effects
            else:
                hits += named_first(d, scenarios.EXPECTED[sc])
            shrink += d.fit.cost <= d.base.cost
        target = 0.95 if sc == "null" else 0.90
        print(f"{sc:<10} {'nothing accepted' if sc == 'null' else 'named first':<17} "
              f"{hits}/{seeds} ({'met' if hits >= target * seeds else 'NOT met'}), gap shrank "
              f"{shrink}/{seeds}, median {np.median(times):.2f} s")
    # a 20-parameter lateral case: the 11 derivatives, Y_p, 4 initial states, 4 biases
    model, data = scenarios.make("gust", 1)
    model = model.with_free(list(model.free) + ["f(3,1)"] + [f"x0({i})" for i in range(1, 5)]
                            + [f"bias({i})" for i in range(1, 5)])
    t0 = time.perf_counter()
    d = mlid.diagnose(model, data)
    wall = time.perf_counter() - t0
    print(f"20-parameter lateral case ({len(d.base.names)} free), "
          f"{len(FAMILIES)} candidate families, "
          f"{len(d.rounds)} rounds: {wall:.2f} s (target < 5 s: {'met' if wall < 5 else 'NOT met'})")


if __name__ == "__main__":
    main()
