"""Affine ties theta_a = c + sum s*theta_b (fortran/models/mlid_ties.f90,
mlid_params.f90): the gradient and information of a tied model against
finite differences of the cost, recovery of the truth, the deck in both
front ends, and one clear line for every bad tie."""

import re
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN

F = [[-1.0, 0.9], [-4.0, -1.5]]
G = [[-0.12], [-6.0]]


def record(truth, seed=3, nt=401, dt=0.02):
    t = np.arange(nt) * dt
    u = np.zeros((nt, 1))
    u[(t > 1) & (t < 1.5), 0] = 0.05
    u[(t > 1.5) & (t < 2), 0] = -0.05
    return mlid.simulate(truth, t, u, noise_std=[2e-3, 5e-3], seed=seed)[0]


def model(ties, free, F=F, G=G, **kw):
    return mlid.LinearModel(F=F, G=G, H=np.eye(2), ties=ties, free=free, r=[4e-6, 25e-6], **kw)


@pytest.mark.parametrize("ties", [
    {"g(1,1)": "0.02*g(2,1)"},                                   # Z_de = V-scaled M_de
    {"g(1,1)": "-0.5 + 0.02*g(2,1)"},                            # with a constant
    {"g(1,1)": "0.1 + 0.02*g(2,1) - 0.03*f(2,2)", "f(1,1)": "f(2,2)*0.5"},   # a sum; s after
    {"x0(2)": "-2*x0(1)", "bias(2)": "0.001 + 3*g(2,1)"},       # initial states and biases
])
def test_gradient_against_finite_differences(ties):
    data = record(model({}, []))
    free = ["f(2,1)", "f(2,2)", "g(2,1)"] + (["x0(1)"] if "x0(2)" in ties else [])
    m = model(ties, free, x0=[0.01, 0.0])
    ev = mlid.evaluate(m, data)
    theta0 = m.theta

    def cost(k, h):
        th = theta0.copy()
        th[m.free_indices()[k]] += h
        mm = m.with_theta(m.tied(th))
        return mlid.evaluate(mm, data)["cost"]

    for k in range(len(free)):
        h = 1e-6 * max(1.0, abs(theta0[m.free_indices()[k]]))
        fd = (cost(k, h) - cost(k, -h)) / (2 * h)
        assert fd == pytest.approx(ev["gradient"][k], rel=2e-4, abs=1e-6 * abs(ev["gradient"]).max())


def test_a_tied_model_recovers_the_truth_and_keeps_its_ties():
    ties = {"g(1,1)": "-0.01 + 0.02*g(2,1)"}
    truth = model(ties, ["f(2,1)", "f(2,2)", "g(2,1)"])
    assert truth.G[0, 0] == pytest.approx(-0.01 + 0.02 * G[1][0])
    start = model(ties, ["f(2,1)", "f(2,2)", "g(2,1)"], F=[[-1.0, 0.9], [-3.0, -1.0]],
                  G=[[0.0], [-4.0]])
    res = mlid.fit(start, record(truth, seed=11))
    est = dict(zip(res.names, zip(res.estimate, res.sigma)))
    for name, want in (("f(2,1)", -4.0), ("f(2,2)", -1.5), ("g(2,1)", -6.0)):
        assert abs(est[name][0] - want) < 4 * est[name][1], name
    assert res.model.G[0, 0] == pytest.approx(-0.01 + 0.02 * res.model.G[1, 0], rel=1e-12)


def test_an_equality_tie_written_as_a_scaled_sum_gives_the_same_fit():
    data = record(model({}, []))
    a = mlid.fit(model({"f(1,1)": "f(2,2)"}, ["f(2,1)", "f(2,2)", "g(2,1)"]), data)
    b = mlid.fit(model({"f(1,1)": "1.0*f(2,2) + 0"}, ["f(2,1)", "f(2,2)", "g(2,1)"]), data)
    np.testing.assert_array_equal(a.estimate, b.estimate)


