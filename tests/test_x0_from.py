"""x0 from the first samples (issue 43 item 4): &estimate x0_from = 'first'
or 'mean' (with x0_samples = k) starts each manoeuvre's measured states at
its own record's first sample or the mean of its first k, less the output's
bias (fortran/models/mlid_initial_states.f90); mlid.fit's x0_from and
x0_samples are the same rule.  A deck with x0 typed in gives the same fit as
x0_from = 'first' when the typed values are the first samples; a state no
output measures keeps the deck's x0; both front ends give the same bytes;
bad values are one line each."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, REPO

SIM = """
&case title = 'make data {n}', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.2, 0.5, -1.0, -2.0,   g = 1.5, 0.3,   h = 1, 0, 1, 1, x0 = {x0} /
&simulate out = 'm{n}.dat', t_end = 4.0, dt = 0.02, seed = {n}, noise_std = 0.01, 0.01,
    input_shape = '3211', amplitude = 1.0, t_start = 0.2, pulse_width = 0.2 /
"""
# output 1 is state 1 (H's row e_1); output 2 = x1 + x2 measures no state alone
FIT = """
&case title = 'fit', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0, g = 1.0, 0.3, h = 1, 0, 1, 1, x0 = {x0}, -0.2, {model}
    free = 'f(1,1)', 'f(2,1)', 'g(1,1)'{free} /
&data file = {files}, time_col = 1, input_cols = 2, output_cols = 3, 4 /
{estimate}"""


def _fit(x0="0.0", model="", free=", 'x0(1)', 'x0(2)'", files="'m1.dat'", estimate=""):
    return FIT.format(x0=x0, model=model, free=free, files=files, estimate=estimate)


def _run(deck, front="fo"):
    cmd = [str(BIN / "mlid"), "run"] if front == "py" else [str(BIN / "mlid-batch")]
    json_path = deck.with_suffix(f".{front}.json")
    out = subprocess.run(cmd + [str(deck), "--json", str(json_path)], capture_output=True,
                         text=True)
    return out, json.loads(json_path.read_text())


@pytest.fixture()
def records(tmp_path):
    """Two records of the same aircraft from different initial states."""
    deck = tmp_path / "sim.nml"
    deck.write_text(SIM.format(n=1, x0="0.3, -0.2") + SIM.format(n=2, x0="-0.25, 0.4"))
    out, _ = _run(deck)
    assert out.returncode == 0, out.stderr
    return tmp_path, [np.loadtxt(tmp_path / f"m{n}.dat") for n in (1, 2)]


def test_typed_first_samples_and_x0_from_first_give_the_same_fit(records):
    """x0(1) typed as the record's first alpha (the 17 digits the file holds)
    and x0_from = 'first': the same report and JSON, x0 free and held, from
    both front ends."""
    folder, (m1, _) = records
    first = repr(float(m1[0, 2]))
    typed = folder / "typed.nml"
    typed.write_text(_fit(x0=first) + _fit(x0=first, free=""))
    rule = folder / "rule.nml"
    rule.write_text(_fit(estimate="&estimate x0_from = 'first' /")
                    + _fit(free="", estimate="&estimate x0_from = 'first' /"))
    runs = {(d.stem, f): _run(d, f) for d in (typed, rule) for f in ("fo", "py")}
    for (stem, front), (out, cases) in runs.items():
        assert out.returncode == 0, (stem, front, out.stderr)
        assert all(c["converged"] for c in cases)
    assert runs["rule", "fo"][1] == runs["typed", "fo"][1]
    assert runs["rule", "fo"][0].stdout == runs["typed", "fo"][0].stdout
    for stem in ("typed", "rule"):
        assert runs[stem, "py"][0].stdout == runs[stem, "fo"][0].stdout
        assert typed.with_suffix(".py.json").read_bytes() == typed.with_suffix(".fo.json").read_bytes()
        assert rule.with_suffix(".py.json").read_bytes() == rule.with_suffix(".fo.json").read_bytes()
    cases = runs["rule", "fo"][1]
    # the start: x0(1) the first sample, x0(2) (no output measures it) the deck's
    assert cases[0]["start"][3:] == [float(m1[0, 2]), -0.2]
    assert cases[0]["start"][3] != 0.0


def test_mean_of_k_samples_less_the_bias_and_an_unmeasured_state(records):
    folder, (m1, _) = records
    deck = folder / "mean.nml"
    deck.write_text(_fit(model="bias = 0.1, 0.0,",
                         estimate="&estimate x0_from = 'mean', x0_samples = 5 /"))
    out, cases = _run(deck)
    assert out.returncode == 0, out.stderr
    np.testing.assert_allclose(cases[0]["start"][3], m1[:5, 2].mean() - 0.1, rtol=1e-15)
    assert cases[0]["start"][4] == -0.2
    out_py, cases_py = _run(deck, "py")
    assert out_py.stdout == out.stdout and cases_py == cases


def test_each_manoeuvre_takes_its_own_first_samples(records):
    """Two files: x0(1)#1 and x0(1)#2 start at each record's own first
    sample; the deck's x0(2) for both; the fit lands near each truth."""
    folder, (m1, m2) = records
    deck = folder / "two.nml"
    deck.write_text(_fit(files="'m1.dat', 'm2.dat'", estimate="&estimate x0_from = 'first' /"))
    out, cases = _run(deck)
    assert out.returncode == 0, out.stderr
    names = cases[0]["parameters"]
    start = dict(zip(names, cases[0]["start"]))
    assert start["x0(1)#1"] == m1[0, 2] and start["x0(1)#2"] == m2[0, 2]
    assert start["x0(2)#1"] == start["x0(2)#2"] == -0.2
    est = dict(zip(names, cases[0]["estimate"]))
    np.testing.assert_allclose([est["x0(2)#1"], est["x0(2)#2"]], [-0.2, 0.4], atol=0.05)
    # the Python API on the deck's case: the same start and estimate, to the bit
    case = mlid.read_deck(deck)[0]
    assert case.options()["x0_from"] == "first"
    res = mlid.fit(case.model, case.record(), **case.options())
    assert res.start.tolist() == cases[0]["start"]
    assert res.estimate.tolist() == cases[0]["estimate"]
    _, cases_py = _run(deck, "py")
    assert cases_py == cases


