"""The equations model (kind 'equations', fortran/models/mlid_equations.f90): exact
Jacobians against finite differences for every operation and function, the
same fit as the built-in linear model and as linear least squares, names in
free and tie lists, and bad input as one line in both front ends."""


import numpy as np
import pytest

import mlid
from conftest import run_both

# every operation and function of the language, through chained definitions
EVERYTHING = dict(
    definitions={"c": "0.5", "s1": "a*x1 + b*u1", "s2": "s1^2 - x2^3 + 2^x1 + (1.5 + x2)^b"},
    states={"x1": "-a*x1 + s2/3 + sin(x2)*cos(s1) - tan(0.3*x1) + tanh(b*x2) + t*u1",
            "x2": "asin(0.5*x1) + acos(0.4*x2) + atan(s1) + atan2(x2, 1 + x1) "
                  "- sqrt(1 + s1^2) + abs(x1 - 0.1) + exp(-c*x2) + log(2 + x1) "
                  "+ log10(3 + b*x2) + min(x1, x2) + max(s1, 0) + (-x1)^2 "
                  "+ step(x1 - 0.25)*a*x2"},
    outputs={"y1": "x1/(1 + x2^2)", "y2": "a*b*x2 - u1*x1", "y3": "-(x1 + 2*b)^3"},
    inputs=["u1"], params={"a": 0.7, "b": 1.3})


@pytest.mark.parametrize("x", [[0.2, -0.35], [-0.4, 0.55], [0.31, 0.12]])
def test_jacobians_exact_for_every_operation(x):
    """Reverse-mode partials against central differences: 1e-7 relative
    (measured ~1e-10; the differences' own truncation error is ~1e-9)."""
    m = mlid.EquationModel(**EVERYTHING, free=["a", "b"])
    errs = mlid.check_jacobians(m, x, [0.8])
    assert max(errs.values()) < 1e-7, errs


@pytest.mark.parametrize("x", [[0.2, -0.35, 0.1], [-0.4, 0.55, -0.3]])
def test_jacobians_exact_where_the_equations_share_most_of_their_nodes(x):
    """Three state equations built on one large definition, each swept on
    its own over the nodes it shares (fortran/models/mlid_expr_diff.f90): its
    partials against central differences as above."""
    m = mlid.EquationModel(
        definitions={"s": "a*x1 + b*x2 + sin(x1)*cos(x2) + exp(-x1*x2) + (x1 + a)^2*(x2 - b) "
                          "+ tanh(a*x2 + b*x1) + sqrt(2 + x1*x2) + atan2(x2, 2 + x1)"},
        states={"x1": "-s + u1", "x2": "a*s - x2", "x3": "b*s + x1*x3"},
        outputs={"y1": "x1", "y2": "x2 + u1", "y3": "s*x3"},
        inputs=["u1"], params={"a": 0.7, "b": 1.3}, free=["a", "b"])
    errs = mlid.check_jacobians(m, x, [0.8])
    assert max(errs.values()) < 1e-7, errs


def short_period(**kw):
    return mlid.EquationModel(
        states={"alpha": "Za*alpha + q + Zd*de", "q": "Ma*alpha + Mq*q + Md*de"},
        outputs={"alpha": "alpha", "q": "q", "az": "V*(Za*alpha + Zd*de)"},
        inputs=["de"], definitions={"V": "80"}, **kw)


F0, G0 = [[-1.0, 1.0], [-4.0, -1.5]], [[-0.1], [-6.0]]


def linear_short_period(F, G, **kw):
    F, G = np.asarray(F), np.asarray(G)
    return mlid.LinearModel(F=F, G=G, H=[[1, 0], [0, 1], [80 * F[0, 0], 0]],
                            D=[[0], [0], [80 * G[0, 0]]], **kw)


def record(seed=3):
    t = np.arange(601) * 0.02
    u = np.zeros((t.size, 1))
    u[(t > 1) & (t < 1.5), 0] = 0.05
    u[(t > 1.5) & (t < 2), 0] = -0.05
    truth = linear_short_period(F0, G0)
    d, _ = mlid.simulate(truth, t, u, noise_std=[1e-3, 2e-3, 5e-2], seed=seed)
    return d


