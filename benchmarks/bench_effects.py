"""Speed of one fit of each structural effect of mlid.discrepancy.effects (issue 16 item 5)
on the discrepancy scenarios' lateral record (400 samples, 11 base
parameters), from the output-error fit without the effect: wall and CPU time
(median of 20 fits) and iterations.  Run with OMP_NUM_THREADS=1 for one
thread.  The golden-section searches these replace took 18+ whole fits each.

The 'lag' scenario's sensor (tests/scenarios.py) is integrated with phi held
over each sample interval, which mlid's inputs-linear-between-samples model
reads as half a sample more lag: wn comes out near 13.6 rad/s, not 15, even
without noise (measured); tests/test_effects.py builds its lag truths with
mlid's own convention and recovers 15 rad/s within 3 sigma.
"""

import sys
import time
from pathlib import Path

import numpy as np

import mlid
from mlid.discrepancy import effects

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import scenarios as sc  # noqa: E402

CASES = [   # (name, scenario, builder)
    ("first-order lag on phi", "lag", lambda m, d: effects.sensor_lag(m, d, "phi")),
    ("second-order lag on phi", "lag", lambda m, d: effects.sensor_lag(m, d, "phi", order=2)),
    ("scale factor on p", "scale", lambda m, d: effects.scale_factor(m, d, "p")),
    ("delay on delta_a", "delay", lambda m, d: effects.input_delay(m, d, "delta_a")),
    ("gust on beta (filter error)", "gust", lambda m, d: effects.gust(m, d, "beta", tau=0.25)),
]


def main(repeat=20, seed=0):
    print(f"{'effect':30s} {'params':>6s} {'iter':>4s} {'wall ms':>8s} {'cpu ms':>7s}  value")
    for name, scenario, build in CASES:
        model, data = sc.make(scenario, seed)
        ext = build(mlid.fit(model, data).model, data)
        walls, cpus = [], []
        for _ in range(repeat):
            w, c = time.perf_counter(), time.process_time()
            res = mlid.fit(ext.model, ext.data, **ext.options)
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c)
        shown = ", ".join(f"{q} {v:.4g} +- {s:.2g} {u}" for q, v, s, u, _ in ext.value(res))
        print(f"{name:30s} {len(res.names):6d} {res.iterations:4d} {1e3 * np.median(walls):8.1f} "
              f"{1e3 * np.median(cpus):7.1f}  {shown}")


if __name__ == "__main__":
    main()
