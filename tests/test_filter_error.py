"""Filter-error maximum likelihood (Kalman filter with process noise):
exact gradient against finite differences, a second implementation of the
filter in numpy, the output-error limit, Monte Carlo against Cramer-Rao."""

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import finite_difference

DT = 0.05
NT = 300


GUST_TIES = {"f(1,3)": "f(1,2)", "f(2,3)": "f(2,2)"}


def gust_model(free=(), q=0.05, r=(1e-3, 2e-3), s12=0.0, ties=GUST_TIES):
    # Two body states and a first-order gust x3 that enters like x2 (the
    # M2/F3 structure in miniature: x2 ~ sideslip, x3 ~ gust, output 2 is the
    # air-relative x2 + x3).
    F = np.array([[-1.0, -3.0, -3.0], [0.4, -0.8, -0.8], [0.0, 0.0, -1.5]])
    G = np.array([[2.0], [0.5], [0.0]])
    H = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    return mlid.LinearModel(F, G, H, Gamma=[[0.0], [0.0], [1.0]], q=[q], r=list(r),
                            S=[[0.0, s12]], free=list(free), ties=ties)


def record(model, seed=3):
    t = np.arange(NT) * DT
    u = input_signal("3211", 1.0, 0.5, 0.3, DT, NT)[:, None]
    return mlid.simulate(model, t, u, seed=seed)[0]


FREE = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "f(3,3)", "r(1)", "r(2)", "h(2,2)", "x0(1)",
        "bias(2)", "s(1,2)"]
BODY = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)"]
GUST = ["f(3,3)", "q(1)", "r(1)", "r(2)"]


@pytest.mark.parametrize("steady", [False, True])
def test_gradient_matches_finite_differences(steady):
    _check_gradient(gust_model(FREE + ["q(1)"], s12=0.003),
                    {"method": "filter_error", "steady_state": steady})


def _check_gradient(model, opts):
    """The analytic gradient against 5-point finite differences of the cost."""
    data = record(model)
    ev = mlid.evaluate(model, data, **opts)
    fd = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), data, **opts)["cost"],
                           model.theta, model.free_indices(), rel=1e-4, floor=1e-1,
                           five_point=True)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1.0)
    assert np.max(rel) < 1e-6, dict(zip(model.free_names(), rel))


def test_gradient_with_state_feedback():
    """A feedback K (the SAS) and a direct input term D: every partial of the
    closed-loop F + G K and H + D K, gain partials included."""
    m = gust_model()
    model = mlid.LinearModel(m.F, m.G, m.H, D=[[0.1], [0.0]], K=[[0.2, -0.1, 0.0]], Gamma=m.Gamma,
                             q=m.q, r=m.r, S=[[0.0, 0.003]], ties=GUST_TIES,
                             free=BODY + ["k(1,1)", "k(1,2)", "d(1,1)", "h(2,2)", "q(1)"])
    _check_gradient(model, {"method": "filter_error", "partials": True})


def _rk4(f, x, ua, ub, h):
    um = 0.5 * (ua + ub)
    k1 = f(x, ua)
    k2 = f(x + 0.5 * h * k1, um)
    k3 = f(x + 0.5 * h * k2, um)
    k4 = f(x + h * k3, ub)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def numpy_filter(m, data, steady=False):
    """The same filter written out directly: predict, update, cost; the
    time-varying filter from P(1|0) = diag(m.p0)."""
    nu, nw = m.nu, m.nw
    Q, R, S = np.diag(m.q), np.diag(m.r), m.S

    def f(x, uw):
        return m.F @ x + m.G @ uw[:nu] + m.Gamma @ uw[nu:]

    h = data.t[1] - data.t[0]
    phi = np.column_stack([_rk4(f, e, np.zeros(nu + nw), np.zeros(nu + nw), h)
                           for e in np.eye(m.nx)])
    W = np.column_stack([_rk4(f, np.zeros(m.nx), np.r_[np.zeros(nu), e], np.r_[np.zeros(nu), e], h)
                         for e in np.eye(nw)])

    def update(P):
        B = m.H @ P @ m.H.T + R
        Bi = np.linalg.inv(B)
        K = P @ m.H.T @ Bi
        return B, Bi, K, P - K @ m.H @ P

    def predict(Pp, K, Bi):
        A = phi @ K @ S.T @ W.T
        return phi @ Pp @ phi.T + W @ (Q - S @ Bi @ S.T) @ W.T - A - A.T

    P = np.diag(m.p0)
    if steady:
        for _ in range(5000):
            B, Bi, K, Pp = update(P)
            P = predict(Pp, K, Bi)
    x, w, cost, yhat = m.x0.copy(), np.zeros(nw), 0.0, []
    for j in range(data.nt):
        if j:
            x = _rk4(f, x, np.r_[data.u[j - 1], w], np.r_[data.u[j], w], h)
            if not steady:
                P = predict(Pp, K, Bi)
        B, Bi, K, Pp = update(P)
        yh = m.H @ x + m.D @ data.u[j] + m.bias
        v = data.y[j] - yh
        cost += 0.5 * (v @ Bi @ v + np.log(np.linalg.det(B)))
        yhat.append(yh)
        x = x + K @ v
        w = S @ Bi @ v
    return cost, np.array(yhat)


