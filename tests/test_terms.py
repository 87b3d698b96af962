"""Nonlinear-term candidates of the equation-based kinds (mlid.discrepancy.terms): a
term appended to the model's own text leaves the model exact.  For the
equations kind, the six-DOF kind and an equations model without states, on
a seeded record simulated from a truth with one such term: the extended
model at coefficient 0 is the base model, the core's gradient in the new
coefficient is the cost's, the true term has the largest score statistic at
the base fit, a fit of it recovers the truth within its Cramer-Rao sigma;
without the term no score is significant.  Another kind is one line naming
it."""

import numpy as np
import pytest
from scipy.stats import chi2

import mlid
from mlid.design.signals import input_signal
from conftest import finite_difference
from mlid.discrepancy import terms
from test_sixdof import CONSTANTS, LAT_TRUTH

# --- the equations kind: a short period with alpha^2 in the pitching moment --

SP_TRUTH = dict(Za=-1.0, Zd=-0.1, Ma=-4.0, Mq=-1.5, Md=-6.0)
#: The missing term and its coefficient: M_alpha falls (more stable) by
#: |10 alpha| of itself, 0.5 rad/s^2 at the record's largest alpha (0.07).
SP_TERM, SP_COEF = "alpha^2", -10.0


def short_period(extra="", params=SP_TRUTH, **kw):
    return mlid.EquationModel(
        states={"alpha": "Za*alpha + q + Zd*de", "q": "Ma*alpha + Mq*q + Md*de" + extra},
        outputs={"alpha": "alpha", "q": "q", "az": "V*(Za*alpha + Zd*de)"},
        inputs=["de"], definitions={"V": "80"}, params=params, **kw)


def equations_record(coef=SP_COEF):
    """A 3211 on the elevator, 20 s at 50 Hz, noise 1e-3 rad, 2e-3 rad/s,
    0.05 m/s^2 (seeded); the base model fitted from the truth's values."""
    t = np.arange(1001) * 0.02
    de = input_signal("3211", 0.05, 1.0, 0.5, 0.02, t.size)
    truth = short_period(" + Maa*alpha^2", dict(SP_TRUTH, Maa=coef))
    data, _ = mlid.simulate(truth, t, de[:, None], noise_std=[1e-3, 2e-3, 5e-2], seed=1)
    return data, mlid.fit(short_period(free=list(SP_TRUTH)), data)


@pytest.fixture(scope="module")
def equations_case():
    data, base = equations_record()
    assert base.converged
    return data, base


# --- the six-degree-of-freedom kind: a lateral model with |beta| beta in Cl ---

#: The missing term: the roll moment's dihedral effect growing with
#: |beta|, by half of C_lbeta (-0.1) at |beta| = 0.1.
SIX_TERM, SIX_COEF = "|beta|*beta", -0.5


def lateral(extra="", params=LAT_TRUTH, **kw):
    """States v, p, r, phi; u, w, q, theta measured inputs (the decoupled
    lateral form of test_sixdof)."""
    return mlid.SixDofModel(CONSTANTS, ["v", "p", "r", "phi"],
                            {"beta": "beta", "p": "p", "r": "r", "phi": "phi", "ay": "ay"},
                            inputs=["da", "dr", "u", "w", "q", "theta"], params=params,
                            definitions={"rho": "1.0", "CY": "CYb*beta",
                                         "Cl": "Clb*beta + Clp*phat + Clr*rhat + Clda*da" + extra,
                                         "Cn": "Cnb*beta + Cnr*rhat + Cndr*dr"}, **kw)


def sixdof_record(coef=SIX_COEF):
    """Aileron and rudder doublets, 40 s at 20 Hz, u, w, theta constant and
    q zero (so alpha and qhat are constants), noise 2e-3 rad (rad/s) and
    0.05 m/s^2 (seeded); the base model fitted from the truth's values."""
    n = 801
    t = np.arange(n) * 0.05
    da = input_signal("doublet", 0.05, 1.0, 1.0, 0.05, n)
    dr = input_signal("doublet", 0.05, 12.0, 1.5, 0.05, n)
    u = np.column_stack([da, dr, np.full(n, 99.0), np.full(n, 8.0), np.zeros(n),
                         np.full(n, 0.08)])
    truth = lateral(" + Clbb*abs(beta)*beta", dict(LAT_TRUTH, Clbb=coef))
    data, _ = mlid.simulate(truth, t, u, noise_std=[2e-3, 2e-3, 2e-3, 2e-3, 0.05], seed=1)
    return data, mlid.fit(lateral(free=list(LAT_TRUTH)), data, max_iter=30)


