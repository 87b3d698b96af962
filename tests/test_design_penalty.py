"""The state penalty of report §7.6 in the deck's design job (issue 43 item
5): &design state_penalty = K (one weight per state, or nx x nx row by row)
maximises tr(WM) - int x'Kx dt.  The deck's design is mlid.InputDesign's
state_penalised on the same problem (the same input, mu and information);
its riccati design is at the T that penalised_length gives for its mu (a
second path); a larger penalty lowers the states' integral; both front ends
print and write the same bytes; bad values are one line each."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN

DECK = """&case title = 'penalised', job = 'design' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.588, -0.562, 1.0, -0.737,   g = -1.66, 0.005,   h = 1, 0, 0, 1,
    r = 1.0, 2.0,
    free = 'f(1,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'g(2,1)' /
&design t_end = 4.0, dt = 0.02, energy = 311.0, out = 'u.dat', {extra} /
"""
F = np.array([[-1.588, -0.562], [1.0, -0.737]])
G = np.array([[-1.66], [0.005]])
R = np.diag([1.0 * 0.02, 2.0 * 0.02])        # the deck's r dt
UNKNOWNS = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "g(2,1)"]
T, ENERGY = 4.0, 311.0


def _design():
    return mlid.InputDesign(F, G, np.eye(2), R, UNKNOWNS)


def _run(tmp_path, extra, front="fo", name="d.nml"):
    deck = tmp_path / name
    deck.write_text(DECK.format(extra=extra))
    cmd = [str(BIN / "mlid"), "run"] if front == "py" else [str(BIN / "mlid-batch")]
    out = subprocess.run(cmd + [str(deck), "--json", str(tmp_path / f"{front}.json")],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return (json.loads((tmp_path / f"{front}.json").read_text())[0],
            np.loadtxt(tmp_path / "u.dat"), out.stdout)


def test_operator_design_with_a_penalty_is_state_penalised(tmp_path):
    got, rec, text = _run(tmp_path, "state_penalty = 5.0, 50.0")
    d = _design()
    inp = d.state_penalised(T, ENERGY, [5.0, 50.0], cells=100)
    np.testing.assert_allclose(got["mu"], inp.mu, rtol=1e-12)
    np.testing.assert_allclose(rec[:-1, 1], inp.u[:, 0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(got["M"], inp.M, rtol=1e-10)
    np.testing.assert_array_equal(got["state_penalty"], np.diag([5.0, 50.0]))
    xx = d.state_integral(T, inp.u)
    np.testing.assert_allclose(got["state_integral_K"], np.sum(np.diag([5.0, 50.0]) * xx),
                               rtol=1e-10)
    np.testing.assert_allclose(got["state_rms"], np.sqrt(np.diag(xx) / T), rtol=1e-10)
    _, x = d.response(T, inp.u, substeps=4)
    np.testing.assert_allclose(got["state_peak"], np.abs(x).max(axis=0), rtol=1e-12)
    # what §7.6 trades: the penalised criterion is mu E
    np.testing.assert_allclose(got["trace_M"] - got["state_integral_K"], got["mu"] * ENERGY,
                               rtol=1e-3)
    assert "state penalty K (report 7.6" in text and "int x'Kx dt = " in text
    assert "(max tr(WM) - int x'Kx dt = mu E)" in text


def test_riccati_design_with_a_penalty_is_at_its_penalised_length(tmp_path):
    """The deck's riccati mu at T = 4 s, given back to penalised_length (the
    Riccati equation of the penalised Hamiltonian, another solver): T."""
    K = np.array([[5.0, 1.0], [1.0, 50.0]])
    got, _, _ = _run(tmp_path, "method = 'riccati', state_penalty = 5.0, 1.0, 1.0, 50.0")
    np.testing.assert_array_equal(got["state_penalty"], K)
    np.testing.assert_allclose(_design().penalised_length(got["mu"], K), T, rtol=1e-6)
    plain = _design().mu_max(T, cells=100, method="riccati")
    assert got["mu"] < plain                       # the penalty costs criterion


def test_a_larger_penalty_lowers_the_state_integral(tmp_path):
    """int x'K0x dt under the designed input, for penalties 0, K0 and 3 K0:
    each larger penalty gives smaller excursions, and the information falls
    with them (what §7.6 trades)."""
    k0 = np.diag([5.0, 50.0])
    d = _design()
    integrals, traces = [], []
    for scale in (0.0, 1.0, 3.0):
        extra = f"state_penalty = {5.0 * scale}, {50.0 * scale}" if scale else "method = 'operator'"
        got, rec, _ = _run(tmp_path, extra)
        integrals.append(np.sum(k0 * d.state_integral(T, rec[:-1, 1:])))
        traces.append(got["trace_M"])
        if scale:
            np.testing.assert_allclose(got["state_integral_K"], scale * integrals[-1],
                                       rtol=1e-10)
        else:
            assert "state_penalty" not in got
    assert integrals[0] > integrals[1] > integrals[2], integrals
    assert integrals[2] < 0.5 * integrals[0], integrals
    assert traces[0] > traces[1] > traces[2], traces


def test_both_front_ends_give_the_same_bytes(tmp_path):
    extra = "method = 'riccati', state_penalty = 5.0, 1.0, 1.0, 50.0"
    a, rec_a, out_a = _run(tmp_path, extra, "fo")
    (tmp_path / "u.dat").rename(tmp_path / "u_fo.dat")
    b, rec_b, out_b = _run(tmp_path, extra, "py")
    assert (tmp_path / "fo.json").read_bytes() == (tmp_path / "py.json").read_bytes()
    assert (tmp_path / "u_fo.dat").read_bytes() == (tmp_path / "u.dat").read_bytes()
    assert out_a == out_b


BAD = {
    "count": ("state_penalty = 1, 2, 3",
              "state_penalty takes one weight per state (2) or nx x nx = 4 values row by row, got 3"),
    "asymmetric": ("state_penalty = 1, 0.5, 0, 1", "state_penalty (K) must be symmetric"),
    "negative": ("state_penalty = 1, -2", "state_penalty weights must be >= 0"),
    "not finite": ("state_penalty = 1, Inf", "state_penalty must be finite"),
    "amplitude method": ("method = 'amplitude', peak = 1, min_width = 0.2, "
                         "state_penalty = 1, 2",
                         "state_penalty is for method 'operator' or 'riccati', not 'amplitude'"),
    "equalised method": ("method = 'equalised', state_penalty = 1, 2",
                         "state_penalty is for method 'operator' or 'riccati', not 'equalised'"),
    "indefinite": ("state_penalty = 1, 2, 2, 1",
                   "state_penalty: the state penalty must be positive semi-definite"),
}
GOOD = DECK.format(extra="state_penalty = 5.0, 50.0").replace("'penalised'", "'good'")


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_state_penalty_is_one_line_in_both_front_ends(tmp_path, name):
    extra, phrase = BAD[name]
    deck = tmp_path / "batch.nml"
    bad = DECK.format(extra=extra).replace("'penalised'", "'bad'").replace("'u.dat'", "'b.dat'")
    if "peak" in extra:                         # the amplitude method takes no energy
        bad = bad.replace("energy = 311.0, ", "")
    deck.write_text(GOOD + bad + GOOD.replace("'good'", "'after'").replace("'u.dat'", "'a.dat'"))
    outs = {}
    for front, who in (("py", "mlid"), ("fo", "mlid-batch")):
        cmd = [str(BIN / "mlid"), "run"] if front == "py" else [str(BIN / "mlid-batch")]
        out = subprocess.run(cmd + [str(deck)], capture_output=True, text=True)
        assert out.returncode == 1, (who, out.stdout, out.stderr)
        assert "Traceback" not in out.stderr
        errors = [ln for ln in out.stderr.splitlines() if ln.startswith(who + ":")]
        assert len(errors) == 1, (who, out.stderr)
        assert f"{deck} case 2 (line 7) 'bad': " in errors[0] and phrase in errors[0], errors[0]
        assert out.stdout.count("designed input written to") == 2    # before and after
        outs[front] = (out.stdout, errors[0].split("': ", 1)[1])
    assert outs["py"] == outs["fo"]


@pytest.mark.parametrize("scale", [10.0, 1e6, 1e12])
def test_a_penalty_above_all_information_is_refused_not_extrapolated(scale):
    """With K so large that every eigenvalue of the penalised operator is
    negative, the Richardson extrapolation of the two grids' (negative)
    largest eigenvalues could come out positive (K = 1e12 K0 gave mu = 11009,
    growing with K; 30 K0 gave 2e-5): the core refuses instead, naming the
    penalty.  (5 K0 still has mu = 0.13 > 0; 10 K0 has none.)"""
    with pytest.raises(mlid.errors.SingularInformationError,
                       match="a state penalty outweighs the information"):
        _design().state_penalised(T, ENERGY, [5.0 * scale, 50.0 * scale], cells=100)
