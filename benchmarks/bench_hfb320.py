"""Speed of the HFB-320 fit on the real record (cases/hfb320): 11 coefficients,
601 samples, 7 outputs, nonlinear model.  In-process (the core called from
Python, median of 20) and end to end through mlid-batch (process start, deck,
data file, fit, report; median of 10).  Target: under 50 ms in-process; the
book's own software takes about 9 s (1.9 s per iteration) for the same fit.
Then the filter-error fit of the same record (extended Kalman filter, 20
parameters: case 3 of the deck), with and without the gain partials, and
against case 4, the same fit with the steady-state gain of the model
linearised at the start of the record: the two fits, and one evaluation of
cost, gradient and information at the start values, timed in turn round by
round (timing.interleaved_medians), so that the load of this shared machine
falls on both.
"""

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mlid
from timing import interleaved_medians

REPO = Path(__file__).resolve().parent.parent
DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"


def median(fn, n):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def main():
    if not DATA.is_file():
        print(f"skipped: real flight data not found at {DATA}")
        return
    case = mlid.read_deck(DECK)[0]
    data = case.record()
    wall, res = median(lambda: mlid.fit(case.model, data, **case.options()), 20)
    print(f"HFB-320 in-process: {1e3 * wall:.1f} ms total, {res.iterations} iterations, "
          f"{1e3 * wall / res.iterations:.2f} ms per iteration "
          f"(target < 50 ms: {'met' if wall < 0.05 else 'NOT met'})")
    batch = Path(sys.executable).parent / "mlid-batch"
    text = DECK.read_text()
    first = text[:text.index("&case", text.index("&case") + 1)]     # the output-error case
    with tempfile.TemporaryDirectory() as tmp:
        deck = Path(tmp) / "hfb320_oe.nml"
        deck.write_text(first.replace("../../../shared/data/hfb320_1_10.asc", str(DATA)))
        wall, _ = median(lambda: subprocess.run([str(batch), str(deck)], check=True,
                                                capture_output=True), 10)
    print(f"HFB-320 through mlid-batch (whole process): {1e3 * wall:.1f} ms")
    fe_case = mlid.read_deck(DECK)[2]
    wall, res = median(lambda: mlid.fit(fe_case.model, data, **fe_case.options()), 3)
    print(f"HFB-320 filter error (EKF), with gain partials, 20 parameters: {1e3 * wall:.0f} ms, "
          f"{res.iterations} iterations, {1e3 * wall / res.iterations:.1f} ms per iteration, "
          f"-J = {-res.cost:.1f}")
    # Without the partials the noise variances have no gradient: hold them at the
    # values just estimated and fit the 11 coefficients from the deck's start.
    theta = res.model.theta.copy()
    theta[:11] = fe_case.model.theta[:11]             # p = [C_D, C_L, C_m] comes first
    held = res.model.with_theta(theta).with_free(fe_case.model.free[:11])
    opts = dict(fe_case.options(), partials=False)
    opts.pop("bounds")
    for partials in (True, False):
        opts["partials"] = partials
        wall, r2 = median(lambda: mlid.fit(held, data, **opts), 3)
        print(f"  11 coefficients, noise held: {'with' if partials else 'without'} gain partials "
              f"{1e3 * wall:.0f} ms, {r2.iterations} iterations, "
              f"{1e3 * wall / r2.iterations:.1f} ms per iteration, -J = {-r2.cost:.1f}")

    steady_against_ekf(data)


def steady_against_ekf(data):
    """Cases 3 (EKF) and 4 (steady-state gain): whole fits and single
    evaluations, interleaved."""
    cases = mlid.read_deck(DECK)[2:4]
    assert [c.options().get("steady_state", False) for c in cases] == [False, True]
    results = [mlid.fit(c.model, data, **c.options()) for c in cases]
    fits = [lambda c=c: mlid.fit(c.model, data, **c.options()) for c in cases]
    evals = [lambda c=c: mlid.evaluate(c.model, data, **{k: v for k, v in c.options().items()
                                                        if k != "bounds"}) for c in cases]
    rounds = 5
    (t_ekf, t_ss), (e_ekf, e_ss) = (interleaved_medians(fits, rounds=rounds, n=1),
                                    interleaved_medians(evals, rounds=rounds, n=5))
    print(f"HFB-320 filter error, EKF (case 3) against the steady-state gain (case 4), "
          f"medians of {rounds} interleaved rounds:")
    for name, res, wall, ev in (("EKF", results[0], t_ekf, e_ekf),
                                ("steady", results[1], t_ss, e_ss)):
        print(f"  {name:<7}{res.iterations:3d} iterations, fit {1e3 * wall:7.0f} ms, "
              f"{1e3 * wall / res.iterations:6.1f} ms per iteration; one evaluation "
              f"(cost, gradient, information) {1e3 * ev:6.1f} ms; -J = {-res.cost:.2f}")
    per = (t_ss / results[1].iterations) / (t_ekf / results[0].iterations)
    print(f"  steady/EKF: fit {t_ss / t_ekf:.2f}, per iteration {per:.2f}, one evaluation "
          f"{e_ss / e_ekf:.2f}")


if __name__ == "__main__":
    main()
