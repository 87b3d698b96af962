"""Units channels are shown in (&data show, FlightData.load(show=)), and the
warning for a channel declared in rad that holds degrees: display only, the
same in both front ends (mlid run and mlid-batch), one line for bad input."""

import json
import subprocess
import warnings

import matplotlib
import numpy as np
import pytest

import mlid
from mlid.report import plots
from conftest import BIN, REPO

matplotlib.use("Agg")

DEG = np.pi / 180
HFB = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"
HFB_DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
needs_hfb = pytest.mark.skipif(not HFB.is_file(), reason=f"real flight data not found at {HFB}")

F = np.array([[-1.2, 0.5], [-1.0, -2.0]])
G = np.array([[1.5], [0.3]])
DECK = """
&case title = 'short period', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.0, 0.5, -0.8, -2.0, g = 1.0, 0.3,
    h = 1, 0, 0, 1, free = 'f(1,1)', 'f(2,1)', 'g(1,1)', names = 'a11', 'a21', 'b1' /
&data file = '{file}', columns = 't[s]', 'de[rad]', 'alpha[rad]', 'q[rad/s]',
    time_col = 't', input_cols = 'de', output_cols = 'alfa', 'q', derived = 'alfa = alpha'{show} /
"""
SHOW = ", show = 'de = deg', 'alfa = deg', 'q = deg/s'"
VALIDATE = """
&case title = 'predict', job = 'validate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.0, 0.5, -0.8, -2.0, g = 1.0, 0.3,
    h = 1, 0, 0, 1, free = 'f(1,1)', 'f(2,1)', 'g(1,1)' /
&data file = '{a}', '{b}', columns = 't[s]', 'de[rad]', 'alpha[rad]', 'q[rad/s]',
    time_col = 't', input_cols = 'de', output_cols = 'alpha', 'q', holdout = 1 /
"""


def _record(path, seed=4, scale=1.0):
    """A simulated short-period record, t de alpha q (rad, rad/s), times scale."""
    t = np.arange(0, 4.0001, 0.02)
    u = np.where((t > 0.2) & (t < 0.8), 1.0, 0.0) - np.where((t > 0.8) & (t < 1.2), 1.0, 0.0)
    model = mlid.LinearModel(F, G, np.eye(2))
    data, _ = mlid.simulate(model, t, u.reshape(-1, 1), noise_std=[0.01, 0.01], seed=seed)
    np.savetxt(path, np.column_stack([t, scale * data.u, scale * data.y]), fmt="%.16e")
    return path


def _run(who, deck, json_path):
    cmd = [str(BIN / who)] + (["run"] if who == "mlid" else []) + [str(deck), "--json",
                                                                    str(json_path)]
    return subprocess.run(cmd, capture_output=True, text=True)


def _decks(tmp_path):
    _record(tmp_path / "sp.dat")
    plain, shown = tmp_path / "plain.nml", tmp_path / "shown.nml"
    plain.write_text(DECK.format(file="sp.dat", show=""))
    shown.write_text(DECK.format(file="sp.dat", show=SHOW))
    return plain, shown


def test_show_changes_the_display_only(tmp_path):
    # the core holds the cases of the deck read last: one deck at a time
    runs = []
    for deck in _decks(tmp_path):
        case = mlid.read_deck(deck)[0]
        runs.append((case.record(), mlid.cli.deck.run_case(case)[1]))
    (a, fa), (b, fb) = runs
    assert np.array_equal(a.u, b.u) and np.array_equal(a.y, b.y)
    assert a.output_units == b.output_units == ["rad", "rad/s"]
    for which, i, unit in (("u", 0, "deg"), ("y", 0, "deg"), ("y", 1, "deg/s")):
        values, got = b.shown(which, i)
        assert got == unit
        np.testing.assert_allclose(values, (a.u if which == "u" else a.y)[:, i] / DEG,
                                   rtol=1e-15, atol=0)
        assert a.shown(which, i)[1] == unit.replace("deg", "rad")
    # the fit's numbers are bit-identical
    assert fa.converged and fb.converged
    for name in ("estimate", "sigma", "rhat", "yhat", "residuals", "cost_history"):
        assert np.array_equal(getattr(fa, name), getattr(fb, name)), name
    # plots label and draw the channels in the unit shown
    fig = plots.outputs(fb)
    labels = [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()]
    assert labels == [plots.axis_label("de", "deg"), "alfa [deg]", "q [deg/s]"]
    measured = fig.axes[1].lines[0].get_ydata()
    np.testing.assert_allclose(measured, a.y[:, 0] / DEG, rtol=1e-15)
    plots.close(fig)
    fig = plots.outputs(fa)
    assert [ax.get_ylabel() for ax in fig.axes if ax.get_ylabel()] == \
        ["de [rad]", "alfa [rad]", "q [rad/s]"]
    plots.close(fig)
    # the HTML report's noise table gives σ in the unit shown
    from mlid.report.html_report import noise_table
    assert "<td>deg/s</td>" in str(noise_table(fb)) and "<td>deg/s</td>" not in str(noise_table(fa))


