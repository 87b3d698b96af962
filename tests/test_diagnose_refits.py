"""The discrepancy workflow's refits (issue 47): every candidate's refit
starts where it reproduces the current model, so none ends above it; one
that does is a failed optimisation, reported as untested, never rejected;
equivalent candidates are said together; the effects' numbers come from
the final fit."""

import json
import math

import numpy as np
import pytest

import mlid
from mlid.discrepancy import diagnose as dg
import scenarios

SEEDS = (1, 2, 3)


def _refitted(d):
    """(round cost, candidate) of every candidate a diagnosis refitted."""
    return [(r["cost"], c) for r in d.rounds for c in r["candidates"] if c.lr is not None]


@pytest.mark.parametrize("scenario", scenarios.SCENARIOS)
def test_no_refit_ends_above_the_current_fit(scenario):
    """On main 76 of these scenarios' 120 records at seeds 1-10 had a lag
    refit at 2dJ < 0 (worst -873.65): its start, two sample intervals, lay
    off the nested point tau = 0, and the refit stalled where RK4 turns
    unstable, tau = 0.36 dt.  Now none, and none untested (measured at seeds
    1-10; tested at 1-3).  The tolerance is the workflow's NESTED_TOL, the
    rounding of the cost."""
    for seed in SEEDS:
        model, data = scenarios.make(scenario, seed)
        d = mlid.diagnose(model, data)
        for cost, c in _refitted(d):
            assert c.lr >= -dg.NESTED_TOL * max(1.0, abs(cost)), (c.name, c.lr, d.report())
        assert not any(c.decision.startswith("untested") for r in d.rounds
                       for c in r["candidates"]), d.report()
        # and no two of these records' candidates are the same model
        assert not any(c.equivalent for r in d.rounds for c in r["candidates"]), d.report()


def test_a_lag_the_data_do_not_want_is_rejected_at_tau_zero():
    """The bias record: the cost rises as a lag on r grows from tau = 0 (main
    refitted it to 2dJ -106.7), so its best is no lag: 2dJ 0, rejected."""
    model, data = scenarios.make("bias", 1)
    d = mlid.diagnose(model, data)
    lag = [c for c in d.rounds[0]["candidates"] if c.name == "lag on r"][0]
    assert lag.lr == 0.0 and lag.decision.startswith("rejected: the cost rises")


@pytest.mark.parametrize("scenario, seed, k, name", [("delay", 4, 1, "lag on phi"),
                                                     ("sas", 6, 1, "lag on rudder")])
def test_a_lag_with_a_weak_slope_starts_at_the_smallest_tau(scenario, seed, k, name):
    """Where the slope at tau = 0 is weak (score 0.8 and 2.0 here) the
    one-step tau and its quarters cost more than the current model, but
    tau = dt/64 costs less: the refit starts there and ends at 2dJ >= 0,
    rejected (an earlier form of the search stopped one quarter short and
    left these untested)."""
    model, data = scenarios.make(scenario, seed)
    d = mlid.diagnose(model, data)
    lag = [c for c in d.rounds[k]["candidates"] if c.name == name][0]
    assert lag.spec["start"] == pytest.approx(scenarios.DT / dg.LAG_SUBSTEPS_MAX)
    assert 0.0 <= lag.lr < 2.0 and lag.decision == "rejected", lag.decision


def test_a_lag_whose_slope_estimate_errs_is_rejected_at_tau_zero(monkeypatch):
    """A slope estimate of the wrong sign (forced: the bias record's lag on
    r, whose cost rises from tau = 0 with slope +2075, given -2075): no
    start down to dt/64 fits as well as the current model, so the cost
    rises from 0 and the lag is rejected there, not refitted."""
    model, data = scenarios.make("bias", 1)
    fit = mlid.fit(model, data)
    cur = model.with_theta(fit.model.theta)
    signed, rest = dg._lag_slope(cur, data, dg.Candidate("sensor lag", "lag on r", output=1),
                                 {})
    assert signed > 1000
    monkeypatch.setattr(dg, "_lag_slope", lambda *a: (-signed, rest))
    c = dg.Candidate("sensor lag", "lag on r", output=1)
    assert dg._lag_start(cur, data, fit, c, {}) is None
    assert c.lr == 0.0 and "at tau = 0.00031 s too" in c.decision