def test_python_fit_takes_x0_from_as_the_deck_does(records):
    folder, (m1, _) = records
    data = mlid.FlightData(m1[:, 0], m1[:, 1:2], m1[:, 2:4])
    model = mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], [[1.0], [0.3]], [[1, 0], [1, 1]],
                             x0=[0.0, -0.2], bias=[0.1, 0.0],
                             free=["f(1,1)", "f(2,1)", "g(1,1)", "x0(1)", "x0(2)"])
    res = mlid.fit(model, data, x0_from="mean", x0_samples=5)
    deck = folder / "mean.nml"
    deck.write_text(_fit(model="bias = 0.1, 0.0,",
                         estimate="&estimate x0_from = 'mean', x0_samples = 5 /"))
    _, cases = _run(deck)
    assert res.start.tolist() == cases[0]["start"]
    np.testing.assert_allclose(res.estimate, cases[0]["estimate"], rtol=1e-12)
    # held, not free: x0 stays at the first sample
    held = mlid.LinearModel(model.F, model.G, model.H, x0=model.x0, bias=model.bias,
                            free=["f(1,1)", "f(2,1)", "g(1,1)"])
    res_held = mlid.fit(held, data, x0_from="first")
    assert res_held.model.x0[0] == m1[0, 2] - 0.1 and res_held.model.x0[1] == -0.2
    # the rule in any case, as the deck reads it
    assert mlid.fit(held, data, x0_from="First").estimate.tolist() == res_held.estimate.tolist()
    ev = mlid.evaluate(held, data, x0_from="first")
    assert np.isfinite(ev["cost"])


def test_an_equations_output_written_as_the_state_is_measured():
    """Output 'alpha = alpha' measures state alpha; 'nz = ...' none: q keeps its x0."""
    model = mlid.EquationModel(
        states={"alpha": "Za*alpha + q + Zd*de", "q": "Ma*alpha + Mq*q + Md*de"},
        outputs={"alpha": "alpha", "nz": "alpha + 0.5*q"}, inputs=["de"],
        params={"Za": -0.8, "Ma": -4.0, "Mq": -1.2, "Zd": -0.1, "Md": -6.0},
        x0=[0.0, 0.02], free=["Za", "x0(1)", "x0(2)"])
    t = np.arange(0, 4.0, 0.02)
    u = np.where((t > 0.5) & (t < 1.0), 0.05, 0.0)[:, None]
    truth = model.with_theta(model.theta)
    truth.x0 = [0.07, 0.02]
    data, _ = mlid.simulate(truth, t, u, noise_std=[0.001, 0.001], seed=2)
    res = mlid.fit(model, data, x0_from="first", max_iter=0)
    assert res.start[1:].tolist() == [data.y[0, 0], 0.02]


