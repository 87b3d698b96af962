"""The Cramer-Rao covariance corrected for coloured residuals (fortran/estimation/time_domain/mlid_colored.f90):
the white-noise identity, a straightforward O(N^2) NumPy double sum, the fit's
own numbers, and a Monte Carlo with AR(1) measurement noise."""

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from mlid.estimate.colored import colored_covariance
from mlid.estimate.evaluate import evaluate

# The C-8 short-period case (cases/c8_short_period): the report's values as the truth.
F0 = np.array([[-0.02, -32.2, 0, 33.74], [0, 0, 1, 0], [0.003, 0, -1.588, -0.562],
               [-0.004, 0, 1, -0.737]])
G0 = np.array([[0.0], [0.0], [-1.658], [0.005]])
FREE = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]
NAMES = {"f(3,3)": "M_q", "f(3,4)": "M_alpha", "f(4,4)": "Z_alpha", "g(3,1)": "M_delta",
         "g(4,1)": "Z_delta"}
STD = np.array([0.35355339, 0.0061706707, 0.0061706707, 0.0087266463])   # c8.nml
DT, NT, PHI = 0.02, 1000, 0.8
RUNS = 300


def _c8():
    truth = mlid.LinearModel(F0, G0, np.eye(4), free=FREE, names=NAMES)
    t = np.arange(NT) * DT
    u = input_signal("3211", 0.08, 1.0, 0.5, DT, NT).reshape(-1, 1)
    clean, _ = mlid.simulate(truth, t, u, noise_std=np.zeros(4))
    return truth, t, u, clean.y


def _ar1(rng, shape, phi):
    """Stationary AR(1) noise of unit variance along axis -2 (samples)."""
    w = rng.standard_normal(shape)
    e = np.empty_like(w)
    e[..., 0, :] = w[..., 0, :]
    for k in range(1, shape[-2]):
        e[..., k, :] = phi * e[..., k - 1, :] + np.sqrt(1 - phi**2) * w[..., k, :]
    return e


def _random_problem(rng, ny=2, nt=120, nf=3):
    s = rng.standard_normal((ny, nt, nf))
    q = rng.standard_normal((ny, ny))
    r = q @ q.T + ny * np.eye(ny)
    w = np.linalg.inv(r)
    a = np.einsum("pq,qif->pif", w, s)
    msens = np.einsum("pif,pig->fg", s, a)
    return a, r, msens


def test_white_identity():
    """Rvv(0) = R, Rvv(k) = 0 for k > 0: the bracket is Ms and Cov_c = M^-1,
    with and without a part of M the sensitivities do not make (a priori weight)."""
    rng = np.random.default_rng(3)
    a, r, msens = _random_problem(rng)
    rvv = np.zeros((6, 2, 2))
    rvv[0] = r
    for extra in (np.zeros((3, 3)), np.diag([5.0, 1.0, 2.0])):
        info = msens + extra
        cov = np.linalg.inv(info)
        cov_c, lag = colored_covariance(a, None, cov, info, msens, segment_starts=[1, 50],
                                        rvv=rvv)
        assert lag == 5
        np.testing.assert_allclose(cov_c, cov, rtol=1e-10, atol=1e-14 * np.abs(cov).max())
    # a non-zero Rvv(1) changes it: the identity is not vacuous
    rvv[1] = 0.3 * r
    cov_c, _ = colored_covariance(a, None, cov, info, msens, rvv=rvv)
    assert np.max(np.abs(cov_c - cov)) > 1e-3 * np.abs(cov).max()


def _double_sum(a, v, seg, lag):
    """Cov_c's bracket the plain way: Rvv(k) = (1/N) sum v(i) v(i+k)' within
    segments, then sum_i sum_j a(i)' w Rvv(i-j) a(j), |i-j| <= lag, within segments."""
    ny, nt, nf = a.shape
    bounds = list(zip(seg, list(seg[1:]) + [nt + 1]))
    rvv = np.zeros((lag + 1, ny, ny))
    for i0, i1 in bounds:
        x = v[:, i0 - 1:i1 - 1]
        for k in range(min(lag, x.shape[1] - 1) + 1):
            rvv[k] += x[:, :x.shape[1] - k] @ x[:, k:].T
    rvv /= nt
    b = np.zeros((nf, nf))
    for i0, i1 in bounds:
        for i in range(i0 - 1, i1 - 1):
            for j in range(i0 - 1, i1 - 1):
                k = abs(i - j)
                if k > lag:
                    continue
                rk = rvv[k] if i >= j else rvv[k].T        # Rvv(i-j), Rvv(-k) = Rvv(k)'
                b += (1 - k / (lag + 1)) * a[:, i, :].T @ rk @ a[:, j, :]
    return b


def test_against_numpy_double_sum():
    rng = np.random.default_rng(11)
    a, r, msens = _random_problem(rng)
    v = (_ar1(rng, (120, 2), 0.6) @ np.linalg.cholesky(r).T).T
    info = msens + np.eye(3)
    cov = np.linalg.inv(info)
    seg = [1, 50]
    for lag in (None, 0, 7):
        cov_c, used = colored_covariance(a, v.T, cov, info, msens, segment_starts=seg, lag=lag)
        if lag is not None:
            assert used == lag
        want = cov @ (info - msens + _double_sum(a, v, seg, used)) @ cov
        np.testing.assert_allclose(cov_c, want, rtol=1e-11, atol=1e-14 * np.abs(want).max())
    # the lag chosen from coloured residuals is more than the white-noise minimum
    assert used > 0