@pytest.fixture(scope="module")
def sixdof_case():
    data, base = sixdof_record()
    assert base.converged
    return data, base


# --- an equations model without states (a regression): alpha*de missing in CL --

REG_TRUTH = dict(CL0=0.2, CLa=5.0, CLde=0.4)
#: The missing term: the elevator's lift falling with alpha, by 3/4 of
#: itself at alpha = 0.1.
REG_TERM, REG_COEF = "alpha*de", -3.0


def regression(extra="", params=REG_TRUTH, **kw):
    return mlid.EquationModel({"CL": "CL0 + CLa*alpha + CLde*de" + extra},
                              inputs=["alpha", "de"], params=params, **kw)


def regression_record(coef=REG_COEF):
    """alpha and de measured inputs, smooth and crossing zero, 32 s at
    25 Hz; noise 5e-3 on CL (seeded); the base model fitted from zero."""
    t = np.arange(800) * 0.04
    u = np.column_stack([0.1 * np.sin(0.5 * t) + 0.03 * np.sin(1.7 * t),
                         0.04 * np.sin(1.1 * t + 1.0)])
    truth = regression(" + CLade*alpha*de", dict(REG_TRUTH, CLade=coef))
    data, _ = mlid.simulate(truth, t, u, noise_std=[5e-3], seed=1)
    return data, mlid.fit(regression(params=dict.fromkeys(REG_TRUTH, 0.0),
                                     free=list(REG_TRUTH)), data)


@pytest.fixture(scope="module")
def regression_case():
    data, base = regression_record()
    assert base.converged
    return data, base


CASES = {"equations": ("equations_case", "the q equation", SP_TERM, SP_COEF),
         "sixdof": ("sixdof_case", "the Cl definition", SIX_TERM, SIX_COEF),
         "regression": ("regression_case", "the CL output", REG_TERM, REG_COEF)}


def case(request, kind):
    fixture, equation, label, coef = CASES[kind]
    data, base = request.getfixturevalue(fixture)
    return data, base, equation, label, coef


def test_where_the_terms_go(equations_case, sixdof_case, regression_case):
    """Equations kind: the equations with a parameter (the outputs alpha
    and q, measuring states, get none); over the states alpha, q and the
    input de: 2 squares, 2 |x|x, 1 pair, 2 with de, 2 x 3 x 2 breakpoints =
    19 each.  Six-DOF kind: CY, Cl, Cn only; alpha and qhat constant over
    the record are left out, u, w, q, theta are kinematic inputs, not
    controls: over beta, phat, rhat and da, dr, 3 + 3 + 3 + 6 + 6
    breakpoints in beta = 21 each.  Without states: the inputs alpha, de
    in the role of states, 2 + 2 + 1 + 12 breakpoints = 17."""
    data, base = equations_case
    cands = terms.candidates(base.model, data)
    eqs = {c.equation for c in cands}
    assert eqs == {"the alpha equation", "the q equation", "the az output"}
    assert len(cands) == 3 * 19
    labels = {c.label for c in cands if c.equation == "the q equation"}
    assert {"alpha^2", "|q|*q", "alpha*q", "q*de"} <= labels
    assert sum(c.label.startswith("max(") for c in cands) == 3 * 12
    data, base = sixdof_case
    cands = terms.candidates(base.model, data)
    assert {c.equation for c in cands} == {"the CY definition", "the Cl definition",
                                           "the Cn definition"}
    assert len(cands) == 3 * 21
    assert not [c for c in cands if "alpha" in c.label or "qhat" in c.label]
    assert {c.label for c in cands if "*d" in c.label} == {
        f"{x}*{u}" for x in ("beta", "phat", "rhat") for u in ("da", "dr")}
    assert len({(c.equation, c.param) for c in cands}) == len(cands)
    data, base = regression_case
    cands = terms.candidates(base.model, data)
    assert {c.equation for c in cands} == {"the CL output"} and len(cands) == 17