def test_the_same_fit_as_the_linear_model():
    """The short period stated as equations and as a linear model with the
    az row tied to the state equation: the same estimates and sigmas (a
    second implementation of the model, the derivatives and the fit)."""
    d = record()
    start = dict(Za=-0.8, Zd=-0.1, Ma=-3.0, Mq=-1.0, Md=-5.0)
    eq = mlid.fit(short_period(params=start, free=list(start)), d)
    F = [[start["Za"], 1.0], [start["Ma"], start["Mq"]]]
    G = [[start["Zd"]], [start["Md"]]]
    lin = mlid.fit(linear_short_period(F, G, free=["f(1,1)", "g(1,1)", "f(2,1)", "f(2,2)",
                                                   "g(2,1)"],
                                       ties={"h(3,1)": "80*f(1,1)", "d(3,1)": "80*g(1,1)"}), d)
    assert eq.converged and lin.converged
    # both in the order of free: Za Zd Ma Mq Md (theta's would be Za Ma Mq Zd Md)
    np.testing.assert_allclose(eq.estimate, lin.estimate, rtol=1e-7)
    np.testing.assert_allclose(eq.sigma, lin.sigma, rtol=1e-6)
    assert eq.cost == pytest.approx(lin.cost, rel=1e-10)


def test_without_states_it_is_linear_least_squares():
    """No states (regression): one Newton step lands on the least-squares
    solution, and the Cramer-Rao sigma is the least-squares standard error
    with the maximum-likelihood residual variance."""
    rng = np.random.default_rng(1)
    t = np.arange(800) * 0.04
    al, de = 0.05 + 0.02 * np.sin(t), 0.01 * np.sign(np.sin(0.7 * t))
    cl = 0.23 + 5.2 * al + 0.4 * de + 1e-3 * rng.standard_normal(t.size)
    m = mlid.EquationModel({"CL": "CL0 + CLa*alpha + CLde*de"}, inputs=["alpha", "de"],
                           params={"CL0": 0, "CLa": 0, "CLde": 0}, free=["CL0", "CLa", "CLde"])
    assert m.nx == 0
    res = mlid.fit(m, mlid.FlightData(t, np.column_stack([al, de]), cl[:, None]))
    X = np.column_stack([np.ones_like(t), al, de])
    beta, *_ = np.linalg.lstsq(X, cl, rcond=None)
    s2 = np.mean((cl - X @ beta) ** 2)
    np.testing.assert_allclose(res.estimate, beta, rtol=1e-9)
    np.testing.assert_allclose(res.sigma, np.sqrt(s2 * np.diag(np.linalg.inv(X.T @ X))),
                               rtol=1e-6)


def test_parameters_by_name_in_free_ties_and_labels():
    m = short_period(params=dict(Za=-0.8, Zd=-0.1, Ma=-3.0, Mq=-1.0, Md=-5.0),
                     free=["Za", "p(3)", "mq", "Md"], ties={"Zd": "0.02*Md"})
    assert m.free == ["p(1)", "p(3)", "p(4)", "p(5)"]
    assert m.names["p(4)"] == "Mq"
    assert m.p[1] == pytest.approx(0.02 * -5.0)
    assert m.tied(np.r_[m.p[:4], -4.0, m.theta[5:]])[1] == pytest.approx(-0.08)


def test_a_parameter_tied_by_several_terms():
    """A tie of several terms (Zd = 0.01 Md + 0.002 Mq) names Zd once for
    each: the parameter Jacobian then has Zd in two columns, each to be its
    partial (the sweep must not give one of them 0).  Gradient against
    central differences of the cost, 2e-4 relative as in test_ties."""
    m = short_period(params=dict(Za=-0.8, Zd=-0.1, Ma=-3.0, Mq=-1.0, Md=-5.0),
                     free=["Ma", "Mq", "Md"], ties={"Zd": "0.01*Md + 0.002*Mq"})
    data = record()
    ev = mlid.evaluate(m, data)
    free = m.free_indices()
    for k, i in enumerate(free):
        h = 1e-6 * max(1.0, abs(m.theta[i]))
        cost = []
        for step in (h, -h):
            th = m.theta.copy()
            th[i] += step
            cost.append(mlid.evaluate(m.with_theta(m.tied(th)), data)["cost"])
        fd = (cost[0] - cost[1]) / (2 * h)
        assert fd == pytest.approx(ev["gradient"][k], rel=2e-4,
                                   abs=1e-6 * abs(ev["gradient"]).max()), m.free[k]


