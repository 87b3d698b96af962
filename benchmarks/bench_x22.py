"""Speed of an X-22 extended-Kalman-filter iteration (cases/x22_vtol): 23
coefficients, 201 samples, 7 outputs, gusts in the outputs.  One iteration
is one likelihood evaluation with gradient and information; timed as
mlid.evaluate (median of 20), with and without the gain partials.
Target: under 20 ms per iteration.
"""

import os
import sys
import time
from pathlib import Path

# numpy's BLAS threads do no work here; keep them from competing with the
# core's OpenMP threads for the two cores
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import mlid  # noqa: E402
from timing import median  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases" / "x22_vtol"))
import x22  # noqa: E402


def main():
    data, _ = x22.record("multistep", "low")
    m = x22.model(x22.TRUTH, "low")
    for partials in (True, False):
        wall = median(lambda: mlid.evaluate(m, data, method="filter_error", partials=partials), 20)
        print(f"X-22 EKF iteration, 23 parameters, {len(data.t)} samples, "
              f"{'with' if partials else 'without'} gain partials: {1e3 * wall:.1f} ms "
              f"(target < 20 ms: {'met' if wall < 0.02 else 'NOT met'})")
    for partials in (True, False):
        t0 = time.perf_counter()
        res = x22.identify(data, "low", partials=partials)
        wall = time.perf_counter() - t0
        print(f"  whole fit from the equation-error start-up, {'with' if partials else 'without'}"
              f" partials: {1e3 * wall:.0f} ms, {res.iterations} iterations, converged "
              f"{res.converged}")


if __name__ == "__main__":
    main()
