"""Three filter-error items of the report that mlid lacked (issue 17):

- the Kalman filter's initial state covariance P(1|0) = diag(p0) (report
  §4.1, "started with ... covariance P(0|0)"; §5.1.4 starts the X-22 filter
  from P(1|1) = diag(R)): gradient, a second implementation, B(1), and a
  start that a large P0 discounts;
- the steady-state gain K and B as the parameters (eqs 4.19-4.21,
  filter_params = 'gain'): gradient, and the same likelihood maximum as q
  and r where the two parameterisations span the same filters;
- the report's J' (§5.1.6), the unweighted mean square one-step prediction
  error, beside J on a record whose measurement noise is correlated with
  the process noise of the interval that follows (§5.1.5's forward
  correlation).
"""

import json

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import finite_difference, run_both
from test_filter_error import BODY, DT, FREE, GUST, NT, gust_model, numpy_filter, record

FE = {"method": "filter_error"}
GAIN = {"method": "filter_error", "filter_params": "gain"}


def _gradient_error(model, data, opts):
    ev = mlid.evaluate(model, data, **opts)
    fd = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), data, **opts)["cost"],
                           model.theta, model.free_indices(), rel=1e-4, floor=1e-1,
                           five_point=True)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1.0)
    return dict(zip(model.free_names(), rel))


# ---- 1. the initial state covariance P(1|0) = diag(p0) --------------------

def _p0_model():
    m = gust_model(FREE + ["q(1)"], s12=0.003)
    m.p0 = [0.2, 0.05, 0.1]
    return m.with_free(FREE + ["q(1)", "p0(1)", "p0(3)"])


def test_p0_gradient_matches_finite_differences():
    """Every partial through P(1|0) (the covariance recursion's start, the
    output matrix's partials acting on it, and p0 itself)."""
    m = _p0_model()
    rel = _gradient_error(m, record(m), FE)
    assert max(rel.values()) < 1e-6, rel


def test_p0_cost_matches_a_second_implementation():
    m = _p0_model()
    data = record(m)
    cost, yhat = numpy_filter(m, data)
    ev = mlid.evaluate(m, data, **FE)
    assert abs(ev["cost"] - cost) < 1e-9 * abs(cost)
    np.testing.assert_allclose(ev["yhat"], yhat, rtol=0, atol=1e-10)


@pytest.mark.parametrize("p0", [0.0, 10.0])
def test_first_innovation_covariance_is_h_p0_h_plus_r(p0):
    """B(1) = H P0 H' + R: the weighted sensitivity of bias(2) at the first
    sample is -B(1)^-1 e2 (its innovation sensitivity there is -e2)."""
    m = gust_model(["bias(2)"])
    m.p0 = [p0] * 3
    ev = mlid.evaluate(m, record(m), **FE)
    b1 = m.H @ np.diag(m.p0) @ m.H.T + np.diag(m.r)
    np.testing.assert_allclose(-ev["weighted_sensitivity"][:, 0, 0], np.linalg.inv(b1)[:, 1],
                               rtol=1e-12)
    if p0:        # the start is discounted: B(1)'s variances thousands of times R's
        assert np.all(np.diag(b1) > 5000 * m.r)


def test_large_p0_discounts_a_wrong_initial_state():
    """The record starts at x0 = (1, -0.5, 0.3); the model is told x0 = 0 and
    keeps it.  From P0 = 0 the filter trusts that start: the transient pulls
    the derivatives 12-15 sigma off (measured, seeds 1-5).  From P0 = 10 I
    the first innovations' covariance is large, the start counts for little,
    and every derivative is within 3 sigma (measured: 0.7-1.7 sigma)."""
    truth = gust_model()
    truth.x0 = [1.0, -0.5, 0.3]
    t = np.arange(NT) * DT
    u = input_signal("3211", 1.0, 0.5, 0.3, DT, NT)[:, None]
    data = mlid.simulate(truth, t, u, seed=3)[0]
    worst = {}
    for p0 in (0.0, 10.0):
        m = gust_model(BODY + GUST)
        m.p0 = [p0] * 3
        fit = mlid.fit(m, data, **FE)
        assert fit.converged
        z = [(e - truth.value(n)) / s for n, e, s in zip(fit.names, fit.estimate, fit.sigma)
             if n in BODY]
        worst[p0] = np.max(np.abs(z))
    assert worst[0.0] > 5 and worst[10.0] < 3, worst


