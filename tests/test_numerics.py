"""Numerical checks against second implementations: finite differences of
the likelihood, an exact matrix-exponential discretisation, the truth."""

import numpy as np
import pytest

import mlid
from conftest import C8_F, C8_G, C8_STD, c8_record, c8_start, c8_truth, finite_difference


def _with_extra_free(model, extra):
    return mlid.LinearModel(model.F, model.G, model.H, model.D, model.x0, model.bias,
                            free=model.free + extra, names=model.names)


@pytest.mark.parametrize("noise", ["diagonal", "full"])
def test_gradient_matches_finite_differences(c8_data, noise):
    # Free derivatives, an initial state and an output bias; R re-estimated at
    # every point, so this is the gradient of the concentrated likelihood.
    model = _with_extra_free(c8_start(), ["x0(3)", "bias(2)", "h(4,3)"])
    ev = mlid.evaluate(model, c8_data, noise=noise)
    fd = finite_difference(
        lambda th: mlid.evaluate(model.with_theta(th), c8_data, noise=noise)["cost"],
        model.theta, model.free_indices())
    assert np.max(np.abs(fd - ev["gradient"]) / np.maximum(1.0, np.abs(fd))) < 1e-6


def test_information_matrix_matches_finite_difference_sensitivities(c8_data):
    model = _with_extra_free(c8_start(), ["x0(1)", "bias(4)"])
    ev = mlid.evaluate(model, c8_data)
    jac = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), c8_data)["yhat"],
                            model.theta, model.free_indices())
    jac = np.moveaxis(jac, 0, -1)                      # (nt, ny, nf)
    rinv = np.linalg.inv(ev["rhat"])
    m_fd = np.einsum("tik,ij,tjl->kl", jac, rinv, jac)
    scale = np.sqrt(np.outer(np.diag(m_fd), np.diag(m_fd)))
    assert np.max(np.abs(m_fd - ev["information"]) / scale) < 1e-6


@pytest.mark.parametrize("noise", ["diagonal", "full"])
def test_information_and_gradient_are_the_weighted_sensitivities_products(c8_data, noise):
    # The core forms them from L' dy (R^-1 = L L') by blocks of 64 samples (301
    # here: a short last block); the weighted sensitivities it returns are
    # R^-1 dy, formed apart: sum_t dy' R^-1 dy and -sum_t (R^-1 dy)' nu from them
    # agree to rounding.
    model = _with_extra_free(c8_start(), ["x0(3)", "bias(2)"])
    ev = mlid.evaluate(model, c8_data, noise=noise)
    ws = ev["weighted_sensitivity"]                          # (ny, nt, nf)
    dy = np.einsum("pq,qtk->ptk", ev["rhat"], ws)
    info = np.einsum("ptk,ptl->kl", dy, ws)
    grad = -np.einsum("ptk,tp->k", ws, c8_data.y - ev["yhat"])
    scale = np.sqrt(np.outer(np.diag(info), np.diag(info)))
    assert np.max(np.abs(info - ev["information"]) / scale) < 1e-12
    assert np.max(np.abs(grad - ev["gradient"]) / np.sqrt(np.diag(info))) < 1e-12
    if noise == "diagonal":
        assert np.count_nonzero(ev["rhat"] - np.diag(np.diag(ev["rhat"]))) == 0


def _expm(a):
    """Matrix exponential by scaling and squaring of a Taylor series."""
    s = max(0, int(np.ceil(np.log2(max(np.linalg.norm(a, 1), 1e-300)))) + 1)
    a = a / 2**s
    e, term = np.eye(len(a)), np.eye(len(a))
    for k in range(1, 20):
        term = term @ a / k
        e = e + term
    for _ in range(s):
        e = e @ e
    return e