def test_a_validate_case_predicts_each_held_out_record_from_its_own_first_sample(records):
    """x0 held: the held-out manoeuvre is predicted from its own first alpha
    (the deck's x0 = 0 would miss it), the same in both front ends."""
    folder, (_, m2) = records
    deck = folder / "validate.nml"
    deck.write_text(_fit(free="", files="'m1.dat', 'm2.dat'", estimate="&estimate x0_from = "
                         "'first' /").replace("'estimate' /", "'validate' /").replace(
                             "output_cols = 3, 4", "output_cols = 3, 4, holdout = 2"))
    out, cases = _run(deck)
    assert out.returncode == 0, out.stderr
    out_py, cases_py = _run(deck, "py")
    assert out_py.stdout == out.stdout and cases_py == cases
    case = mlid.read_deck(deck)[0]
    _, result = mlid.cli.deck.run_case(case)
    pred = result.validation.prediction.yhat
    assert pred[0, 0] == m2[0, 2]              # y1 = x1 at the first sample
    assert abs(pred[0, 0]) > 0.2
    # mlid.validate on the fit of the first record: the same prediction
    m2_data = case.record([2])[0]
    own = mlid.validate(result, m2_data, holdout=[2], x0_from="first")
    np.testing.assert_allclose(own.prediction.yhat, pred, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(own.theil, result.validation.theil, rtol=1e-12)


BAD = {
    "unknown word": ("&estimate x0_from = 'last' /",
                     "group &estimate: x0_from must be 'first' or 'mean', got 'last'"),
    "k below 1": ("&estimate x0_from = 'mean', x0_samples = 0 /",
                  "x0_from = 'mean' needs x0_samples >= 1 (the samples averaged), got 0"),
    "k with first": ("&estimate x0_from = 'first', x0_samples = 4 /",
                     "x0_samples is for x0_from = 'mean'"),
    "k without x0_from": ("&estimate x0_samples = 4 /", "x0_samples is for x0_from = 'mean'"),
    "k beyond the record": ("&estimate x0_from = 'mean', x0_samples = 500 /",
                            "x0_samples = 500 is more than the 201 samples of manoeuvre 1"),
    "no output is a state": ("&estimate x0_from = 'first' /", "x0_from: no output is one of the "
                             "states"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_x0_from_is_one_line_in_both_front_ends(records, name):
    folder, _ = records
    group, phrase = BAD[name]
    bad = _fit(estimate=group).replace("'fit'", "'bad'")
    if name == "no output is a state":
        bad = bad.replace("h = 1, 0, 1, 1", "h = 1, 0.5, 1, 1")
    deck = folder / "batch.nml"
    deck.write_text(_fit() + bad + _fit().replace("'fit'", "'after'"))
    outs = {}
    for front, who in (("py", "mlid"), ("fo", "mlid-batch")):
        out, _ = _run(deck, front)
        assert out.returncode == 1, (who, out.stdout, out.stderr)
        assert "Traceback" not in out.stderr
        errors = [ln for ln in out.stderr.splitlines() if ln.startswith(who + ":")]
        assert len(errors) == 1, (who, out.stderr)
        assert f"{deck} case 2 (line 8) 'bad': " in errors[0] and phrase in errors[0], errors[0]
        assert out.stdout.count("converged (") == 2, out.stdout      # before and after
        outs[front] = (out.stdout, errors[0].split("': ", 1)[1])
    assert outs["py"] == outs["fo"]


def test_a_model_that_cannot_say_and_a_monte_carlo_are_refused(tmp_path):
    deck = tmp_path / "user.nml"
    user = (REPO / "cases" / "user_model" / "cubic_short_period.nml").read_text()
    deck.write_text(user.replace("&estimate max_iter = 30 /",
                                 "&estimate max_iter = 30, x0_from = 'first' /") + """
&case title = 'mc', job = 'monte_carlo' /
&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1, g = 1, h = 1, r = 1e-4, free = 'f(1,1)' /
&monte_carlo runs = 2, input_file = 'cubic_doublet.dat' /
&estimate x0_from = 'first' /
""")
    outs = {}
    for front, who in (("py", "mlid"), ("fo", "mlid-batch")):
        out, _ = _run(deck, front)
        errors = [ln for ln in out.stderr.splitlines() if ln.startswith(who + ":")]
        assert len(errors) == 2, out.stderr
        assert "case 2 (line 14)" in errors[0] and "x0_from: a model of kind 'user' cannot say " \
            "which output is which state" in errors[0], errors[0]
        assert "case 3 (line" in errors[1] and "x0_from is for the fits of estimate and " \
            "validate cases" in errors[1], errors[1]
        outs[front] = out.stdout
    assert outs["py"] == outs["fo"]
    # the same refusal from the Python API
    case = mlid.read_deck(deck)[1]
    with pytest.raises(mlid.InputError, match="cannot say which output is which state"):
        mlid.fit(case.model, case.record(), x0_from="first")


def test_python_refuses_bad_values(records):
    _, (m1, _) = records
    data = mlid.FlightData(m1[:, 0], m1[:, 1:2], m1[:, 2:4])
    model = mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], [[1.0], [0.3]], [[1, 0], [1, 1]],
                             free=["f(1,1)"])
    for kw, phrase in (({"x0_from": "last"}, "x0_from must be 'first' or 'mean'"),
                       ({"x0_from": 3}, "x0_from must be 'first' or 'mean'"),
                       ({"x0_samples": 3}, "x0_samples is for x0_from = 'mean'"),
                       ({"x0_from": "mean"}, "needs x0_samples >= 1"),
                       ({"x0_from": "mean", "x0_samples": 2.5}, "x0_samples must be a whole"),
                       ({"x0_from": "mean", "x0_samples": 202},
                        "x0_samples = 202 is more than the 201 samples of manoeuvre 1")):
        with pytest.raises(mlid.InputError, match=phrase.replace("(", r"\(")):
            mlid.fit(model, data, **kw)


DATA = REPO.parent / "shared" / "data"


@pytest.mark.skipif(not DATA.is_dir(), reason="real flight data not beside the checkout")
def test_real_records_in_the_units_the_fit_sees():
    """ATTAS test case 11 (cases/attas_channels, case 2) types x0 as the
    first samples of elevator 1 in rad (its channels are in deg): x0_from =
    'first' on that record gives the same x0 to the deck's 10 digits and
    the same fit; HFB-320's longitudinal model (cases/hfb320) starts its
    four states at the first samples of V, alpha, theta, q."""
    case = mlid.read_deck(REPO / "cases" / "attas_channels" / "attas_sp.nml")[1]
    elv1 = case.record()[0]
    typed = mlid.fit(case.model, elv1, **case.options())
    model = case.model.with_theta(case.model.theta)
    model.x0 = [0.0, 0.0]
    res = mlid.fit(model, elv1, x0_from="first", **case.options())
    np.testing.assert_allclose(res.model.x0, case.model.x0, rtol=0, atol=5e-11)   # 10 digits
    np.testing.assert_allclose(res.estimate, typed.estimate, rtol=1e-6)
    hfb = mlid.read_deck(REPO / "cases" / "hfb320" / "hfb320.nml")[0]
    data = hfb.record()
    opts = dict(hfb.options(), max_iter=0)
    res = mlid.fit(hfb.model, data, x0_from="first", **opts)
    assert res.model.x0.tolist() == data.y[0, :4].tolist()
    assert hfb.model.x0.tolist() != data.y[0, :4].tolist()     # the reference's own x0


@pytest.mark.skipif(not DATA.is_dir(), reason="real flight data not beside the checkout")
def test_flight_path_outputs_written_as_states_on_three_manoeuvres():
    """cases/flight_path/tc22 types each manoeuvre's initial_states: u, v, w
    from the air data, phi, theta, psi, h the first samples (deg -> rad, ft
    -> m) to its digits.  x0_from = 'first' sets those four from each
    record (the outputs 'phi', ..., 'h' are written as the states), keeps
    u, v, w, and gives the same fit to 1e-5 sigma (the deck is left as it
    is: its published numbers come from its typed digits)."""
    case = mlid.read_deck(REPO / "cases" / "flight_path" / "tc22.nml")[0]
    data, opts = case.record(), case.options()
    typed = np.array(opts["initial_states"])
    res = mlid.fit(case.model, data, x0_from="first", **opts)
    for k, (m, rec) in enumerate(zip(res.manoeuvres, data)):
        assert m.x0[3:].tolist() == rec.y[0, 3:].tolist()
        assert m.x0[:3].tolist() == typed[k, :3].tolist()
        np.testing.assert_allclose(m.x0[3:], typed[k, 3:], rtol=0, atol=1e-9)
    ref = mlid.fit(case.model, data, **opts)
    assert np.all(np.abs(res.estimate - ref.estimate) < 1e-5 * ref.sigma)
    np.testing.assert_allclose(res.sigma, ref.sigma, rtol=1e-6)