def test_p0_refusals():
    m = gust_model(BODY)
    m.p0 = [1.0, 1.0, 1.0]
    data = record(m)
    for opts, words in ((dict(FE, steady_state=True), "time-varying Kalman filter"),
                        ({}, "time-varying Kalman filter"),
                        (GAIN, "time-varying Kalman filter")):
        with pytest.raises(mlid.InputError, match=words):
            mlid.fit(m, data, **opts)
    m.p0 = [1.0, -1.0, 1.0]
    with pytest.raises(mlid.InputError, match="p0 must be >= 0"):
        mlid.fit(m, data, **FE)


# ---- 2. the steady-state gain K and B as the parameters --------------------

GAIN_FREE = BODY + ["stab(1,1)", "stab(2,1)", "stab(1,2)", "stab(2,2)", "stab(3,2)", "bias(2)",
                    "x0(1)"]


@pytest.mark.parametrize("noise", ["diagonal", "full"])
def test_gain_gradient_matches_finite_differences(noise):
    """The gradient of J with B = B-hat (eq. 4.20) is that of the
    concentrated likelihood: eq. 4.21 and its partials of K (dK nu)."""
    m0 = gust_model()
    model = mlid.LinearModel(m0.F, m0.G, m0.H, Gamma=m0.Gamma, q=m0.q, r=m0.r, ties=m0.ties,
                             stab=[[0.3, 0.1], [0.05, 0.2], [0.0, 0.4]], free=GAIN_FREE)
    rel = _gradient_error(model, record(m0), dict(GAIN, noise=noise))
    assert max(rel.values()) < 1e-6, rel


def _roll(free, q=0.4, r=4e-4, k=None):
    """Roll subsidence p' = L_p p + L_da da + w, y = p + v: one state, one
    output, where (q, r) -> (K, B) is one to one (0 < K < 1)."""
    return mlid.LinearModel([[-2.0]], [[8.0]], [[1.0]], Gamma=[[1.0]], q=[q], r=[r],
                            stab=None if k is None else [[k]], free=free,
                            names={"f(1,1)": "L_p", "g(1,1)": "L_da"})


@pytest.mark.parametrize("seed", [1, 2])
def test_gain_and_noise_parameterisations_reach_the_same_maximum(seed):
    """Where the K, B family is the q, r family (one state, one output),
    filter_params = 'gain' reaches the steady-state filter's maximum:
    the same cost to 1e-6 relative (measured 2e-11), L_p and L_da within
    0.05 sigma (measured 5e-5) with the same Cramer-Rao sigma, and R
    recovered from K and B by eq. 4.18, R = (1 - H K) B, equal to the r of
    the q, r fit (measured 3e-5 relative)."""
    t = np.arange(600) * DT
    u = input_signal("3211", 0.1, 0.5, 0.4, DT, 600)[:, None]
    data = mlid.simulate(_roll([]), t, u, seed=seed)[0]
    a = mlid.fit(_roll(["f(1,1)", "g(1,1)", "q(1)", "r(1)"], q=0.2, r=1e-3), data,
                 **FE, steady_state=True)
    b = mlid.fit(_roll(["f(1,1)", "g(1,1)", "stab(1,1)"], k=0.5), data, **GAIN)
    assert a.converged and b.converged
    assert abs(a.cost - b.cost) < 1e-6 * abs(a.cost)
    assert np.all(np.abs(a.estimate[:2] - b.estimate[:2]) < 0.05 * a.sigma[:2])
    np.testing.assert_allclose(b.sigma[:2], a.sigma[:2], rtol=1e-3)
    k, bhat = b.estimate[2], b.rhat[0, 0]
    assert 0 < k < 1
    assert abs((1 - k) * bhat / a.estimate[3] - 1) < 1e-3


def test_gain_refusals():
    m = gust_model(BODY + ["q(1)"])
    data = record(m)
    with pytest.raises(mlid.InputError, match="replace q, r and s"):
        mlid.fit(m, data, **GAIN)
    with pytest.raises(mlid.InputError, match="is for filter error"):
        mlid.fit(m, data, method="output_error", filter_params="gain")
    k = m.with_free(BODY + ["stab(1,1)"])
    for opts in ({}, FE):
        with pytest.raises(mlid.InputError, match="free only as the filter's gain"):
            mlid.fit(k, data, **opts)


# ---- 3. J' of §5.1.6 ------------------------------------------------------