def test_rk4_agrees_with_exact_discretisation():
    # Input linear between samples: augment (x, u, du/dt) and take the exact
    # transition over each interval.
    data = c8_record()
    model = c8_truth()
    clean, states = mlid.simulate(model, data.t, data.u)
    dt = data.t[1] - data.t[0]
    a = np.zeros((6, 6))
    a[:4, :4], a[:4, 4:5], a[4, 5] = C8_F, C8_G, 1.0
    phi = _expm(a * dt)
    x = np.zeros(4)
    exact = [x]
    for k in range(data.nt - 1):
        z = np.concatenate([x, data.u[k], (data.u[k + 1] - data.u[k]) / dt])
        x = (phi @ z)[:4]
        exact.append(x)
    exact = np.array(exact)
    scale = np.max(np.abs(exact), axis=0)
    assert np.max(np.abs(states - exact) / scale) < 1e-5
    np.testing.assert_allclose(clean.y, states, rtol=0, atol=1e-15)


def test_c8_fit_recovers_truth_within_3_sigma(c8_data):
    res = mlid.fit(c8_start(), c8_data)
    truth = c8_truth().theta[c8_truth().free_indices()]
    assert res.converged
    assert res.iterations <= 10
    z = (res.estimate - truth) / res.sigma
    assert np.all(np.abs(z) < 3), z
    # the start was 30-50% off, i.e. many sigma away
    assert np.max(np.abs((res.start - truth) / res.sigma)) > 5
    # R-hat estimates the simulated noise variances (N = 301: +-25% is > 3 standard errors)
    np.testing.assert_allclose(np.diag(res.rhat), C8_STD**2, rtol=0.25)
    assert res.cost_history[-1] <= res.cost_history[0]
    assert np.all(np.diff(res.cost_history) <= 0)
    c = res.correlation
    np.testing.assert_allclose(np.diag(c), 1.0)


def test_monte_carlo_sigma_matches_cramer_rao():
    # Reduced version of cases/c8_short_period/c8.py --runs 200 (the same
    # experiment and seeds; the README quotes the 200-run numbers).  With
    # N = 60 runs the sample standard deviation has a relative standard error
    # of 1/sqrt(2(N-1)) = 9.2%; the 30% band is over 3 standard errors.
    data = c8_record()
    mc = mlid.monte_carlo(c8_truth(), c8_start(), data.t, data.u, C8_STD, runs=60, seed=100)
    assert np.all(mc["status"] == 0)
    est, sig = mc["estimates"], mc["sigma"]
    ratio = est.std(axis=0, ddof=1) / sig.mean(axis=0)
    assert np.all(np.abs(ratio - 1) < 0.30), ratio
    # no bias beyond 4 standard errors of the mean
    bias = (est.mean(axis=0) - mc["truth"]) / (sig.mean(axis=0) / np.sqrt(len(est)))
    assert np.all(np.abs(bias) < 4), bias


def test_monte_carlo_is_reproducible():
    data = c8_record()
    a = mlid.monte_carlo(c8_truth(), c8_start(), data.t, data.u, C8_STD, runs=3, seed=5)
    b = mlid.monte_carlo(c8_truth(), c8_start(), data.t, data.u, C8_STD, runs=3, seed=5)
    np.testing.assert_array_equal(a["estimates"], b["estimates"])


def test_zero_order_hold_and_substeps_change_the_integration(c8_data):
    a = mlid.simulate(c8_truth(), c8_data.t, c8_data.u)[1]
    b = mlid.simulate(c8_truth(input_hold="zoh"), c8_data.t, c8_data.u)[1]
    c = mlid.simulate(c8_truth(substeps=4), c8_data.t, c8_data.u)[1]
    assert np.max(np.abs(a - b)) > 1e-4       # the held input lags the ramp
    assert np.max(np.abs(a - c)) < 1e-7       # RK4 is already converged at dt = 0.02


def test_singular_information_names_the_parameter():
    # State 2 never moves (x0 = 0, no input or coupling into it): F(1,2) has
    # no effect on the outputs.
    model = mlid.LinearModel([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2),
                             free=["f(1,1)", "f(1,2)", "g(1,1)"])
    t = np.arange(200) * 0.02
    u = np.sin(3 * t)[:, None]
    data, _ = mlid.simulate(model, t, u, [0.01, 0.01], seed=3)
    with pytest.raises(mlid.SingularInformationError, match=r"'f\(1,2\)'") as exc:
        mlid.fit(model, data)
    assert exc.value.result is not None


