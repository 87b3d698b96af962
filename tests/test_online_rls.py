"""Recursive least squares (issue 45 item 2; fortran/estimation/online/
mlid_rls.f90, mlid.online.rls): the textbook software's RLS on test case
23's six aerodynamic regressions (refs/recursive/ref_tc23_RLS.txt, every
setting its header's), batch least squares as a second implementation,
forgetting that tracks a change, and a covariance bound that stops wind-up."""

import numpy as np
import pytest

import mlid
from conftest import REPO

REFS = REPO.parent / "shared" / "data" / "refs" / "recursive"
needs_refs = pytest.mark.skipif(not (REFS / "data_tc23_RLS.csv").is_file(),
                                reason="the recursive references are not in ../shared")

#: The six regressions of test case 23, in the reference header's words.
TC23 = {"CD": ["CD0", "CDal"], "CL": ["CL0", "CLal"], "Cm": ["Cm0", "Cmal", "Cmq", "Cmde"],
        "CY": ["CY0", "CYbe"], "Cl": ["Cl0", "Clbe", "Clp", "Clr", "Clda"],
        "Cn": ["Cn0", "Cnbe", "Cnp", "Cnr", "Cndr"]}
#: The regressor behind each parameter's suffix.
REGRESSOR = {"0": None, "al": "al", "be": "be", "q": "qn", "p": "pn", "r": "rn",
             "de": "de", "da": "da", "dr": "dr"}


def _regressors(data, names):
    cols = []
    for n in names:
        key = REGRESSOR[n[2:]]
        cols.append(np.ones(len(data)) if key is None else data[key].to_numpy())
    return np.column_stack(cols)


def _reference_finals():
    out, rows = {}, False
    for line in (REFS / "ref_tc23_RLS.txt").read_text().splitlines():
        if line.startswith("# [final]"):
            rows = True
        elif line.startswith("#"):
            rows = rows and not line.startswith("# [")
        elif rows and line.split():
            name, final, sigma = line.split()[:3]
            out[name] = (float(final), float(sigma))
    return out


@needs_refs
def test_tc23_rls_is_the_textbooks_sample_by_sample():
    """lambda = 1, P0 = 1e6 I (Cm: 1e7 I), theta0 = 0 (the header's
    settings): every estimate at every sample equals the reference's
    history within 1e-6 of the parameter's final size (measured: 2.1e-9 at
    the worst, the first samples; 1.1e-10 after the first 20%), the finals
    its [final] values to 1e-9 relative (measured 4.7e-11).  sigma: ours
    weighs the a-posteriori residuals of each step, the reference's (LS_Stat)
    the residuals of the final estimate over the record: within 5%
    (measured 0.4-3.4% below)."""
    import pandas as pd
    data = pd.read_csv(REFS / "data_tc23_RLS.csv")
    hist = pd.read_csv(REFS / "hist_tc23_RLS.csv")
    finals = _reference_finals()
    for z, names in TC23.items():
        est = mlid.online.rls(_regressors(data, names), data[z].to_numpy(), names=names,
                              t=data["t"].to_numpy(), p0=1e7 if z == "Cm" else 1e6)
        ref = hist[names].to_numpy()
        scale = np.abs(ref[-1])
        assert np.max(np.abs(est.estimates - ref) / scale) < 1e-6, z
        for j, n in enumerate(names):
            value, sigma = finals[n]
            assert est.final[n] == pytest.approx(value, rel=1e-9, abs=1e-12), n
            assert est.sigma[-1, j] == pytest.approx(sigma, rel=0.05), n


def test_rls_without_forgetting_is_batch_least_squares():
    """With lambda = 1 and a vague start the last estimate is the batch
    least-squares solution (numpy's lstsq, a second implementation), up to
    the start's weight 1/P0; sigma its sqrt(s2 diag inv(X'X)) within 5%."""
    rng = np.random.default_rng(3)
    X = np.column_stack([np.ones(800), rng.standard_normal(800), np.sin(0.02 * np.arange(800))])
    y = X @ [0.3, -1.2, 2.0] + 0.05 * rng.standard_normal(800)
    est = mlid.online.rls(X, y, p0=1e8)
    ls, res, *_ = np.linalg.lstsq(X, y, rcond=None)
    np.testing.assert_allclose(est.estimates[-1], ls, rtol=1e-7)
    s2 = res[0] / (800 - 3)
    np.testing.assert_allclose(est.sigma[-1], np.sqrt(s2 * np.diag(np.linalg.inv(X.T @ X))),
                               rtol=0.05)


def test_forgetting_tracks_a_halved_parameter():
    """b halves at sample 1000 of 2000: with lambda = 0.98 (memory about 50
    samples) the estimate is within 2% of the new value 200 samples later;
    without forgetting it stays near the average of the two."""
    rng = np.random.default_rng(5)
    n = 2000
    X = np.column_stack([np.ones(n), rng.standard_normal(n)])
    b = np.where(np.arange(n) < 1000, -2.0, -1.0)
    y = 0.5 + b * X[:, 1] + 0.01 * rng.standard_normal(n)
    tracked = mlid.online.rls(X, y, forgetting=0.98).estimates[:, 1]
    plain = mlid.online.rls(X, y).estimates[:, 1]
    assert abs(tracked[1200] + 1.0) < 0.02 and abs(tracked[999] + 2.0) < 0.02
    assert abs(plain[-1] + 1.5) < 0.05


def test_a_covariance_bound_stops_wind_up_when_the_excitation_stops():
    """The regressor goes to zero after sample 300: with lambda = 0.95, P
    grows as 0.95^-k (sigma of the slope by e^(0.05 k)); with p_max the
    division pauses and sigma stays bounded; the estimates agree."""
    rng = np.random.default_rng(7)
    x = np.where(np.arange(1000) < 300, rng.standard_normal(1000), 0.0)
    X = np.column_stack([np.ones(1000), x])
    y = 1.0 + 3.0 * x + 0.01 * rng.standard_normal(1000)
    free = mlid.online.rls(X, y, forgetting=0.95)
    bounded = mlid.online.rls(X, y, forgetting=0.95, p_max=10.0)
    assert free.sigma[-1, 1] > 1e6 * free.sigma[299, 1]
    assert bounded.sigma[-1, 1] < 1e3 * bounded.sigma[299, 1]
    assert bounded.final["theta2"] == pytest.approx(3.0, abs=0.01)


@pytest.mark.parametrize("kwargs, words", [
    (dict(forgetting=1.5), "the forgetting factor must be in (0, 1]"),
    (dict(forgetting=0.0), "the forgetting factor must be in (0, 1]"),
    (dict(p0=-1.0), "P0 (the start covariance"),
    (dict(p_max=-1.0), "the covariance bound p_max must be >= 0"),
    (dict(theta0=[0.0]), "theta0 must hold one start value per regressor (2)"),
    (dict(names=["a"]), "1 names for 2 regressors"),
])
def test_bad_settings_one_line(kwargs, words):
    X = np.column_stack([np.ones(10), np.arange(10.0)])
    with pytest.raises(mlid.InputError, match=None) as err:
        mlid.online.rls(X, np.arange(10.0), **kwargs)
    assert words in str(err.value) and "\n" not in str(err.value)
