"""Filter error: the steady-state gain against the time-varying one, per
iteration (one evaluation of the cost, gradient and information matrix, gain
partials included), measured side by side.

  - the 24-parameter lateral case of cases/dhc2_turbulence (2 states,
    5 outputs, 601 samples, continuous process noise on both rate equations),
    the issue's target: steady <= 0.5x time-varying;
  - the M2/F3 case of cases/m2f3_gusts (5 states, 20 parameters, 401 samples).

    python benchmarks/bench_filter_error.py
"""

import os
import sys
from pathlib import Path

import numpy as np

import mlid
from timing import interleaved_medians

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "cases" / "dhc2_turbulence"))
sys.path.insert(0, str(HERE.parent / "cases" / "m2f3_gusts"))
import dhc2  # noqa: E402
import m2f3  # noqa: E402


def dhc2_problem():
    data, realised = dhc2.record()
    f, g, ay, bx, bias, sigma = dhc2.start()
    model = dhc2.model(f, g, ay, bx, bias, sigma, 1e-3 * np.var(data.y, axis=0))
    return model, data, {"process_noise": "continuous_sd"}


def m2f3_problem():
    data = m2f3.record()[0]
    free = list(m2f3.ELEMENT.values()) + ["f(5,5)", "q(1)"] + [f"r({i})" for i in range(1, 6)]
    return m2f3.model(m2f3.start_values(), free=free), data, {}


def main():
    print(f"threads: OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    for name, (model, data, extra) in [("DHC-2-like lateral", dhc2_problem()),
                                       ("M2/F3 with gusts", m2f3_problem())]:
        calls = [lambda s=s: mlid.evaluate(model, data, method="filter_error", steady_state=s,
                                           **extra) for s in (False, True)]
        tv, ss = interleaved_medians(calls, rounds=5, n=5)
        nf = int(model.free_mask.sum())
        print(f"{name}: {nf} free parameters, {data.nt} samples, {model.nx} states; per iteration "
              f"time-varying {tv * 1e3:.2f} ms, steady-state {ss * 1e3:.2f} ms, ratio {ss / tv:.2f}")


if __name__ == "__main__":
    main()