def test_an_unidentifiable_parameter_leaves_the_others_estimated():
    """One free parameter without effect (F(1,2) on a state that never
    moves): the fit still estimates the others, from a start away from the
    truth, as the fit without it does (the step leaves out only the
    singular direction), and then says which parameter it could not have."""
    truth = mlid.LinearModel([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2))
    t = np.arange(200) * 0.02
    data, _ = mlid.simulate(truth, t, np.sin(3 * t)[:, None], [0.01, 0.01], seed=3)
    start = dict(F=[[-0.6, 0.5], [0.0, -2.0]], G=[[1.4], [0.0]], H=np.eye(2))
    without = mlid.fit(mlid.LinearModel(**start, free=["f(1,1)", "g(1,1)"]), data)
    with pytest.raises(mlid.SingularInformationError, match=r"'f\(1,2\)'") as exc:
        mlid.fit(mlid.LinearModel(**start, free=["f(1,1)", "f(1,2)", "g(1,1)"]), data)
    res = exc.value.result
    assert res.iterations >= 3
    np.testing.assert_allclose(res.estimate[[0, 2]], without.estimate, rtol=1e-8)


def test_divergence_is_reported(c8_data):
    F = C8_F.copy()
    F[2, 2] = 200.0                    # wildly unstable start
    model = mlid.LinearModel(F, C8_G, np.eye(4), free=["f(3,3)"])
    with pytest.raises(mlid.DivergenceError, match="diverged"):
        mlid.fit(model, c8_data)


def test_iteration_limit_is_reported_not_raised(c8_data):
    res = mlid.fit(c8_start(), c8_data, max_iter=1)
    assert not res.converged and res.reason == "iteration limit reached"
    assert "not converged" in res.message


def test_zero_residual_output_is_reported():
    model = c8_truth()
    data = c8_record()
    data.y[:, 1] = mlid.simulate(model, data.t, data.u)[0].y[:, 1]   # a noise-free channel
    with pytest.raises(mlid.SingularInformationError, match="output 2"):
        mlid.fit(model, data)


@pytest.mark.parametrize("kwargs, match", [
    ({"max_iter": -1}, "max_iter"),
    ({"noise": "banana"}, "noise"),
    ({"rcond": 2.0}, "rcond"),
    ({"tolerance": 1.0}, "unknown option"),
])
def test_bad_options(c8_data, kwargs, match):
    with pytest.raises(mlid.InputError, match=match):
        mlid.fit(c8_start(), c8_data, **kwargs)


def test_bad_data_is_rejected(c8_data):
    c8_data.y[17, 2] = np.nan
    with pytest.raises(mlid.InputError, match="output 3 is NaN or infinite at sample 18"):
        mlid.fit(c8_start(), c8_data)
    short = mlid.FlightData(c8_data.t[:4], c8_data.u[:4], c8_data.y[:4])
    with pytest.raises(mlid.InputError, match="too few"):
        mlid.fit(c8_start(), short)
    wrong = mlid.FlightData(c8_data.t, c8_data.u, c8_data.y[:, :3])
    with pytest.raises(mlid.InputError, match="3 output columns"):
        mlid.fit(c8_start(), wrong)
    back = mlid.FlightData(c8_data.t[::-1], c8_data.u, np.nan_to_num(c8_data.y))
    with pytest.raises(mlid.InputError, match="time does not increase"):
        mlid.fit(c8_start(), back)


def test_unknown_free_parameter():
    with pytest.raises(mlid.InputError, match=r"'f\(5,1\)' does not exist"):
        mlid.LinearModel(C8_F, C8_G, np.eye(4), free=["f(5,1)"])
    with pytest.raises(mlid.InputError, match="does not exist"):
        mlid.LinearModel(C8_F, C8_G, np.eye(4), free=["m_q"])
