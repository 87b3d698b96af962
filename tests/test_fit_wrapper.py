"""What fit() does around the core call: the core's option arrays kept by the
options given (the core still checks every name and value: a bad one gives
the core's message every time), and the fields a FitResult makes when first
asked for (model, manoeuvres, param_units), which must be those of the fit
as it was made, whatever happens to the model afterwards."""

import pickle

import numpy as np
import pytest

import mlid
from mlid._bridge import api as _api
from conftest import c8_record, c8_start

GIVEN = {"max_iter": 7, "tol_cost": 1e-7, "noise": "full", "partials": False,
         "rank_rule": "staged"}


@pytest.fixture(scope="module")
def data():
    return c8_record()


def test_a_fits_options_are_the_defaults_with_the_given_ones(data):
    want = mlid.default_options()
    assert mlid.fit(c8_start(), data).options == want
    want.update(GIVEN)
    first = mlid.fit(c8_start(), data, **GIVEN)
    assert first.options == want and first.iterations <= 7
    # what a result holds is its own: changing it changes no later fit
    first.options["max_iter"] = 1
    first.flat_options[:] = 0
    first.flat_real_options[:] = 0
    second = mlid.fit(c8_start(), data, **GIVEN)
    assert second.options == want
    assert second.estimate.tolist() == mlid.fit(c8_start(), data, **GIVEN).estimate.tolist()
    # numpy scalars are the same options as Python's
    numpy_given = dict(GIVEN, max_iter=np.int64(7), tol_cost=np.float64(1e-7),
                       partials=np.bool_(False))
    assert mlid.fit(c8_start(), data, **numpy_given).options == want
    # the model's own options are the model's, not the fit's
    assert "input_hold" not in second.options and "substeps" not in second.options


def _core_says(name, text):
    """The core's message for one option set by name on the defaults."""
    iopt, ropt = _api.mlid_default_options()
    status, msg = _api.mlid_option_set(iopt, ropt, name, text)
    if status == 0:
        status, msg = _api.mlid_options_check(iopt, ropt)
    assert status != 0
    return msg.decode().strip()


@pytest.mark.parametrize("name, value, text", [
    ("noise", "bogus", "bogus"), ("max_iter", -1, "-1"), ("max_iter", 2.5, "2.5"),
    ("tol_cost", float("nan"), "nan"), ("partials", 3, "3")])
def test_a_bad_option_gives_the_cores_message_every_time(data, name, value, text):
    for _ in range(2):                  # an error is never kept as an answer
        with pytest.raises(mlid.InputError) as exc:
            mlid.fit(c8_start(), data, **{name: value})
        assert str(exc.value) == _core_says(name, text)
    with pytest.raises(mlid.InputError) as exc:
        mlid.evaluate(c8_start(), data, **{name: value})
    assert str(exc.value) == _core_says(name, text)
    # the option's good values still go through
    good = mlid.default_options()[name]
    assert mlid.fit(c8_start(), data, **{name: good}).options[name] == good


def test_an_unknown_option_and_a_bad_model_option(data):
    for _ in range(2):
        with pytest.raises(mlid.InputError, match="^unknown option 'bogus'; known: max_iter, "):
            mlid.fit(c8_start(), data, bogus=1)
    model = c8_start()
    model.substeps = 0
    with pytest.raises(mlid.InputError) as exc:
        mlid.fit(model, data)
    assert str(exc.value) == _core_says("substeps", "0")


def _made_now(res):
    """The fields a result makes when asked, asked for now."""
    return (res.model.theta.tolist(), res.model.free_names(), dict(res.model.names),
            [m.theta.tolist() for m in res.manoeuvres], list(res.param_units))


def _change(model):
    """Everything of a model a user might change after fitting it."""
    model.x0 = [1.0, 2.0, 3.0, 4.0]
    model.F[1, 1] = 7.0
    model.names["f(2,2)"] = "renamed"
    model.free = model.free[:2]


def test_fields_made_later_are_those_of_the_fit(data):
    model = c8_start()
    eager = _made_now(mlid.fit(model, data))
    late = mlid.fit(model, data)
    _change(model)
    assert _made_now(late) == eager
    # and they are what they say: the start model with the estimates put in
    start = c8_start()
    theta = start.theta
    theta[start.free_indices()] = late.estimate
    assert late.model.theta.tolist() == theta.tolist()
    assert late.model.free_names() == late.names
    assert late.manoeuvres[0].theta.tolist() == theta.tolist()
    assert late.manoeuvres[0] is not late.model
    units = start.param_units(data.input_units, data.output_units)
    assert late.param_units == [units[k] for k in start.free_indices()]
    assert late.model is late.model     # made once
    # a result travels with them made or not
    copy = pickle.loads(pickle.dumps(mlid.fit(c8_start(), data)))
    assert _made_now(copy) == eager


def test_several_manoeuvres_fields_made_later(data):
    records = [data, c8_record(seed=2)]
    x0s = [np.zeros(4), np.full(4, 0.01)]

    def joint(model):
        return mlid.fit(model, records, initial_states=x0s, biases=[np.zeros(4)] * 2)

    model = c8_start()
    eager = _made_now(joint(model))
    late = joint(model)
    _change(model)
    assert _made_now(late) == eager
    assert [m.x0.tolist() for m in late.manoeuvres] == [x.tolist() for x in x0s]