def test_show_in_both_front_ends_gives_the_same_bytes(tmp_path):
    """The report and the JSON do not change with show, and both front ends
    write the same bytes."""
    plain, shown = _decks(tmp_path)
    outs = {}
    for who in ("mlid", "mlid-batch"):
        for deck in (plain, shown):
            run = _run(who, deck, tmp_path / f"{who}-{deck.stem}.json")
            assert run.returncode == 0 and run.stderr == "", (who, deck.stem, run.stderr)
            outs[who, deck.stem] = (run.stdout, (tmp_path / f"{who}-{deck.stem}.json").read_bytes())
    assert len(set(outs.values())) == 1
    assert json.loads(outs["mlid", "shown"][1])[0]["converged"]


def test_show_in_load_and_from_frame(tmp_path):
    import pandas as pd
    path = _record(tmp_path / "sp.dat")
    cols = ["t[s]", "de[rad]", "alpha[rad]", "q[rad/s]"]
    d = mlid.FlightData.load(path, "t", ["de"], ["alpha", "q", "qq"], columns=cols,
                             derived={"qq": "2*q"}, show={"alpha": "deg", "qq": "deg/s"})
    raw = np.loadtxt(path)
    assert d.output_display[0][0] == "deg" and d.output_display[1] == ("rad/s", 1.0, 0.0)
    np.testing.assert_allclose(d.shown("y", 0)[0], raw[:, 2] / DEG, rtol=1e-15)
    np.testing.assert_allclose(d.shown("y", 2)[0], 2 * raw[:, 3] / DEG, rtol=1e-15)
    assert np.array_equal(d.y[:, 0], raw[:, 2])
    frame = pd.DataFrame(raw, columns=cols)
    f = mlid.FlightData.from_frame(frame, "t", ["de"], ["alpha", "q"], show=["q = deg/s"])
    np.testing.assert_allclose(f.shown("y", 1)[0], raw[:, 3] / DEG, rtol=1e-15)
    assert f.shown("y", 1)[1] == "deg/s" and f.shown("y", 0)[1] == "rad"
    # a unit with an offset: kelvin shown in degC
    (tmp_path / "temp.dat").write_text("t[s] T[K]\n0 300\n0.1 301\n")
    temp = mlid.FlightData.load(tmp_path / "temp.dat", "t", [], ["T"], show={"T": "degC"})
    np.testing.assert_allclose(temp.shown("y", 0)[0], [26.85, 27.85], rtol=1e-14)
    assert temp.shown("y", 0)[1] == "degC"


@pytest.mark.parametrize("show, message", [
    ({"alpha": "dgr"}, r"sp.dat: show alpha: unknown unit 'dgr' \(known: s ms rad"),
    ({"alpha": "m/s"}, r"sp.dat: show alpha = m/s: alpha is in rad, m/s converts to m/s, "
                       r"not rad$"),
    ({"q": "deg"}, r"sp.dat: show q = deg: q is in rad/s, deg converts to rad, not rad/s$"),
    ({"beta": "deg"}, r"sp.dat: show: no channel named beta \(channels: t de alpha q\)$"),
    (["alpha deg"], r"sp.dat: show: "),
])
def test_bad_show_is_one_line(tmp_path, show, message):
    path = _record(tmp_path / "sp.dat")
    with pytest.raises(mlid.InputError, match=message):
        mlid.FlightData.load(path, "t", ["de"], ["alpha", "q"],
                             columns=["t[s]", "de[rad]", "alpha[rad]", "q[rad/s]"], show=show)


def test_show_needs_a_declared_unit(tmp_path):
    path = _record(tmp_path / "sp.dat")
    with pytest.raises(mlid.InputError, match=r"show alpha = deg: alpha has no unit declared "
                                              r"\(declare it: units = 'alpha = unit' or "
                                              r"alpha\[unit\]\)"):
        mlid.FlightData.load(path, "t", ["de"], ["alpha"], columns=["t", "de", "alpha", "q"],
                             show={"alpha": "deg"})
    # a derived channel of channels in different units still has a core unit
    d = mlid.FlightData.load(path, "t", ["de"], ["a"], columns=["t", "de[rad]", "alpha[deg]", "q"],
                             derived={"a": "de + alpha"}, show={"a": "deg"})
    assert d.output_units == ["rad"] and d.shown("y", 0)[1] == "deg"


