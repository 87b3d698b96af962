"""State-equation biases bx of the linear model (xdot = F x + G (u + K x) +
bx + Gamma w): analytic partials against finite differences, the same fit
as the old trick of a constant input of ones, recovery within the
Cramer-Rao bound, filter error, and the deck in both front ends."""


import numpy as np
import pytest

import mlid
from conftest import refused_by_both, run_both

F = [[-1.0, 0.9], [-4.0, -1.5]]
G = [[-0.1], [-6.0]]
BX = [0.02, -0.3]


def record(seed=1, nt=501, dt=0.02, **kw):
    t = np.arange(nt) * dt
    u = np.zeros((nt, 1))
    u[(t > 1) & (t < 1.5), 0] = 0.05
    u[(t > 1.5) & (t < 2), 0] = -0.05
    truth = mlid.LinearModel(F=F, G=G, H=np.eye(2), bx=BX, **kw)
    d, _ = mlid.simulate(truth, t, u, noise_std=[2e-3, 5e-3], seed=seed)
    return d


def test_partials_against_finite_differences():
    m = mlid.LinearModel(F=F, G=G, H=np.eye(2), D=[[0.1], [0.2]], K=[[0.3, -0.2]], bx=BX,
                         free=["bx(1)", "bx(2)", "k(1,1)", "k(1,2)", "f(2,1)", "g(2,1)"])
    errs = mlid.check_jacobians(m, np.array([0.1, -0.2]), np.array([0.04]))
    assert max(errs.values()) < 1e-7, errs


def test_the_same_fit_as_a_constant_input_of_ones():
    d = record()
    free = ["f(1,1)", "f(2,1)", "f(2,2)", "g(2,1)"]
    with_bx = mlid.LinearModel(F=np.array(F) * 0.8, G=G, H=np.eye(2), free=free + ["bx(1)", "bx(2)"])
    ones = mlid.LinearModel(F=np.array(F) * 0.8, G=np.column_stack([G, [0.0, 0.0]]), H=np.eye(2),
                            free=free + ["g(1,2)", "g(2,2)"])
    a = mlid.fit(with_bx, d)
    b = mlid.fit(ones, mlid.FlightData(d.t, np.column_stack([d.u, np.ones(d.nt)]), d.y))
    np.testing.assert_allclose(a.estimate, b.estimate, rtol=1e-7, atol=1e-12)
    np.testing.assert_allclose(a.sigma, b.sigma, rtol=1e-6)
    assert a.cost == pytest.approx(b.cost, rel=1e-10)


@pytest.mark.parametrize("method", ["output_error", "filter_error"])
def test_biases_recovered_within_the_bound(method):
    kw = {"Gamma": [[0.0], [1.0]], "q": [1e-4], "r": [4e-6, 25e-6]} if method == "filter_error" \
        else {}
    d = record(seed=7, **kw)
    free = ["f(2,1)", "f(2,2)", "g(2,1)", "bx(1)", "bx(2)"]
    free += ["q(1)"] if method == "filter_error" else []
    f0 = np.array(F) * [[1.0], [0.8]]              # only the free row starts off
    # bx(2) started a third short: from zero the filter-error fit (the same
    # with a column of ones, checked) stalls after 2 iterations
    start = mlid.LinearModel(F=f0, G=G, H=np.eye(2), free=free, bx=[0.0, -0.2], **kw)
    res = mlid.fit(start, d, method=method)
    assert res.converged
    got = dict(zip(res.names, zip(res.estimate, res.sigma)))
    for k, name in enumerate(("bx(1)", "bx(2)")):
        value, sigma = got[name]
        assert abs(value - BX[k]) < 4 * sigma, (name, value, sigma)


DECK = """
&case title = 'state biases', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -0.8, 0.72, -3.2, -1.2,   g = -0.1, -6.0,   h = 1, 0, 0, 1,
    bx = {bx},
    free = 'f(2,1)', 'f(2,2)', 'bx(1)', 'bx(2)', names = 'M_a', 'M_q', 'Z_0', 'M_0',
    output_names = 'alpha', 'q' /
&data file = 'r.dat', time_col = 1, input_cols = 2, output_cols = 3, 4,
    units = 'u1 = rad', 'y1 = rad', 'y2 = rad/s', columns = 't', 'u1', 'y1', 'y2' /
"""


def test_the_deck_gives_the_same_report_in_both_front_ends(tmp_path):
    record().save(tmp_path / "r.dat")
    (tmp_path / "ok.nml").write_text(DECK.format(bx="0.0, 0.0"))
    (tmp_path / "bad.nml").write_text(DECK.format(bx="0.0, 0.0, 1.0"))
    outs = run_both(tmp_path / "ok.nml", cwd=tmp_path)
    assert outs[0].returncode == 0 and outs[0].stdout == outs[1].stdout, outs[0].stderr
    assert " Z_0              rad/s" in outs[0].stdout and " M_0              rad/s2" in outs[0].stdout
    refused_by_both(tmp_path / "bad.nml", "bx has 3 values, it needs 2", cwd=tmp_path)


@pytest.mark.parametrize("steady", [False, True])
def test_filter_error_is_the_same_as_with_a_constant_input_of_ones(steady):
    """The Kalman filter's transition and noise matrices are the linear
    part of an affine model: with bx the cost, gradient and information are
    those of the same model carrying bx as a column of G on an input of ones
    (a bx that leaked into Phi changed the cost by 1.9 at bx = (1, -3))."""
    kw = {"Gamma": [[0.0], [1.0]], "q": [1e-4], "r": [4e-6, 25e-6]}
    d = record(seed=5, **kw)
    free = ["f(2,1)", "g(2,1)", "q(1)", "r(1)"]
    with_bx = mlid.LinearModel(F=F, G=G, H=np.eye(2), bx=[1.0, -3.0], free=free + ["bx(2)"],
                               **kw)
    ones = mlid.LinearModel(F=F, G=np.column_stack([G, [1.0, -3.0]]), H=np.eye(2),
                            free=free + ["g(2,2)"], **kw)
    ones_data = mlid.FlightData(d.t, np.column_stack([d.u, np.ones(d.nt)]), d.y)
    opts = {"method": "filter_error", "steady_state": steady}
    a = mlid.evaluate(with_bx, d, **opts)
    b = mlid.evaluate(ones, ones_data, **opts)
    assert a["cost"] == pytest.approx(b["cost"], rel=1e-12, abs=1e-9)
    np.testing.assert_allclose(a["gradient"], b["gradient"], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(a["information"], b["information"], rtol=1e-8)


def test_rebuilt_models_keep_their_state_biases():
    """diagnose's candidate models (mlid.discrepancy.effects) and the perfect-state
    reduction carry bx (a lag or gust state gets none of its own)."""
    import importlib
    dg = importlib.import_module("mlid.discrepancy.diagnose")
    from mlid.discrepancy import effects
    m = mlid.LinearModel(F=F, G=G, H=np.eye(2), bx=BX, free=["bx(1)", "f(2,1)"])
    d = mlid.FlightData(np.arange(50) * 0.1, np.zeros((50, 1)), np.zeros((50, 2)))
    assert list(effects.scale_factor(m, d, 1).model.bx) == BX
    assert list(dg._noisy(m, [1]).bx) == BX
    assert list(effects.sensor_lag(m, d, 1).model.bx) == BX + [0.0]
    assert list(effects.sensor_lag(m, d, 1, order=2).model.bx) == BX + [0.0, 0.0]
    r = mlid.reduce_measured_state(m.with_free(["bx(1)"]), state=2, output=2)
    assert list(r.bx) == BX[:1] and r.free == ["bx(1)"]