@pytest.mark.parametrize("kw, message", [
    ({"outputs": {"y": "x + zz"}}, "equations model, output y: 'x \\+ zz' at character 5: "
                                   "no variable named zz"),
    ({"outputs": {"y": "x"}, "inputs": ["x"]}, "the name 'x' is given twice"),
    ({"outputs": {"y": "x"}, "definitions": {"t": "1"}}, "the name 't' is given twice"),
    ({"outputs": {"y": "x*(2"}}, "output y: 'x\\*\\(2' at character 5: '\\)' is missing"),
    ({"outputs": {}}, "equations model: no outputs"),
    ({"outputs": {"y": "x"}, "params": {"2b": 0}}, "'2b' is not a name"),
    ({"outputs": {"y": "x" + " + x" * 300}}, "output y: '\\.\\.\\.x \\+ x.*at character \\d+: the "
                                              "expression is too long"),
    ({"outputs": {"y": "x"},          # 85 distinct terms each: shared subexpressions are not
      "definitions": {f"d{k}": " + ".join(f"{k + i / 1000}*x" for i in range(85))
                      for k in range(17)}},      # counted twice
     "definition d15: the equations and definitions together pass 4096 operations"),
])
def test_bad_models_are_one_line(kw, message):
    with pytest.raises(mlid.InputError, match=message) as err:
        mlid.EquationModel(states={"x": "-x"}, **kw)
    assert "\n" not in str(err.value)


DECK = """&case title = 'first order', job = 'estimate' /
&model kind = 'equations', state_names = 'x', input_names = 'u', output_names = 'y',
    params = 'a = -1.5', 'b = 0.5', xdot = '{xdot}', outputs = 'x',
    {extra} free = 'a', 'b' /
&data file = 'fo.dat', time_col = 1, input_cols = 2, output_cols = 3 /
&estimate max_iter = 20 /
&case title = 'the next case', job = 'estimate' /
&model kind = 'equations', state_names = 'x', input_names = 'u', params = 'a = -1.5',
    xdot = 'a*x + u', outputs = 'x', free = 'a' /
&data file = 'fo.dat', time_col = 1, input_cols = 2, output_cols = 3 /
"""


def first_order_file(path):
    t = np.arange(301) * 0.05
    u = np.where((t > 1) & (t < 3), 1.0, 0.0)
    m = mlid.EquationModel({"y": "x"}, states={"x": "a*x + b*u"}, inputs=["u"],
                           params={"a": -2.0, "b": 0.8})
    d, _ = mlid.simulate(m, t, u[:, None], noise_std=[0.01], seed=2)
    np.savetxt(path, np.column_stack([d.t, d.u, d.y]))


def same_report(deck, tmp_path):
    """Both front ends' run of deck: the same report and exit status; the first."""
    outs = run_both(deck, cwd=tmp_path)
    assert outs[0].returncode == outs[1].returncode, (outs[0].stderr, outs[1].stderr)
    assert outs[0].stdout == outs[1].stdout, (outs[0].stdout, outs[1].stdout)
    return outs[0]


def test_a_deck_fits_in_both_front_ends(tmp_path):
    """The deck's fit recovers the truth within 4 sigma, the same in both front ends."""
    first_order_file(tmp_path / "fo.dat")
    deck = tmp_path / "fo.nml"
    deck.write_text(DECK.format(xdot="a*x + b*u", extra=""))
    run = same_report(deck, tmp_path)
    assert run.returncode == 0, run.stderr
    out = run.stdout
    case = mlid.read_deck(deck)[0]
    _, res = mlid.cli.deck.run_case(case)
    assert res.converged
    assert np.all(np.abs(np.asarray(res.estimate) - [-2.0, 0.8]) < 4 * np.asarray(res.sigma))
    assert " a " in out and " b " in out