def test_a_failed_fit_makes_them_too():
    truth = mlid.LinearModel([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2))
    t = np.arange(200) * 0.02
    record = mlid.simulate(truth, t, np.sin(3 * t)[:, None], [0.01, 0.01], seed=3)[0]
    model = mlid.LinearModel([[1000.0, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2),
                             free=["f(1,1)"])
    with pytest.raises(mlid.DivergenceError) as exc:
        mlid.fit(model, record)
    res = exc.value.result
    assert res.failed and res.model.F[0, 0] == 1000.0
    assert res.manoeuvres[0].theta.tolist() == model.theta.tolist()
    assert res.param_units == [""]


# ---- results keyed by name (issue 42, results out) ------------------------------

def _named_fit(manoeuvres=1):
    m = mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], [[1.0], [0.3]], np.eye(2),
                         free=["f(1,1)", "g(1,1)"], names={"f(1,1)": "Mq", "g(1,1)": "Mde"})
    t = np.arange(101) * 0.02
    d, _ = mlid.simulate(m, t, np.sin(3 * t)[:, None], [0.01, 0.01], seed=3)
    d.output_names = ["q", "theta"]
    return mlid.fit(m, d if manoeuvres == 1 else [d] * manoeuvres), d


def test_params_are_keyed_by_name():
    res, _ = _named_fit()
    p = res.params
    assert list(p.index) == res.names == ["Mq", "Mde"]
    assert p.loc["Mq", "estimate"] == res.estimate[0]
    assert p.loc["Mde", "sigma_cr"] == res.sigma[1]
    assert res.to_frame().equals(p)


def test_outputs_and_residuals_as_time_indexed_frames():
    res, d = _named_fit()
    f = res.outputs_frame()
    assert list(f.columns.get_level_values(1)[:2]) == ["q", "theta"]
    assert np.array_equal(f.index.to_numpy(), d.t)
    assert np.array_equal(f["measured"].to_numpy(), d.y)
    assert np.allclose(f["residual"].to_numpy(), d.y - res.yhat)
    assert list(res.residuals_frame().columns) == ["q", "theta"]
    assert [w["output"] for w in res.whiteness()] == ["q", "theta"]


def test_several_manoeuvres_each_on_its_own_time():
    res, d = _named_fit(manoeuvres=2)
    f = res.residuals_frame()
    assert f.index.names == ["manoeuvre", "t"]
    assert np.array_equal(f.loc[2].index.to_numpy(), d.t)


def test_sensitivity_norms_by_name():
    res, _ = _named_fit()
    f = res.sensitivity_frame()
    assert list(f.index) == ["Mq", "Mde"] and list(f.columns) == ["q", "theta"]
    assert np.array_equal(f.to_numpy(), res.sensitivity_norms().T)


def test_the_report_names_each_output_under_the_noise_diagonal(tmp_path):
    """Issue 42, text: 'R diagonal' named no outputs.  Each value has its
    output's name under it, right-aligned in its column, and its unit
    squared when the record has units; the same from mlid-batch."""
    res, data = _named_fit()
    lines = res.report().split("\n")
    k = next(i for i, ln in enumerate(lines) if ln.startswith(" R diagonal:"))
    values, names = lines[k], lines[k + 1]
    assert names.split() == ["output:", "q", "theta"]
    for name, v in zip(("q", "theta"), values.split()[2:]):       # right ends aligned
        assert names.index(name) + len(name) == values.index(v) + len(v)
    assert not lines[k + 2].startswith(" unit:")                  # no units: no line
    assert res.identifiability()[0].startswith(" normalised information")
    deck = tmp_path / "d.nml"
    deck.write_text("&case title = 'u', job = 'estimate' /\n&model kind = 'linear', nx = 2, "
                    "nu = 1, ny = 2, f = -1.0, 0.5, -0.8, -2.0, g = 1.0, 0.3, h = 1, 0, 0, 1,\n"
                    "    free = 'f(1,1)', 'g(1,1)' /\n&data file = 'r.csv', time_col = 't', "
                    "input_cols = 'de', output_cols = 'q', 'theta' /\n")
    t = data.t
    (tmp_path / "r.csv").write_text("t,de[deg],q[deg/s],theta[deg]\n" + "".join(
        f"{a},{np.degrees(b)},{np.degrees(c)},{np.degrees(d)}\n"
        for a, b, c, d in zip(t, data.u[:, 0], data.y[:, 0], data.y[:, 1])))
    import subprocess
    from conftest import BIN
    out = subprocess.run([str(BIN / "mlid-batch"), deck.name], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120).stdout.split("\n")
    k = next(i for i, ln in enumerate(out) if ln.startswith(" R diagonal:"))
    assert out[k + 1].split() == ["output:", "q", "theta"]
    assert out[k + 2].split() == ["unit:", "(rad/s)^2", "rad^2"]