def test_a_lag_refit_starts_below_the_current_fit():
    """A first-order lag's start (one Newton step from tau = 0, damped) fits
    at least as well as the model without it; the refit recovers tau."""
    model, data = scenarios.first_order_lag(1)
    fit = mlid.fit(model, data)
    cur = model.with_theta(fit.model.theta)
    c = dg.Candidate("sensor lag", "lag on phi", output=3)
    tau = dg._lag_start(cur, data, fit, c, {})
    assert tau is not None and 0.02 < tau < 0.4
    dg._refit(cur, data, fit, c, {"startup": "none"})
    assert c.lr > 100 and c.quantities[0][1] == pytest.approx(0.1, rel=0.05)


def test_a_refit_that_fails_twice_is_untested(monkeypatch):
    """A refit forced to end above the current fit (its cost raised by 10^4)
    is retried nearer its nested point, and when that fails too the
    candidate is untested: not rejected, not accepted, the 2dJ of both tries
    in its decision."""
    real = dg.fit_model

    def broken(m, data, **opts):
        res = real(m, data, **opts)
        if "bias(3)" in m.free:          # the bias on beta's refits
            res.cost += 1e4
        return res
    monkeypatch.setattr(dg, "fit_model", broken)
    model, data = scenarios.make("bias", 1)
    d = mlid.diagnose(model, data)
    c = [c for c in d.rounds[0]["candidates"] if c.name == "bias on beta"][0]
    assert c.lr is None and c.decision.startswith("untested"), d.report()
    assert c not in d.effects and "again" in c.decision
    assert "untested" in d.report()
    listed = [x for r in d.as_dict()["rounds"] for x in r["listed"]]
    assert any(x["name"] == "bias on beta" and x["decision"].startswith("untested")
               for x in listed)


def test_the_effects_numbers_come_from_the_final_fit():
    """The two-effect record: the aileron delay is accepted in round 1, the
    bias on beta in round 2, which moves the delay's estimate (0.05896 to
    0.05936 s at seed 1, 0.7 sigma).  The report, the JSON and the HTML give
    the final fit's numbers; the round's listing keeps the refit's."""
    from mlid.discrepancy.diagnosis import _g
    model, data = scenarios.make("two", 1)
    d = mlid.diagnose(model, data)
    delay, bias = d.effects
    assert (delay.name, delay.round, bias.round) == ("delay on delta_a", 1, 2)
    k = d.fit.names.index("delay delta_a")
    value, sigma = delay.quantities[0][1:3]
    assert (value, sigma) == (d.fit.estimate[k], d.fit.sigma[k])
    old = delay.refit_quantities[0][1]
    assert abs(old - value) > 0.3 * sigma                 # the second effect moved it
    report = d.report()
    assert f"time delay = {value:.5g} +- {sigma:.2g} s" in report
    assert f"{old:.5g}" not in report
    out = json.loads(json.dumps(d.as_dict()))
    assert out["effects"][0]["value"] == value and out["effects"][0]["round"] == 1
    listed = [c for c in out["rounds"][0]["listed"] if c["name"] == "delay on delta_a"][0]
    assert listed["value"] == old
    page = d._repr_html_()
    assert _g(value) in page and _g(old) not in page