@pytest.mark.parametrize("xdot, extra, message", [
    ("a*x + c*u", "", "equations model, state x: 'a\\*x \\+ c\\*u' at character 7: no variable "
                      "named c"),
    ("a*x + b*u", "initial_states = 1, 2,", "initial_states has 2 values; nx = 1 for each of "
                                            "the 1 data files needs 1"),
    ("a*x + b*u", "tie = 'b = 2*zz',", "'zz' is no parameter"),
    ("a*x + b*u", "definitions = 'a = 2',", "the name 'a' is given twice"),
    ("a*x + b*u", "definitions = 'pi = 3',", "the name 'pi' is given twice or reserved"),
    ("a*x + b*u", "params = 'a = 2 3', 'b',", "params entry 'a = 2 3': '2 3' at character 3: "
                                            "unexpected '3'"),
    ("a*x + b*u", "params = 'a = -1.5 junk', 'b',", "params entry 'a = -1.5 junk'"),
    ("a*x + b*u", "p = 1, 2,", "takes its parameters in params"),
    ("a*x + b*u", "state_names = 'x', '', 'z',", "state_names\\(2\\) is empty"),
    ("a*x + b*u", "output_names = 'y', 'z',", "input_names and output_names name every input "
                                              "and output \\(nu = 1, ny = 1\\) or none"),
    ("a*x + b*u", "tie = 'b = 2 * a (1)',", "tie 'b = 2 \\* a \\(1\\)': 'a \\(1\\)' is no parameter"),
])
def test_bad_decks_are_one_line_and_the_rest_runs(tmp_path, xdot, extra, message):
    first_order_file(tmp_path / "fo.dat")
    deck = tmp_path / "fo.nml"
    text = DECK.format(xdot=xdot, extra=extra)
    # extra's name replaces the first case's own (a name given twice is refused)
    for given in ("params = 'a = -1.5', 'b = 0.5', ", "state_names = 'x', ", "output_names = 'y',"):
        if extra.startswith(given.split(" =")[0] + " ="):
            text = text.replace(given, "", 1)
    deck.write_text(text)
    out = same_report(deck, tmp_path).stdout
    import re
    bad = [line for line in out.splitlines() if re.search(message, line)]
    assert len(bad) == 1, out
    assert "the next case" in out and "converged" in out


def test_params_values_are_expressions_and_one_file_takes_initial_states(tmp_path):
    """'a = -3/2' is -1.5 (never a list-directed read); initial_states with one
    data file is that manoeuvre's x0, the same in both front ends."""
    first_order_file(tmp_path / "fo.dat")
    deck = tmp_path / "fo.nml"
    deck.write_text(DECK.format(xdot="a*x + b*u", extra="initial_states = 0.25,")
                    .replace("'a = -1.5', 'b = 0.5'", "'a = -3/2', 'b = 2^-1'"))
    assert same_report(deck, tmp_path).returncode == 0
    case = mlid.read_deck(deck)[0]
    assert list(case.model.p) == [-1.5, 0.5]
    assert case.model.x0[0] == 0.25


def test_a_simulate_case_refuses_initial_states(tmp_path):
    deck = tmp_path / "s.nml"
    deck.write_text("""&case title = 's', job = 'simulate' /
&model kind = 'equations', state_names = 'x', input_names = 'u', params = 'a = -1',
    xdot = 'a*x + u', outputs = 'x', initial_states = 1 /
&simulate out = 's.dat', t_end = 1, dt = 0.1 /
""")
    out = same_report(deck, tmp_path).stdout
    assert "initial_states is for estimate cases" in out


def test_entries_of_another_kind_are_refused(tmp_path):
    deck = tmp_path / "l.nml"
    deck.write_text("""&case title = 'l', job = 'simulate' /
&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1, g = 1, h = 1, xdot = 'x' /
&simulate out = 's.dat', t_end = 1, dt = 0.1 /
""")
    assert "xdot, outputs, definitions and params are for kind = 'equations'" in \
        same_report(deck, tmp_path).stdout


def test_power_zero_and_names_in_python():
    """x^0 has the derivative 0 (not 0*Inf = NaN at x = 0); a name must be
    one word, and inputs a list."""
    m = mlid.EquationModel({"y": "x^0 + x^2"}, states={"x": "-x + u^1"}, inputs=["u"])
    assert max(mlid.check_jacobians(m, [0.0], [0.0]).values()) < 1e-7
    with pytest.raises(mlid.InputError, match="inputs must be a list"):
        mlid.EquationModel({"y": "d"}, inputs="de")
    with pytest.raises(mlid.InputError, match="is not a name"):
        mlid.EquationModel({"y": "k"}, params={"k\nx b = 1": 1.0})
