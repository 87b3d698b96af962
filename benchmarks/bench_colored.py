"""Cost of the coloured-residual correction of the Cramer-Rao bound
(fortran/mlid_colored.f90) against the fit it corrects, on the real HFB-320
record (cases/hfb320: output error, 11 coefficients, 7 outputs; and the
filter-error case, 20 parameters), measured side by side in one run.  The
correction is timed alone on the weighted sensitivities and residuals at the
estimate (mlid.evaluate); the fit's time includes its own correction.  Then
the size of the brief, N = 3000 samples, ny = 4, nf = 10, on synthetic
sensitivities and AR(1) residuals.

    python benchmarks/bench_colored.py
"""

from pathlib import Path

import numpy as np

import mlid
from mlid.core import colored_covariance, evaluate
from timing import median

REPO = Path(__file__).resolve().parent.parent
DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"


def correction_inputs(res, data, options):
    # evaluate takes the fit's options but not its prior or bounds
    options = {k: v for k, v in options.items() if k not in ("prior", "prior_weight", "bounds")}
    ev = evaluate(res.model, data, **options)
    return (ev["weighted_sensitivity"], data.y - ev["yhat"], res.covariance, ev["information"],
            ev["information_sensitivity"])


def hfb320(index, label, nfit):
    case = mlid.read_deck(DECK)[index]
    data, opts = case.record(), case.options()
    t_fit = median(lambda: mlid.fit(case.model, data, **opts), nfit)
    res = mlid.fit(case.model, data, **opts)
    args = correction_inputs(res, data, opts)
    t_col = median(lambda: colored_covariance(*args), 50)
    cov_c, lag = colored_covariance(*args)
    assert np.allclose(cov_c, res.covariance_corrected, rtol=1e-8)
    ny, nt, nf = args[0].shape
    print(f"HFB-320 {label} (N = {nt}, ny = {ny}, nf = {nf}, lag {lag}): fit {1e3 * t_fit:.1f} ms, "
          f"correction {1e3 * t_col:.2f} ms, ratio correction/fit {t_col / t_fit:.4f}")
    ratio = res.sigma_corrected / res.sigma
    print(f"  corrected/CR sigma: {ratio.min():.2f} to {ratio.max():.2f} "
          f"({', '.join(f'{n} {r:.2f}' for n, r in zip(res.names, ratio))})")


def brief_size():
    rng = np.random.default_rng(1)
    ny, nt, nf = 4, 3000, 10
    a = rng.standard_normal((ny, nt, nf)).cumsum(axis=1) / 30     # smooth, like sensitivities
    w = rng.standard_normal((nt, ny))
    v = np.empty_like(w)
    v[0] = w[0]
    for k in range(1, nt):
        v[k] = 0.8 * v[k - 1] + 0.6 * w[k]
    m = np.einsum("pif,pig->fg", a, a)
    cov = np.linalg.inv(m)
    for lag in (None, 100, 300):
        t = median(lambda: colored_covariance(a, v, cov, m, m, lag=lag), 10)
        _, used = colored_covariance(a, v, cov, m, m, lag=lag)
        print(f"N = {nt}, ny = {ny}, nf = {nf}, lag {used}{' (chosen)' * (lag is None)}: "
              f"{1e3 * t:.1f} ms")


def main():
    if DATA.is_file():
        hfb320(0, "output error", 10)
        hfb320(2, "filter error (EKF)", 3)
    else:
        print(f"skipped HFB-320: real flight data not found at {DATA}")
    brief_size()


if __name__ == "__main__":
    main()