def test_fourier_bracket_with_odd_outputs_and_lags_beyond_a_manoeuvre():
    """The bracket is taken through the Fourier transform (outputs two to a
    transform, each manoeuvre zero-padded): three outputs, five parameters,
    manoeuvres of 30, 1 and 89 samples, lags up to and past the longest."""
    rng = np.random.default_rng(5)
    a, r, msens = _random_problem(rng, ny=3, nf=5)
    v = (_ar1(rng, (120, 3), 0.7) @ np.linalg.cholesky(r).T).T
    info = msens + np.eye(5)
    cov = np.linalg.inv(info)
    seg = [1, 31, 32]
    for lag in (1, 29, 60, 119):
        cov_c, used = colored_covariance(a, v.T, cov, info, msens, segment_starts=seg, lag=lag)
        want = cov @ (info - msens + _double_sum(a, v, seg, used)) @ cov
        np.testing.assert_allclose(cov_c, want, rtol=1e-11, atol=1e-14 * np.abs(want).max())


def test_bad_sizes():
    rng = np.random.default_rng(1)
    a, r, msens = _random_problem(rng)
    with pytest.raises(mlid.InputError, match="segment starts"):
        colored_covariance(a, np.zeros((120, 2)), msens, msens, msens, segment_starts=[2])
    with pytest.raises(mlid.InputError, match="residuals"):
        colored_covariance(a, np.zeros((100, 2)), msens, msens, msens)


def test_fit_reports_the_correction():
    """The fit's corrected covariance is the routine's on the sensitivities and
    residuals at the estimate, and both front ends' texts carry it."""
    truth, t, u, y = _c8()
    rng = np.random.default_rng(5)
    data = mlid.FlightData(t, u, y + STD * _ar1(rng, (NT, 4), PHI))
    res = mlid.fit(truth, data)
    ev = evaluate(res.model, data)
    cov_c, lag = colored_covariance(ev["weighted_sensitivity"], data.y - ev["yhat"],
                                    res.covariance, ev["information"],
                                    ev["information_sensitivity"])
    assert lag == res.colored_lag
    np.testing.assert_allclose(res.covariance_corrected, cov_c, rtol=1e-8)
    np.testing.assert_allclose(res.sigma_corrected, np.sqrt(np.diag(cov_c)), rtol=1e-8)
    assert "sigma col." in res.report()
    assert '"sigma_corrected"' in res.json()


@pytest.mark.parametrize("opts, converged, reason", [
    ({}, True, "tol_cost"),
    # the budget spent: the last full evaluation is the last step's
    ({"max_iter": 2}, False, "iteration limit"),
    ({"noise": "full", "max_iter": 3}, False, "iteration limit"),
    # no tolerance can be met: the fit ends on an iteration none of whose
    # trials lowers the cost, and its last full evaluation (the first trial's)
    # is not at the estimate it returns
    ({"tol_cost": 0.0, "tol_step": 0.0, "tol_grad": 0.0, "max_iter": 40}, False,
     "no cost decrease"),
    ({"method": "filter_error", "max_iter": 2}, False, "iteration limit"),
])
def test_fit_correction_is_at_the_estimate_however_the_fit_ends(opts, converged, reason):
    """The weighted sensitivities are made once, at the end of a fit, from
    what its last accepted evaluation kept: the corrected covariance is, to
    the bit, the routine's on evaluate's sensitivities and residuals at the
    estimate returned, whether the fit converged, ran out of iterations or
    stopped without a decrease."""
    truth, t, u, y = _c8()
    rng = np.random.default_rng(5)
    data = mlid.FlightData(t, u, y + STD * _ar1(rng, (NT, 4), PHI))
    if opts.get("method") == "filter_error":      # the noise statistics the filter needs
        truth = mlid.LinearModel(F0, G0, np.eye(4), free=FREE, names=NAMES, r=list(STD**2))
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.3, 1.0))
    res = mlid.fit(start, data, **opts)
    assert res.converged == converged and reason in res.reason
    ev = evaluate(res.model, data, **{k: v for k, v in opts.items() if k in ("noise", "method")})
    cov_c, lag = colored_covariance(ev["weighted_sensitivity"], data.y - ev["yhat"],
                                    res.covariance, ev["information"],
                                    ev["information_sensitivity"])
    assert lag == res.colored_lag
    np.testing.assert_array_equal(res.covariance_corrected, cov_c)
    assert not np.array_equal(res.covariance_corrected, res.covariance)


def test_monte_carlo_ar1_noise():
    """AR(1) measurement noise (phi = 0.8) on every output of the C-8 case,
    RUNS seeded records fitted by output error: the sample sigma of the
    estimates is about 3 times the mean Cramer-Rao sigma, and the mean
    corrected sigma is within 20% of it.  The relative standard error of a
    sample sigma from 300 runs is 1/sqrt(2*299) = 4.1%, so 20% is about 5
    standard errors; the CR sigma is off by more than 50%."""
    truth, t, u, y = _c8()
    rng = np.random.default_rng(2026)
    noise = STD * _ar1(rng, (RUNS, NT, 4), PHI)
    est, cr, col = [], [], []
    for r in range(RUNS):
        res = mlid.fit(truth, mlid.FlightData(t, u, y + noise[r]))
        est.append(res.estimate)
        cr.append(res.sigma)
        col.append(res.sigma_corrected)
    sample = np.std(est, axis=0, ddof=1)
    cr, col = np.mean(cr, axis=0), np.mean(col, axis=0)
    print("\nparameter  sample sigma  mean CR sigma  mean corrected sigma")
    for name, s, c, k in zip(res.names, sample, cr, col):
        print(f"{name:9s} {s:12.5f} {c:14.5f} {k:21.5f}")
    assert np.all(cr < 0.5 * sample), cr / sample
    assert np.all(np.abs(col / sample - 1) < 0.2), col / sample
