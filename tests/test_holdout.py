"""Held-out verdicts of the discrepancy workflow (mlid.discrepancy.holdout, issue 16):
the split, the held-out criterion against an independent computation, and
that an effect which does not hold on the held-out part is not accepted."""

import sys

import numpy as np
import pytest

import mlid
from mlid.discrepancy import holdout

from conftest import REPO

sys.path.insert(0, str(REPO / "tests"))
import scenarios  # noqa: E402


def test_the_split_of_one_record_and_of_several():
    _, data = scenarios.make("null", 1)
    s = holdout.Split.of(data)
    assert (s.head(data).nt, s.rows, s.what) == (267, 133, "the last third of the record")
    two = [data, data.head(200)]
    s = holdout.Split.of(two)
    assert (len(s.head(two)), s.rows, s.what) == (1, 200, "the last manoeuvre")
    assert holdout.Split.of(data.head(80)) is None          # 27 samples held out < 30


def test_output_error_heldout_cost_is_the_simulation_error_criterion():
    """Independently: simulate the head's fit over the whole record; the
    criterion of the last third's errors."""
    model, data = scenarios.make("derivative", 2)
    s = holdout.Split.of(data)
    cost, res, yhat = holdout.heldout_cost(model, data, s, {})
    sim, _ = mlid.simulate(res.model, data.t, data.u, noise_std=np.zeros(4))
    e = data.y[-s.rows:] - sim.y[-s.rows:]
    expected = 0.5 * s.rows * np.sum(np.log(np.mean(e**2, axis=0)))
    assert cost == pytest.approx(expected, rel=1e-9)
    np.testing.assert_allclose(yhat, sim.y, atol=1e-10)


def test_filter_error_heldout_cost_is_the_innovations_criterion():
    """Independently: a steady-state Kalman filter in numpy over the whole
    record with the head fit's parameters; the criterion of its innovations
    over the last third."""
    model, data = scenarios.make("gust", 1)
    F, G = scenarios.matrices(scenarios.BASE)
    fe = mlid.LinearModel(F, G, np.eye(4), Gamma=[[0], [0], [1.0], [0]], q=[1e-3],
                          r=np.square(scenarios.NOISE), free=list(model.free) + ["q(1)"]
                          + [f"r({i})" for i in range(1, 5)])
    opts = {"method": "filter_error"}
    s = holdout.Split.of(data)
    cost, res, _ = holdout.heldout_cost(fe, data, s, opts)
    m = res.model
    dt = data.t[1] - data.t[0]
    # the core's discretisation: RK4 of the linear model (inputs linear between
    # samples), process noise held over the interval
    from scipy.linalg import expm, solve_discrete_are
    n = m.nx
    big = np.zeros((n + 4, n + 4))
    big[:n, :n], big[:n, n:n + 2], big[n:n + 2, n + 2:] = m.F, m.G, np.eye(2) / dt
    E = expm(big * dt)
    phi, g0, g1 = E[:n, :n], E[:n, n:n + 2] - E[:n, n + 2:], E[:n, n + 2:]
    gam = np.linalg.solve(m.F, (phi - np.eye(n))) @ m.Gamma
    Q = gam @ np.diag(m.q) @ gam.T
    R = np.diag(m.r)
    P = solve_discrete_are(phi.T, m.H.T, Q, R)
    B = m.H @ P @ m.H.T + R
    K = P @ m.H.T @ np.linalg.inv(B)
    x = m.x0.copy()
    held = []
    for k in range(data.nt):
        nu = data.y[k] - m.H @ x - m.bias
        if k >= data.nt - s.rows:
            held.append(nu)
        xc = x + K @ nu
        if k + 1 < data.nt:
            x = phi @ xc + g0 @ data.u[k] + g1 @ data.u[k + 1]
    total = 0.5 * s.rows * np.sum(np.log(np.mean(np.square(held), axis=0)))
    # the core integrates by RK4 (not the exponential): a relative 1e-4 covers
    # its truncation error at this step (|lambda dt| < 0.1)
    assert cost == pytest.approx(total, rel=1e-4)


def test_an_effect_that_does_not_hold_out_is_not_accepted():
    """A beta bias of 0.15 deg in the first two thirds only (a sensor reset):
    significant in the record, but a bias fitted to the head predicts the
    held-out third worse than none."""
    model, data = scenarios.make("null", 3)
    y = data.y.copy()
    y[:267, 2] += 0.15
    data = mlid.FlightData(data.t, data.u, y, data.input_names, data.output_names)
    d = mlid.diagnose(model, data, families=("bias",))
    bias = [c for r in d.rounds for c in r["candidates"] if c.name == "bias on beta"][0]
    assert bias.lr > d.rounds[0]["threshold"]               # significant in the record
    assert bias.holdout < 0 and "fails its held-out check" in bias.decision
    assert "bias on beta" not in [e.name for e in d.effects]
    assert "checked on the last third of the record" in d.report()