@pytest.mark.parametrize("seed", (1, 2))
def test_equivalent_candidates_are_one_explanation(seed):
    """tests/scenarios.py's equivalent_pair: N_phi free, phi fed back to the
    aileron and phi fed back to the rudder are one model (L_phi is free), and
    score alike (937.54 at seed 1).  Main called two of them "significant,
    not the best this round" (and at seed 2 named the rudder loop alone); now
    one effect carries all three names in the report, JSON and HTML."""
    model, data = scenarios.equivalent_pair(seed)
    d = mlid.diagnose(model, data)
    assert len(d.effects) == 1, d.report()
    e = d.effects[0]
    others = {"phi fed back to delta_a", "phi fed back to delta_r"}
    assert e.name == "N_phi" and {c.name for c in e.equivalent} == others
    assert e.value[0] == pytest.approx(scenarios.N_PHI, abs=3 * e.value[1])
    for c in e.equivalent:
        assert c.equivalent_to is e and c.decision.startswith("the same model as N_phi")
        assert abs(c.lr - e.lr) < 1e-6
    report = d.report()
    assert "not the best this round" not in report
    assert "N_phi (the same model as phi fed back to delta_a, phi fed back to delta_r)" in report
    out = json.loads(json.dumps(d.as_dict()))
    assert {x["name"] for x in out["effects"][0]["equivalent"]} == others
    assert all(name in out["verdict"] for name in others | {"N_phi"})
    page = d._repr_html_()
    table = page[page.index('class="mlid-effects"'):]
    table = table[:table.index("</table>")]
    assert all(name in table for name in others | {"N_phi"})


def test_a_bias_in_the_v_equation_is_named_first():
    """tests/scenarios.py's longitudinal_linear: a thrust-like 0.05 m/s2 in
    V-dot.  Main had no state-equation family and named the breakpoint
    max(V - b, 0) in the V equation at all of these seeds; a term now needs
    a margin over a constant (TERM_ALPHA), which seeds 4 and 5 need (the
    term's 2dJ was 0.5 and 0.9 above the bias's).  Measured: named first at
    20 of 20 seeds.  Without the bias nothing is accepted."""
    for seed in range(1, 7):
        model, data = scenarios.longitudinal_linear(seed)
        d = mlid.diagnose(model, data)
        assert [e.name for e in d.effects] == ["bias in the V equation"], d.report()
        value, sigma = d.effects[0].value
        assert d.effects[0].family == "state-equation bias"
        assert abs(value - scenarios.V_DOT_BIAS) < 3 * sigma
    for seed in (1, 2):
        model, data = scenarios.longitudinal_linear(seed, v_dot_bias=0.0)
        assert not mlid.diagnose(model, data).effects


def test_a_bias_in_an_equation_of_the_equations_kind():
    """The equations kind gets the family as a constant term written into
    each state equation with an estimated parameter (terms.state_biases):
    tests/test_terms.py's short period with 0.02 rad/s2 in q-dot (ours) is
    named first at seeds 1-3, within 3 sigma; without it nothing is.  A
    kind whose state equations are the core's is refused in one line."""
    from mlid.design.signals import input_signal
    from mlid.discrepancy import terms
    from test_terms import SP_TRUTH, short_period
    t = np.arange(1001) * 0.02
    de = input_signal("3211", 0.05, 1.0, 0.5, 0.02, t.size)[:, None]
    model = short_period(free=list(SP_TRUTH))
    assert [(b.equation, b.expression) for b in terms.state_biases(model)] == [
        ("the alpha equation", "1"), ("the q equation", "1")]
    for bias in (0.02, 0.0):
        for seed in (1, 2, 3):
            truth = short_period(" + Mb", dict(SP_TRUTH, Mb=bias))
            data, _ = mlid.simulate(truth, t, de, noise_std=[1e-3, 2e-3, 5e-2], seed=seed)
            d = mlid.diagnose(model, data)
            if bias:
                assert [e.name for e in d.effects] == ["bias in the q equation"], d.report()
                value, sigma = d.effects[0].value
                assert abs(value - bias) < 3 * sigma
            else:
                assert not d.effects, d.report()
    with pytest.raises(mlid.InputError, match="no state equations in its text"):
        terms.state_biases(scenarios.analysis_model())
