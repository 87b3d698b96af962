"""Validation (mlid.validate, the deck job 'validate' of both front ends):
fit on some manoeuvres, predict the others with their own initial state and
biases fitted and every other parameter held.  Theil's U and rms/sigma are
checked against numpy on the prediction; rms/sigma against what the noise
and the Cramer-Rao bound allow."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN

F = [[-1.0, 0.9], [-4.0, -1.5]]
G = [[-0.1], [-6.0]]
NOISE = np.array([2e-3, 5e-3])
FREE = ["f(1,1)", "f(1,2)", "f(2,1)", "f(2,2)", "g(1,1)", "g(2,1)", "x0(1)", "x0(2)"]


def truth(**kw):
    return mlid.LinearModel(F=F, G=G, H=np.eye(2), **kw)


def manoeuvre(seed, x0=(0.0, 0.0), nt=601, dt=0.02):
    """A doublet and a pulse at times of its own, seeded noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(nt) * dt
    a, b = rng.uniform(1.0, 3.0), rng.uniform(5.0, 8.0)
    u = np.zeros((nt, 1))
    u[(t > a) & (t < a + 0.5), 0] = 0.05
    u[(t > a + 0.5) & (t < a + 1.0), 0] = -0.05
    u[(t > b) & (t < b + 0.4), 0] = -0.04
    d, _ = mlid.simulate(truth(x0=list(x0)), t, u, noise_std=NOISE, seed=seed)
    return mlid.FlightData(d.t, d.u, d.y, ["de"], ["alpha", "q"], input_units=["rad"],
                           output_units=["rad", "rad/s"])


def start():
    return mlid.LinearModel(F=np.array(F) * 0.7, G=np.array(G) * 1.2, H=np.eye(2), free=FREE)


def test_theil_and_rms_are_those_of_the_prediction():
    res = mlid.fit(start(), manoeuvre(1))
    held = manoeuvre(2, x0=(0.02, -0.01))
    v = mlid.validate(res, held)
    y, yhat = held.y, v.prediction.yhat
    rms = np.sqrt(np.mean((y - yhat) ** 2, axis=0))
    theil = rms / (np.sqrt(np.mean(y**2, axis=0)) + np.sqrt(np.mean(yhat**2, axis=0)))
    np.testing.assert_allclose(v.rms, rms, rtol=1e-12)
    np.testing.assert_allclose(v.theil, theil, rtol=1e-12)
    np.testing.assert_allclose(v.rms_over_sigma, rms / np.sqrt(np.diag(res.rhat)), rtol=1e-12)
    # the held-out initial state was fitted there, not taken from the identification
    assert v.prediction.names == ["x0(1)", "x0(2)"]
    np.testing.assert_allclose(v.prediction.estimate, [0.02, -0.01],
                               atol=4 * v.prediction.sigma.max())


def test_a_right_model_predicts_to_the_noise_and_a_wrong_one_does_not():
    """With the right structure the prediction error is the noise plus the
    parameter error's share (O(nf/N)): rms/sigma within 0.1 of 1, where the
    sampling spread of an rms over N = 601 samples is 1/sqrt(2N) = 0.029.
    Held at half its M_de the same structure predicts several times worse."""
    res = mlid.fit(start(), manoeuvre(3))
    v = mlid.validate(res, [manoeuvre(4), manoeuvre(5, x0=(0.01, 0.0))])
    assert np.all(np.abs(v.rms_over_sigma - 1.0) < 0.1), v.rms_over_sigma
    assert np.all(v.theil < 0.2)
    wrong = start().with_free([n for n in FREE if n != "g(2,1)"])
    wrong.G = [[-0.1], [-3.0]]
    bad = mlid.validate(mlid.fit(wrong, manoeuvre(3)), [manoeuvre(4), manoeuvre(5)])
    assert bad.rms[1] > 2 * v.rms[1] and bad.theil[1] > 2 * v.theil[1]


def test_nothing_own_free_predicts_by_simulation():
    res = mlid.fit(start().with_free(FREE[:6]), manoeuvre(6))
    held = manoeuvre(7)
    v = mlid.validate(res, held)
    model = res.model.with_theta(res.model.theta)
    model.r = np.zeros(2)
    sim, _ = mlid.simulate(model, held.t, held.u)
    np.testing.assert_allclose(v.prediction.yhat, sim.y, rtol=1e-12, atol=1e-15)


def test_validate_refuses_what_it_cannot_use():
    res = mlid.fit(start(), manoeuvre(1))
    with pytest.raises(mlid.InputError, match="FitResult"):
        mlid.validate("fit", manoeuvre(2))
    with pytest.raises(mlid.InputError, match="FlightData"):
        mlid.validate(res, [])
    with pytest.raises(mlid.InputError, match="holdout"):
        mlid.validate(res, manoeuvre(2), holdout=[1, 2])


def test_the_plot_marks_each_output():
    import matplotlib
    matplotlib.use("Agg")
    res = mlid.fit(start(), manoeuvre(1))
    v = mlid.validate(res, [manoeuvre(2), manoeuvre(8)])
    fig = v.plot()
    texts = [ax.get_title(loc="left") for ax in fig.axes]      # above each panel, off the data
    assert f"Theil U {v.theil[1]:.3f}" in texts[2]
    assert fig.axes[1].get_ylabel() == "alpha [rad]"
    # no line across the join of the two held-out manoeuvres
    line = fig.axes[1].get_lines()[1]
    assert np.isnan(line.get_ydata()).sum() == 1


