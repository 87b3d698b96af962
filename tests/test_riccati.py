"""The filter's steady-state covariance from the Riccati equation (structured
doubling, mlid_riccati) and continuous-time process noise (Van Loan): the
cost against a second implementation that solves the Riccati equation with
scipy and integrates the noise covariance by quadrature, and the gradient,
Stein-equation partials included, against finite differences."""

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

import mlid
from test_filter_error import FREE, _check_gradient, _rk4, gust_model, record


def second_filter(m, data, process_noise="held"):
    """The steady-state filter written out with scipy: P from
    solve_discrete_are (cross term W S), V = W Q W' for held noise or the
    quadrature of e^{As} Gamma Qc Gamma' e^{A's} for continuous noise."""
    nu, nw = m.nu, m.nw
    q = np.asarray(m.q, float)
    Q = np.diag(q**2 if process_noise == "continuous_sd" else q)
    R, S = np.diag(m.r), np.asarray(m.S, float)
    h = data.t[1] - data.t[0]

    def f(x, uw):
        return m.F @ x + m.G @ uw[:nu] + m.Gamma @ uw[nu:]

    phi = np.column_stack([_rk4(f, e, np.zeros(nu + nw), np.zeros(nu + nw), h)
                           for e in np.eye(m.nx)])
    W = np.column_stack([_rk4(f, np.zeros(m.nx), np.r_[np.zeros(nu), e], np.r_[np.zeros(nu), e], h)
                         for e in np.eye(nw)])
    if process_noise == "held":
        V, G = W @ Q @ W.T, W @ S
    else:
        gq = m.Gamma @ Q @ m.Gamma.T
        V = scipy.integrate.quad_vec(
            lambda s: scipy.linalg.expm(m.F * s) @ gq @ scipy.linalg.expm(m.F.T * s), 0, h,
            epsabs=1e-14, epsrel=1e-12)[0]
        G = np.zeros((m.nx, m.ny))
    P = scipy.linalg.solve_discrete_are(phi.T, m.H.T, V, R, s=G)
    B = m.H @ P @ m.H.T + R
    Bi = np.linalg.inv(B)
    K = P @ m.H.T @ Bi
    x, w, cost = m.x0.copy(), np.zeros(nw), 0.0
    for j in range(data.nt):
        if j:
            x = _rk4(f, x, np.r_[data.u[j - 1], w], np.r_[data.u[j], w], h)
        v = data.y[j] - (m.H @ x + m.D @ data.u[j] + m.bias)
        cost += 0.5 * (v @ Bi @ v + np.log(np.linalg.det(B)))
        x = x + K @ v
        w = S @ Bi @ v if process_noise == "held" else np.zeros(nw)
    return cost


@pytest.mark.parametrize("r", [(1e-3, 2e-3), (1e-11, 2e-12)])
def test_steady_state_cost_agrees_with_scipy(r):
    """Held noise correlated with the measurement noise; the second R makes
    the outputs nearly noise-free, where iterating the Riccati recursion to
    its fixed point took minutes."""
    model = gust_model(s12=0.0 if r[0] < 1e-6 else 0.004, r=r)
    data = record(model)
    ev = mlid.evaluate(model, data, method="filter_error", steady_state=True)
    assert ev["cost"] == pytest.approx(second_filter(model, data), rel=1e-9)


@pytest.mark.parametrize("kind", ["continuous", "continuous_sd"])
def test_continuous_noise_cost_agrees_with_quadrature(kind):
    model = gust_model(q=0.05 if kind == "continuous" else 0.2)
    data = record(gust_model())
    ev = mlid.evaluate(model, data, method="filter_error", steady_state=True, process_noise=kind)
    assert ev["cost"] == pytest.approx(second_filter(model, data, kind), rel=1e-9)


@pytest.mark.parametrize("kind", ["continuous", "continuous_sd"])
@pytest.mark.parametrize("steady", [False, True])
def test_continuous_noise_gradient_matches_finite_differences(kind, steady):
    free = [n for n in FREE if n != "s(1,2)"] + ["q(1)", "f(2,1)"]
    model = gust_model(free, q=0.05 if kind == "continuous" else 0.2)
    _check_gradient(model, {"method": "filter_error", "steady_state": steady,
                            "process_noise": kind})


def test_continuous_noise_refuses_a_cross_covariance():
    model = gust_model(s12=0.003)
    data = record(gust_model())
    with pytest.raises(mlid.MlidError, match="cross-covariance s .* needs held noise"):
        mlid.evaluate(model, data, method="filter_error", process_noise="continuous")
