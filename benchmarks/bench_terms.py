"""Nonlinear-term candidates of the equation-based kinds (mlid.discrepancy.terms): how
many each model gets, and how long candidates() plus one score evaluation
per candidate takes, on one thread.

- the two seeded records of tests/test_terms.py (a short period with alpha^2
  missing from the pitching moment, a lateral six-DOF with |beta| beta
  missing from C_l): medians of 5 runs, and where the true term ranks;
- the real HFB-320 record (cases/hfb320, case 1's model and start values)
  in the six-DOF kind's longitudinal form, and the real ATTAS lateral
  record in the six-DOF kind (cases/attas_lateral/sixdof_vs_linear.py):
  counts, the five best scores and the time, after the base fit;
- the ATTAS coefficients by regression (cases/aero_coefficients, test case
  23: an equations model without states, linear in alpha, beta, the rates
  and the surfaces): count, the five best scores and the time;
- the full ten-state six-DOF model of tests/test_sixdof.py: its count.

    python benchmarks/bench_terms.py
"""

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")      # one thread: before the core is loaded
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import mlid  # noqa: E402
from mlid.design.signals import input_signal  # noqa: E402
from mlid.discrepancy import terms  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "cases" / "attas_lateral"))
sys.path.insert(0, str(REPO / "cases" / "aero_coefficients"))
import test_sixdof  # noqa: E402
import test_terms  # noqa: E402

DATA = REPO.parent / "shared" / "data"


def ranked(model, data):
    """The candidates, their scores best first, and the seconds taken."""
    t0 = time.perf_counter()
    cands = terms.candidates(model, data)
    t1 = time.perf_counter()
    scores = [c.score(data) for c in cands]
    t2 = time.perf_counter()
    order = np.argsort(scores)[::-1]
    return [cands[k] for k in order], [scores[k] for k in order], t1 - t0, t2 - t1


def show(title, data, base, truth=None, runs=1):
    times = []
    for _ in range(runs):
        cands, scores, tc, ts = ranked(base.model, data)
        times.append((tc, ts))
    tc, ts = np.median(times, axis=0)
    print(f"\n{title}: {len(cands)} candidates in "
          f"{len({c.equation for c in cands})} equations; candidates() {1e3 * tc:.0f} ms, "
          f"{len(cands)} scores {1e3 * ts:.0f} ms ({1e3 * ts / max(len(cands), 1):.1f} ms each)"
          + (f", median of {runs}" if runs > 1 else ""))
    if truth:
        rank = [(c.equation, c.label) for c in cands].index(truth) + 1
        print(f"  the true term ({truth[1]} in {truth[0]}) ranks {rank}")
    for c, s in zip(cands[:5], scores[:5]):
        print(f"  {s:10.1f}  {c.label:<28} {c.equation}")


def hfb320():
    """Case 1 of cases/hfb320/hfb320.nml in the six-DOF longitudinal form:
    the same coefficients, constants, fixed initial state and start values."""
    raw = np.loadtxt(DATA / "hfb320_1_10.asc")
    n = len(raw)
    u = np.column_stack([raw[:, 1], raw[:, 3], np.zeros((n, 4))])
    data = mlid.FlightData(raw[:, 0], u, raw[:, 4:11])
    V0, a0 = 106.023, 0.111685
    start = dict(zip(test_sixdof.LONG_PARAMS,
                     [5.67516e-3, 7.72612e-3, 0.674256, -0.318267, 0.260317, 5.37576,
                      4.98218e-2, 1.89182e-2, -0.498586, -25.8439, -0.990687]))
    model = mlid.SixDofModel(test_sixdof.CONSTANTS, ["u", "w", "q", "theta"],
                             {"V": "V", "alpha": "alpha", "theta": "theta", "q": "q",
                              "qdot": "qdot", "ax": "ax", "az": "az"},
                             inputs=["de", "F", "v", "p", "r", "phi"], params=start,
                             definitions=test_sixdof.LONG_DEFS, free=list(start),
                             x0=[V0 * np.cos(a0), V0 * np.sin(a0), -0.00332659, 0.104887])
    return data, mlid.fit(model, data, noise="diagonal", max_iter=30)


def attas():
    import sixdof_vs_linear as sv
    data = sv.sixdof_record()
    return data, mlid.fit(sv.sixdof_model(), data, noise="diagonal", max_iter=50)


def tc23():
    import aero_coefficients as ac
    data = ac.record("tc23")
    return data, mlid.fit(ac.model("tc23"), data, noise="diagonal", max_iter=50)


def main():
    show("short period, alpha^2 missing (tests/test_terms.py)", *test_terms.equations_record(),
         truth=("the q equation", "alpha^2"), runs=5)
    show("six-DOF lateral, |beta|*beta missing (tests/test_terms.py)",
         *test_terms.sixdof_record(), truth=("the Cl definition", "|beta|*beta"), runs=5)
    if (DATA / "hfb320_1_10.asc").is_file():
        data, base = hfb320()
        print(f"\n(HFB-320 six-DOF base fit: converged {base.converged}, cost {base.cost:.2f})")
        show("HFB-320 real record, six-DOF longitudinal form", data, base)
    if (DATA / "fAttasAilRud2.mat").is_file():
        data, base = attas()
        print(f"\n(ATTAS six-DOF base fit: converged {base.converged}, cost {base.cost:.2f})")
        show("ATTAS lateral real record, six-DOF (cases/attas_lateral)", data, base)
    if (DATA / "refs").is_dir():
        data, base = tc23()
        print(f"\n(ATTAS tc23 regression base fit: converged {base.converged}, "
              f"cost {base.cost:.2f})")
        show("ATTAS coefficients by regression, test case 23 (cases/aero_coefficients)", data,
             base)
    x0 = [100.0, 3.0, 9.0, 0.1, -0.05, 0.08, 0.2, 0.1, 0.5, 3000.0]
    model = test_sixdof.full_model(free=["CXa", "CZa", "Cma", "CYb", "Clb", "Cnb"], x0=x0)
    t = np.arange(201) * 0.05
    u = np.column_stack([input_signal("doublet", 0.03, 1.0, 1.0, 0.05, t.size)] * 3
                        + [np.full(t.size, 20000.0)])
    data, _ = mlid.simulate(model, t, u)
    cands = terms.candidates(model, data)
    print(f"\nfull ten-state six-DOF model (tests/test_sixdof.py): {len(cands)} candidates in "
          f"{len({c.equation for c in cands})} coefficients")


if __name__ == "__main__":
    main()