def test_report_and_json_give_j_prime():
    m = gust_model(BODY + GUST)
    fit = mlid.fit(m, record(m), **FE)
    assert fit.cost_prime == pytest.approx(0.5 * np.sum(fit.residuals ** 2) / NT, rel=1e-12)
    line = next(s for s in fit.report().splitlines() if s.startswith(" cost J'"))
    assert float(line.split()[3]) == pytest.approx(fit.cost_prime, rel=1e-9)
    assert json.loads(fit.json())["cost_prime"] == pytest.approx(fit.cost_prime, rel=1e-15)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_j_prime_on_a_forward_correlated_record(seed):
    """Measurement noise correlated with the process noise of the interval
    that follows (S = E{w v'}, §5.1.5's forward correlation, here 0.012).
    Fitted with S known and with S = 0 (unmodelled): the unweighted one-step
    prediction error J' is lower with the correlation modelled (measured on
    seeds 1-5: by 0.2-2.3%), as the report's Table 5.1 found (cols 5-6);
    J per sample moves 0.5-0.8% (2 dJ 15-25: the likelihood tells the two
    apart far more surely than J')."""
    truth = gust_model(s12=0.012, q=0.05, r=(1e-3, 4e-3))
    t = np.arange(NT) * DT
    u = input_signal("3211", 1.0, 0.5, 0.3, DT, NT)[:, None]
    data = mlid.simulate(truth, t, u, seed=seed)[0]
    fits = [mlid.fit(gust_model(BODY + GUST, s12=s, q=0.05, r=(1e-3, 4e-3)), data, **FE)
            for s in (0.012, 0.0)]
    assert fits[0].cost_prime < fits[1].cost_prime
    assert fits[0].cost < fits[1].cost - 5


# ---- both front ends -------------------------------------------------------

DECK = """&case title = 'gust: simulate', job = 'simulate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.0, -3.0, -3.0,  0.4, -0.8, -0.8,  0.0, 0.0, -1.5,
    g = 2.0, 0.5, 0.0,  h = 1, 0, 0,  0, 1, 1,
    gamma = 0, 0, 1, q = 0.05, r = 1e-3, 2e-3, x0 = 1.0, -0.5, 0.3 /
&simulate out = 'gust.dat', t_end = 15.0, dt = 0.05, seed = 5,
    input_shape = '3211', amplitude = 1.0, t_start = 0.5, pulse_width = 0.3 /
&case title = 'gust: P0', job = 'estimate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.0, -3.0, -3.0,  0.4, -0.8, -0.8,  0.0, 0.0, -1.5,
    g = 2.0, 0.5, 0.0,  h = 1, 0, 0,  0, 1, 1,
    gamma = 0, 0, 1, q = 0.05, r = 1e-3, 2e-3, p0 = 10, 10, 10,
    free = 'f(1,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'q(1)', 'r(1)', 'r(2)',
    tie = 'f(1,3) = f(1,2)', 'f(2,3) = f(2,2)' /
&data file = 'gust.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
&estimate method = 'filter_error' /
&case title = 'gust: K and B', job = 'estimate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.0, -3.0, -3.0,  0.4, -0.8, -0.8,  0.0, 0.0, -1.5,
    g = 2.0, 0.5, 0.0,  h = 1, 0, 0,  0, 1, 1, gamma = 0, 0, 1,
    stab = 0.3, 0.1,  0.05, 0.2,  0.0, 0.4,  x0 = 1.0, -0.5, 0.3,
    free = 'f(1,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'stab(1,1)', 'stab(2,1)', 'stab(3,2)',
    tie = 'f(1,3) = f(1,2)', 'f(2,3) = f(2,2)' /
&data file = 'gust.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
&estimate method = 'filter_error', filter_params = 'gain', noise = 'full' /
"""


def test_both_front_ends_run_p0_and_gain(tmp_path):
    deck = tmp_path / "items.nml"
    deck.write_text(DECK)
    py, fo = run_both(deck, "--json", str(tmp_path / "{exe}.json"), cwd=tmp_path)
    assert py.returncode == fo.returncode == 0, py.stderr + fo.stderr
    assert py.stdout == fo.stdout
    assert "cost J'" in fo.stdout and "K and B as the parameters" in fo.stdout
    a, b = (json.loads((tmp_path / f"{e}.json").read_text()) for e in ("mlid", "mlid-batch"))
    assert a == b
    assert all(c["status"] == 0 and c["cost_prime"] > 0 for c in a[1:])
    # the deck's P0 fit is the Python one
    model = gust_model(["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "q(1)", "r(1)", "r(2)"], r=(1e-3, 2e-3))
    model.p0 = [10.0] * 3
    data = mlid.FlightData.load(tmp_path / "gust.dat", time_col=1, input_cols=[2],
                                output_cols=[3, 4])
    fit = mlid.fit(model, data, **FE)
    np.testing.assert_allclose(a[1]["estimate"], fit.estimate, rtol=1e-10)
