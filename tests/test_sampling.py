"""What the core does with uneven sampling (README, filter error section):
output error integrates each interval over its own length (checked against
the exact solution), a step over 1.5 times the median is a gap for every
method, and filter error refuses a step more than 0.1% off the first."""

import numpy as np
import pytest

import mlid

F = np.array([[-0.8, 2.0], [-2.0, -0.8]])        # poles -0.8 +- 2i
X0 = np.array([1.0, -0.5])
DT = 0.02


def _model(**kw):
    return mlid.LinearModel(F, [[0.0], [1.0]], np.eye(2), x0=X0, free=["f(1,1)"], **kw)


def _exact(t):
    """y = x = expm(F t) x0, from the eigen-decomposition."""
    lam, v = np.linalg.eig(F)
    c = np.linalg.solve(v, X0)
    return np.real(np.exp(np.outer(t, lam)) * c @ v.T)


def _uneven(n, seed=4):
    """Steps DT times 0.7 .. 1.3: uneven, but no gap (1.3 < 1.5 x median)."""
    steps = DT * np.random.default_rng(seed).uniform(0.7, 1.3, n - 1)
    return np.r_[0.0, np.cumsum(steps)]


def test_output_error_integrates_each_uneven_step():
    t = _uneven(300)
    zero = np.zeros((t.size, 1))
    data = mlid.FlightData(t, zero, _exact(t))
    yhat = mlid.evaluate(_model(), data)["yhat"]
    # RK4's local error is below (h |lambda|)^5 / 120 = 5e-9 at h <= 0.026,
    # |lambda| = 2.15, so under 1.5e-6 over 300 steps (measured 4e-8); steps
    # taken as DT instead of their own lengths are off by more than 1e-3
    np.testing.assert_allclose(yhat, _exact(t), rtol=0, atol=1.5e-6)
    uniform = mlid.evaluate(_model(), mlid.FlightData(np.arange(t.size) * DT, zero,
                                                      _exact(t)))["yhat"]
    assert np.max(np.abs(uniform - _exact(t))) > 1e-3


@pytest.mark.parametrize("method", ["output_error", "filter_error"])
def test_a_step_over_one_and_a_half_medians_is_a_gap(method):
    t = np.arange(200) * DT
    t[120:] += 0.55 * DT                          # one step of 1.55 DT
    model = _model(Gamma=[[0.0], [1.0]], q=[1e-4], r=[1e-4, 1e-4])
    data = mlid.FlightData(t, np.zeros((200, 1)), _exact(t))
    with pytest.raises(mlid.InputError, match=r"a gap in time .* at sample 121 "):
        mlid.evaluate(model, data, method=method)
    t[120:] -= 0.1 * DT                           # 1.45 DT: no gap
    mlid.evaluate(model, mlid.FlightData(t, np.zeros((200, 1)), _exact(t)),
                  method="output_error")


def test_filter_error_needs_one_sample_interval():
    model = _model(Gamma=[[0.0], [1.0]], q=[1e-4], r=[1e-4, 1e-4])
    t = np.arange(200) * DT
    rounded = t.copy()
    rounded[50:] += 0.0009 * DT                   # a step 0.09% long: rounding, accepted
    ev = mlid.evaluate(model, mlid.FlightData(rounded, np.zeros((200, 1)), _exact(rounded)),
                       method="filter_error")
    assert np.isfinite(ev["cost"])
    t[50:] += 0.002 * DT                          # 0.2% long: refused, the sample named
    with pytest.raises(mlid.InputError, match="needs uniform sampling; time step changes at "
                                              "sample 51"):
        mlid.evaluate(model, mlid.FlightData(t, np.zeros((200, 1)), _exact(t)),
                      method="filter_error")
    # output error takes the same record
    assert np.isfinite(mlid.evaluate(model, mlid.FlightData(t, np.zeros((200, 1)), _exact(t)),
                                     method="output_error")["cost"])