def test_degrees_declared_as_radians_warn(tmp_path):
    import pandas as pd
    path = _record(tmp_path / "deg.dat", scale=1 / DEG)
    raw = np.loadtxt(path)
    alpha_max = raw[np.argmax(np.abs(raw[:, 2])), 2]
    cols = ["t[s]", "de[rad]", "alpha[rad]", "q[rad/s]"]
    with pytest.warns(mlid.MlidWarning) as caught:
        d = mlid.FlightData.load(path, "t", [], ["alpha", "q"], columns=cols)
    assert len(caught) == 1
    text = str(caught[0].message)
    # the value named is the largest in magnitude, to the digits it is printed with
    value = float(text.split("reaches ")[1].split(",")[0])
    assert abs(value - alpha_max) < 1e-5 and abs(alpha_max) > 2 * np.pi
    assert text.startswith("data file ") and "deg.dat: channel alpha is declared in rad" in text
    assert text.endswith("declare it deg"), text       # q is in rad/s: not checked
    assert np.array_equal(d.y[:, 0], raw[:, 2])        # a warning: nothing changed
    # the worst channel named, the others after it
    with pytest.warns(mlid.MlidWarning, match=r"channel (alpha|de) .* declare it deg "
                                              r"\(so do (de|alpha)\)$"):
        mlid.FlightData.load(path, "t", ["de"], ["alpha"], columns=cols)
    with pytest.warns(mlid.MlidWarning, match=r"data DataFrame: channel alpha is declared in rad"):
        mlid.FlightData.from_frame(pd.DataFrame(raw, columns=cols), "t", [], ["alpha"])
    # within 2 pi, outside the window, or declared in deg: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mlid.FlightData.load(_record(tmp_path / "rad.dat"), "t", ["de"], ["alpha"], columns=cols)
        mlid.FlightData.load(path, "t", [], ["alpha"], columns=cols, t_end=0.1)
        mlid.FlightData.load(path, "t", ["de"], ["alpha"],
                             columns=["t[s]", "de[deg]", "alpha[deg]", "q[deg/s]"])
        mlid.FlightData.load(path, "t", ["de"], ["alpha"], columns=["t", "de", "alpha", "q"])


def test_degrees_declared_as_radians_warn_alike_in_both_front_ends(tmp_path):
    _record(tmp_path / "deg.dat", scale=1 / DEG)
    _record(tmp_path / "deg2.dat", seed=5, scale=1 / DEG)
    deck = tmp_path / "deg.nml"
    deck.write_text(DECK.format(file="deg.dat", show="")
                    + VALIDATE.format(a="deg.dat", b="deg2.dat"))
    py, fo = (_run(who, deck, tmp_path / f"{who}.json") for who in ("mlid", "mlid-batch"))
    assert py.returncode == fo.returncode == 0, (py.stderr, fo.stderr)
    assert py.stdout == fo.stdout
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    lines = {who: [ln.split("': ", 1) for ln in out.stderr.splitlines()]
             for who, out in (("mlid", py), ("mlid-batch", fo))}
    assert [t for _, t in lines["mlid"]] == [t for _, t in lines["mlid-batch"]]
    assert [w for w, _ in lines["mlid"]] == \
        [w.replace("mlid-batch:", "mlid:") for w, _ in lines["mlid-batch"]]
    texts = [t for _, t in lines["mlid"]]
    # case 1 its file; case 2 the file fitted (2), then the one held out (1)
    assert [w.split(" case ")[1].split(" ")[0] for w, _ in lines["mlid"]] == ["1", "2", "2"]
    assert [t.split("data file ")[1].split(":")[0].split("/")[-1] for t in texts] == \
        ["deg.dat", "deg2.dat", "deg.dat"]
    assert all(t.startswith("warning: data file") and "declare it deg" in t for t in texts)
    # Python's record() says it too
    with pytest.warns(mlid.MlidWarning, match="deg.dat: channel"):
        mlid.read_deck(deck)[0].record()


@needs_hfb
def test_hfb320_deck_shows_angles_in_degrees():
    case = mlid.read_deck(HFB_DECK)[0]
    rec = case.record()
    cols = ["T[s]", "DELV[rad]", "PDYN[Pa]", "THRUST[N]", "TASCG[m/s]", "ALFCG[rad]",
            "THE[rad]", "Q[rad/s]", "QDOT[rad/s2]", "AXCG[m/s2]", "AZCG[m/s2]"]
    plain = mlid.FlightData.load(HFB, "T", ["DELV", "THRUST"],
                                 ["TASCG", "ALFCG", "THE", "Q", "QDOT", "AXCG", "AZCG"],
                                 columns=cols)
    assert np.array_equal(rec.u, plain.u) and np.array_equal(rec.y, plain.y)
    assert [u for u, _, _ in rec.input_display] == ["deg", "N"]
    assert [u for u, _, _ in rec.output_display] == \
        ["m/s", "deg", "deg", "deg/s", "deg/s2", "m/s2", "m/s2"]
    np.testing.assert_allclose(rec.shown("y", 1)[0], plain.y[:, 1] / DEG, rtol=1e-15)