DECK = """
&case title = 'fit on 1 and 3, predict 2', job = 'validate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -0.7, 0.63, -2.8, -1.05,   g = -0.12, -7.2,   h = 1, 0, 0, 1,
    free = 'f(1,1)', 'f(1,2)', 'f(2,1)', 'f(2,2)', 'g(1,1)', 'g(2,1)', 'x0(1)', 'x0(2)',
    names = 'Z_a', 'Z_q', 'M_a', 'M_q', 'Z_de', 'M_de', 'a0', 'q0',
    output_names = 'alpha', 'q' /
&data file = 'm1.dat', 'm2.dat', 'm3.dat', time_col = 't', input_cols = 'de',
    output_cols = 'alpha', 'q', units = 'de = deg', 'alpha = deg', holdout = 2 /
&estimate max_iter = 30 /
"""


def write_manoeuvres(folder):
    """Three records with a header and the angles in degrees."""
    for k in (1, 2, 3):
        d = manoeuvre(10 + k, x0=(0.01 * k, 0.0))
        x = np.column_stack([d.t, np.degrees(d.u[:, 0]), np.degrees(d.y[:, 0]), d.y[:, 1]])
        np.savetxt(folder / f"m{k}.dat", x, header="t de alpha q", comments="")


def run_both(deck, tmp_path):
    py = subprocess.run([str(BIN / "mlid"), "run", str(deck), "--json", str(tmp_path / "p.json")],
                        capture_output=True, text=True, cwd=tmp_path)
    fo = subprocess.run([str(BIN / "mlid-batch"), str(deck), "--json",
                         str(tmp_path / "f.json")], capture_output=True, text=True, cwd=tmp_path)
    return py, fo


def test_the_validate_job_is_the_same_in_both_front_ends_and_in_python(tmp_path):
    write_manoeuvres(tmp_path)
    deck = tmp_path / "v.nml"
    deck.write_text(DECK)
    py, fo = run_both(deck, tmp_path)
    assert py.returncode == 0 and fo.returncode == 0, (py.stderr, fo.stderr)
    assert py.stdout == fo.stdout
    assert (tmp_path / "p.json").read_bytes() == (tmp_path / "f.json").read_bytes()
    case = json.loads((tmp_path / "p.json").read_text())[0]
    assert case["validation"]["holdout"] == [2] and case["validation"]["outputs"] == ["alpha", "q"]
    assert "a0#2" in case["parameters"] and "a0#3" not in case["parameters"]
    # the deck's numbers are mlid.validate's on the same records
    c = mlid.read_deck(deck)[0]
    recs = c.record()
    res = mlid.fit(c.model, [recs[0], recs[2]], **c.options())
    v = mlid.validate(res, recs[1], holdout=[2])
    np.testing.assert_allclose(case["validation"]["theil"], v.theil, rtol=1e-12)
    np.testing.assert_allclose(case["validation"]["rms_over_sigma"], v.rms_over_sigma,
                               rtol=1e-12)
    assert np.all(np.abs(v.rms_over_sigma - 1.0) < 0.1)
    assert "validation: predicted file 2" in py.stdout and "Theil U" in py.stdout


@pytest.mark.parametrize("holdout, job, phrase", [
    ("", "validate", "a validate case needs holdout"),
    ("holdout = 1, 2, 3", "validate", "a validate case needs holdout"),
    ("holdout = 4", "validate", "holdout 4 is no file number (1 to 3)"),
    ("holdout = 2, 2", "validate", "holdout lists file 2 twice"),
    ("holdout = 2", "estimate", "holdout is for job 'validate'"),
])
def test_bad_holdout_is_one_line_in_both_front_ends(tmp_path, holdout, job, phrase):
    write_manoeuvres(tmp_path)
    deck = tmp_path / "v.nml"
    deck.write_text(DECK.replace("holdout = 2", holdout).replace("job = 'validate'",
                                                                   f"job = '{job}'"))
    py, fo = run_both(deck, tmp_path)
    assert py.stdout == fo.stdout
    for out, who in ((py, "mlid"), (fo, "mlid-batch")):
        assert out.returncode == 1
        errors = [ln for ln in out.stderr.splitlines() if ln.startswith(who + ":")]
        assert len(errors) == 1 and phrase in errors[0] and "case 1 (line 2)" in errors[0], \
            (who, out.stderr)


@pytest.mark.parametrize("change", ["holdout = 3, 1", "max_iter = 2"])
def test_both_front_ends_agree_on_two_holdouts_and_on_a_fit_that_stops(tmp_path, change):
    """Two held-out files listed out of order are joined in file order by
    both; a fit that does not converge is reported, fails the case and is
    not validated, by both."""
    write_manoeuvres(tmp_path)
    deck = tmp_path / "v.nml"
    text = DECK.replace("holdout = 2", change if change.startswith("holdout") else "holdout = 2")
    if change.startswith("max_iter"):
        text = text.replace("max_iter = 30", change)
    deck.write_text(text)
    py, fo = run_both(deck, tmp_path)
    assert py.stdout == fo.stdout
    assert (tmp_path / "p.json").read_bytes() == (tmp_path / "f.json").read_bytes()
    if change.startswith("holdout"):
        assert py.returncode == 0 and "predicted files 3 1" in py.stdout
    else:
        assert py.returncode == fo.returncode == 1 and "validation:" not in py.stdout
        assert "not converged after 2 iterations" in py.stderr