@pytest.mark.parametrize("ties, phrase", [
    ({"f(1,1)": "f(2,2)", "f(2,2)": "f(1,1)"}, "itself tied (a chain or a cycle of ties)"),
    ({"f(1,1)": "f(2,1)*f(2,2)"}, "multiplies two parameters"),
    ({"f(1,1)": "2*q(9)"}, "is no parameter"),
    ({"f(1,1)": "0.5"}, "names no parameter to follow"),
    ({"f(2,1)": "f(2,2)"}, "both free and tied"),
    ({"f(1,1)": "2 x f(2,2)"}, "expected + or -"),
    ({"f(1,1)": "0.5*f(1,1)"}, "ties a parameter to itself"),
    ({"f(1,1)": "1d400*f(2,2)"}, "not finite"),
    ({"f(1,1)": "f(2,2)", "F(1, 1)": "2*f(2,2)"}, "parameter 'f(1,1)' is tied twice"),
])
def test_bad_ties_are_one_clear_line(ties, phrase):
    with pytest.raises(mlid.InputError, match=re.escape(phrase)):
        model(ties, ["f(2,1)", "f(2,2)"])


DECK = """
&case title = 'affine ties', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.9, -3.0, -1.0,   g = 0.0, -4.0,   h = 1, 0, 0, 1,
    free = 'f(2,1)', 'f(2,2)', 'g(2,1)', names = 'M_a', 'M_q', 'M_de',
    tie = {tie} /
&data file = 'r.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
"""


def test_the_deck_in_both_front_ends(tmp_path):
    truth = model({"g(1,1)": "-0.01 + 0.02*g(2,1)"}, [])
    record(truth).save(tmp_path / "r.dat")
    (tmp_path / "ok.nml").write_text(DECK.format(tie="'g(1,1) = -0.01 + 0.02*g(2,1)'"))
    runs = [subprocess.run([str(BIN / exe), *pre, "ok.nml", "--json", f"{exe}.json"],
                           capture_output=True, text=True, cwd=tmp_path)
            for exe, pre in (("mlid", ["run"]), ("mlid-batch", []))]
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    case = mlid.read_deck(tmp_path / "ok.nml")[0]
    assert case.model.tie_terms() == model({"g(1,1)": "-0.01 + 0.02*g(2,1)"}, []).tie_terms()
    # negative scales and sums come back from the core as the deck wrote them
    rhs = "0.5 - 0.02*g(2,1) - f(2,2)"
    (tmp_path / "neg.nml").write_text(DECK.format(tie=f"'g(1,1) = {rhs}'"))
    case = mlid.read_deck(tmp_path / "neg.nml")[0]
    assert case.error is None
    assert case.model.tie_terms() == model({"g(1,1)": rhs}, []).tie_terms()
    for bad, phrase in (("'f(1,1) = f(2,1)*f(2,2)'", "multiplies two parameters"),
                        ("'f(1,1) = f(1,2)', 'f(1,2) = f(1,1)'",
                         "'f(1,1)' is tied to 'f(1,2)', which is itself tied"),
                        ("'f(2,1) = f(1,2)'", "parameter 'f(2,1)' is both free and tied"),
                        ("'f(1,1) = f(1,2)', 'f(1,1) = 2*f(1,2)'", "tied twice"),
                        ("'f(1,1) = " + "0.5*f(1,2) + " * 50 + "1'", "longer than 511")):
        (tmp_path / "bad.nml").write_text(DECK.format(tie=bad))
        for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
            out = subprocess.run([str(BIN / exe), *pre, "bad.nml"], capture_output=True,
                                 text=True, cwd=tmp_path)
            lines = [ln for ln in out.stderr.splitlines() if ln.startswith(exe + ":")]
            assert out.returncode == 1 and len(lines) == 1 and phrase in lines[0], out.stderr
            assert "case 1 (line 2)" in lines[0]


def test_the_bode_band_samples_keep_affine_ties():
    from mlid.report.plots import sampled_models
    ties = {"f(1,1)": "0.1 - 0.5*f(2,2)"}
    res = mlid.fit(model(ties, ["f(2,1)", "f(2,2)", "g(2,1)"]), record(model(ties, [])))
    draws = sampled_models(res, samples=20)
    assert len({m.F[1, 1] for m in draws}) == 20
    for m in draws:
        assert m.F[0, 0] == pytest.approx(0.1 - 0.5 * m.F[1, 1], rel=1e-14)