@pytest.mark.parametrize("steady", [False, True])
def test_filter_agrees_with_numpy_implementation(steady):
    model = gust_model(s12=0.004)
    data = record(model)
    ev = mlid.evaluate(model, data, method="filter_error", steady_state=steady)
    cost, yhat = numpy_filter(model, data, steady)
    assert ev["cost"] == pytest.approx(cost, rel=1e-10)
    np.testing.assert_allclose(ev["yhat"], yhat, rtol=0, atol=1e-10)


def test_no_process_noise_is_output_error():
    model = gust_model(["f(1,1)", "g(1,1)"], q=0.0)
    data = record(model.with_theta(gust_model(q=0.05).theta))
    fe = mlid.evaluate(model, data, method="filter_error")
    oe = mlid.evaluate(model, data)
    np.testing.assert_allclose(fe["yhat"], oe["yhat"], rtol=0, atol=1e-13)
    v = data.y - oe["yhat"]
    expected = 0.5 * (np.sum(v**2 / model.r) + data.nt * np.sum(np.log(model.r)))
    assert fe["cost"] == pytest.approx(expected, rel=1e-12)


def test_filter_error_fit_and_monte_carlo_sigma():
    # Reduced version of the M2/F3 Monte Carlo (benchmarks/monte_carlo_m2f3.py,
    # 100 runs).  40 runs: the sample sigma has a 11% standard error, so a 35%
    # band is three standard errors.
    truth = gust_model(BODY + GUST)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.25, 1.0))
    data = record(truth, seed=11)
    res = mlid.fit(start, data, method="filter_error")
    assert res.converged
    z = (res.estimate - truth.theta[truth.free_indices()]) / res.sigma
    assert np.all(np.abs(z) < 3.5), z
    mc = mlid.monte_carlo(truth, start, data.t, data.u, runs=40, seed=200, method="filter_error")
    ok = mc["status"] == 0
    assert ok.sum() >= 38
    ratio = mc["estimates"][ok].std(axis=0, ddof=1) / mc["sigma"][ok].mean(axis=0)
    assert np.all(np.abs(ratio - 1) < 0.35), dict(zip(mc["names"], ratio))


def test_output_error_fails_where_filter_error_succeeds():
    truth = gust_model(BODY + GUST, q=0.5)
    data = record(truth, seed=5)
    oe = mlid.fit(truth.with_free(BODY), data)
    fe = mlid.fit(truth, data, method="filter_error")
    tr = truth.theta[truth.with_free(BODY).free_indices()]
    z_oe = np.abs((oe.estimate - tr) / oe.sigma)
    body = [fe.names.index(n) for n in BODY]          # by name: BODY's order in fe
    z_fe = np.abs((fe.estimate[body] - tr) / fe.sigma[body])
    assert np.max(z_oe) > 3 and np.max(z_fe) < 3, (z_oe, z_fe)


@pytest.mark.parametrize("change, match", [
    ({"q": [-0.1]}, r"q\(1\) must be >= 0"),
    ({"r": [0.0, 1e-3]}, r"r\(1\) must be > 0"),
])
def test_bad_noise_statistics(change, match):
    model = gust_model(["f(1,1)"])
    data = record(model)
    kw = dict(q=model.q, r=model.r)
    kw.update(change)
    bad = mlid.LinearModel(model.F, model.G, model.H, Gamma=model.Gamma, free=["f(1,1)"], **kw)
    with pytest.raises(mlid.InputError, match=match):
        mlid.fit(bad, data, method="filter_error")


def test_noise_covariance_not_positive_semidefinite():
    model = gust_model(q=1e-4, r=(1e-4, 1e-4), s12=0.1)
    with pytest.raises(mlid.InputError, match="not positive semi-definite"):
        record(model)


def test_nonuniform_sampling_rejected_by_filter():
    model = gust_model(["f(1,1)"])
    data = record(model)
    data.t[5:] += 0.01
    with pytest.raises(mlid.InputError, match="uniform sampling"):
        mlid.fit(model, data, method="filter_error")


def test_bad_ties():
    with pytest.raises(mlid.InputError, match="both free and tied"):
        gust_model(["f(1,3)"])


def test_gust_time_constant_of_wrong_sign():
    model = gust_model(BODY)
    data = record(model)
    bad = model.with_theta(model.theta)
    bad.F[2, 2] = 0.5                      # an unstable "gust"
    with pytest.raises(mlid.InputError, match=r"gust state 3 .* wrong sign: f\(3,3\)"):
        mlid.fit(bad, data, method="filter_error")