@pytest.mark.parametrize("kind", CASES)
def test_the_extended_model_at_zero_is_the_base_model(request, kind):
    """Every candidate: the same outputs to the last bit along the record,
    every existing element by the same name at the same index, the
    settings kept, the coefficient the last p, free, 0."""
    data, base, *_ = case(request, kind)
    model = base.model
    y0 = mlid.simulate(model, data.t, data.u)[0].y
    for c in terms.candidates(model, data):
        m, param = c.extend()
        assert type(m) is type(model) and m.np == model.np + 1
        assert param == c.param and m.free_names()[model.np] == param == m.names[f"p({m.np})"]
        assert m.p[-1] == 0.0 and np.array_equal(m.p[:-1], model.p)
        assert m.free == model.free + [f"p({m.np})"]
        assert all(m.names.get(k, k) == v for k, v in model.names.items())
        for block in ("x0", "bias", "r", "delay", "udelay"):
            assert np.array_equal(getattr(m, block), getattr(model, block))
        np.testing.assert_array_equal(mlid.simulate(m, data.t, data.u)[0].y, y0, err_msg=c.label)


@pytest.mark.parametrize("kind", CASES)
def test_the_gradient_in_the_coefficient_is_the_cost_s(request, kind):
    """Every candidate at the base fit: the core's gradient of the cost in
    the coefficient against central differences of the cost (R re-estimated
    at each point: the concentrated likelihood), step a thousandth of the
    coefficient's own Cramer-Rao sigma s = M_cc^-1/2, compared in cost per
    sigma (g s, the square root of the score when the term is uncorrelated
    with the rest): within 1e-7 of max(1, |g s|).  The differences' own
    error is rounding, 1e-16 |J| s / h ~ 2e-9 (measured 5e-9 on both)."""
    data, base, *_ = case(request, kind)
    errors = []
    for c in terms.candidates(base.model, data):
        m, param = c.extend()
        ev = mlid.evaluate(m, data)
        k = m.free_names().index(param)
        s = 1 / np.sqrt(ev["information"][k, k])
        fd = finite_difference(lambda th: mlid.evaluate(m.with_theta(th), data)["cost"],
                               m.theta, [m.np - 1], rel=1e-3 * s, floor=1.0)[0]
        g = ev["gradient"][k]
        errors.append(abs(fd - g) * s / max(1.0, abs(g) * s))
    assert max(errors) < 1e-7, max(errors)


@pytest.mark.parametrize("kind", CASES)
def test_the_true_term_scores_highest_and_its_fit_recovers_it(request, kind):
    """The truth's term has the largest score statistic of all candidates at
    the base fit, and a fit of its extended model from the base estimate
    recovers the coefficient within 3 Cramer-Rao sigma (a correct fit fails
    this on 0.3% of seeds; the seed is fixed)."""
    data, base, equation, label, coef = case(request, kind)
    cands = terms.candidates(base.model, data)
    scores = [c.score(data) for c in cands]
    best = cands[int(np.argmax(scores))]
    assert (best.equation, best.label) == (equation, label), sorted(
        zip(scores, map(repr, cands)))[-3:]
    model, param = best.extend()
    fit = mlid.fit(model, data, max_iter=30)
    k = fit.names.index(param)
    assert fit.converged
    assert abs(fit.estimate[k] - coef) < 3 * fit.sigma[k], (fit.estimate[k], fit.sigma[k])


@pytest.mark.parametrize("record", [equations_record, sixdof_record, regression_record])
def test_without_the_term_no_score_is_significant(record):
    """The same records simulated without the term (the base model is the
    truth): the scores are chi-square(1) draws, so none passes the 1% level
    with Bonferroni's correction over the candidates (a correct score fails
    this on fewer than 1% of seeds; the seed is fixed).  Catches a score
    on the wrong scale, such as the information of another noise level."""
    data, base = record(0.0)
    assert base.converged
    scores = [c.score(data) for c in terms.candidates(base.model, data)]
    assert max(scores) < chi2.isf(0.01 / len(scores), 1), max(scores)


@pytest.mark.parametrize("model, kind", [
    (mlid.LinearModel([[-1.0]], [[1.0]], [[1.0]]), "LinearModel"),
    (mlid.FlightPathModel(dict(xA=0, yA=0, zA=0, xN=0, yN=0, zN=0, g=9.81)), "FlightPathModel"),
])
def test_another_kind_is_one_line_naming_it(model, kind, equations_case):
    data, _ = equations_case
    with pytest.raises(mlid.InputError, match=f"a {kind} is not a kind") as err:
        terms.candidates(model, data)
    assert "\n" not in str(err.value)
