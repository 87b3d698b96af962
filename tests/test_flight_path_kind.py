"""The flight-path model (kind 'flight_path', mlid.FlightPathModel,
fortran/models/mlid_flightpath.f90) and the compatibility step after it
(mlid.estimate.compatibility): the kind written from sensor positions gives the fit
of the same equations stated by hand (test case 22b), exact Jacobians with
every correction and a wind, a wind read as the physics says, the corrected
record refits to neutral corrections and is written by a deck (&estimate
corrected) to the same bytes by both front ends, and bad input in one line
in both front ends."""

import numpy as np
import pytest

import mlid
from mlid.estimate import compatibility
from mlid.model.models import FLIGHTPATH_CORRECTIONS, FLIGHTPATH_INPUTS
from conftest import REPO, both_front_ends_json, refused_by_both, run_both

HERE = REPO / "cases" / "flight_path"
DATA = REPO.parent / "shared" / "data"
needs_data = pytest.mark.skipif(not (DATA / "fAttasElv1_pqrDot.asc").is_file(),
                                reason="the ATTAS records are not in ../shared/data")
ATTAS = dict(xA=-1.010, yA=0.886, zA=0.103, xN=13.080, yN=-0.010, zN=-0.027, g=9.80)


@needs_data
def test_the_kind_is_the_model_written_by_hand(tmp_path):
    """compatibility.nml (the kind) against tc22b.nml (the same equations by
    hand): the same estimates, sigmas and det R, in both front ends."""
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    kind = both_front_ends_json(HERE / "compatibility.nml", tmp_path / "a")
    hand = both_front_ends_json(HERE / "tc22b.nml", tmp_path / "b")
    assert kind["parameters"] == hand["parameters"]
    np.testing.assert_allclose(kind["estimate"], hand["estimate"], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(kind["sigma"], hand["sigma"], rtol=1e-7)
    assert kind["det_R"] == pytest.approx(hand["det_R"], rel=1e-9)


def test_jacobians_with_every_correction_and_a_wind():
    values = {n: (1.02 if n.startswith("f_") else 0.01 * (k + 1))
              for k, n in enumerate(FLIGHTPATH_CORRECTIONS)}
    values.update(w_n=4.0, w_e=-3.0, w_d=0.5)
    m = mlid.FlightPathModel(ATTAS, values, free=list(values))
    x = np.array([120.0, 2.0, 6.0, 0.2, 0.05, 1.1, 3000.0])
    u = np.array([0.3, -0.2, -9.6, 0.05, -0.02, 0.03, 0.1, -0.05, 0.02])
    errs = mlid.check_jacobians(m, x, u)
    assert max(errs.values()) < 1e-7, errs


def test_a_wind_from_ahead_adds_to_the_airspeed():
    """Flying north level at 100 m/s into a 10 m/s wind from the north
    (w_n = -10): V = 110; with a 10 m/s wind from the east (w_e = -10),
    beta = atan(10/100)."""
    t = np.arange(51) * 0.02
    u = np.zeros((51, 9))
    u[:, 2] = -9.80                                   # az balances g
    for wind, v, beta in (({"w_n": -10.0}, 110.0, 0.0),
                          ({"w_e": -10.0}, np.hypot(100.0, 10.0), np.arctan(0.1))):
        m = mlid.FlightPathModel(ATTAS, wind, x0=[100.0, 0, 0, 0, 0, 0, 1000.0])
        y = mlid.simulate(m, t, u)[0].y
        np.testing.assert_allclose(y[:, 0], v, rtol=1e-12)
        np.testing.assert_allclose(y[:, 2], beta, atol=1e-12)


@needs_data
def test_the_corrected_record_refits_to_neutral_corrections(tmp_path):
    """tc33 fitted, its record corrected (biases, scale factors, delays),
    the corrected record refitted: every correction within one Cramer-Rao
    sigma of neutral, where it stood 4 to 844 sigmas out (measured: at most
    0.13 sigma, and 0.73 for tau_psi, whose correction interpolates the
    measured psi between samples); the significance table calls the gyros
    and b_az significant as the case README says."""
    case = mlid.read_deck(HERE / "tc33.nml")[0]
    data, opts = case.record(), case.options()
    res = mlid.fit(case.model, data, **opts)
    table = {row[0]: row[5] for row in compatibility.significance(res)["rows"]}
    assert all(table[n] for n in ("b_az", "b_p", "b_q", "b_r", "f_be", "tau_psi"))
    assert not any(table[n] for n in ("b_ay", "f_al", "b_al"))
    fixed = compatibility.corrected_record(res)
    again = mlid.fit(case.model, fixed, **opts)
    for name, v, s in zip(again.names, again.estimate, again.sigma):
        if not name.startswith("x0"):
            assert abs(v - compatibility.neutral(name)) < s, (name, v, s)
    fixed[0].save(tmp_path / "elv1_corrected.dat")
    back = mlid.FlightData.load(tmp_path / "elv1_corrected.dat", 1, list(range(2, 11)),
                                list(range(11, 18)))
    np.testing.assert_array_equal(back.u, fixed[0].u)


def _deck_with_corrected(folder, files):
    """compatibility.nml (tc22b by the kind) with the alpha, beta and psi
    delays (tc33's), the roll gyro's delay and the phi bias of each
    manoeuvre free, its records named absolutely, writing the corrected
    records to files (in folder)."""
    text = (HERE / "compatibility.nml").read_text().replace("'../../../shared/data/", f"'{DATA}/")
    text = text.replace("'f_be', 'b_be' /", "'f_be', 'b_be', 'delay(2)', 'delay(3)', 'delay(6)', "
                        "'udelay(4)', 'bias(4)', delay = 7*0.0, udelay = 9*0.0 /")
    head, _, rest = text.partition("&estimate")
    folder.mkdir()
    deck = folder / "deck.nml"
    deck.write_text(head + "&estimate corrected = " + ", ".join(f"'{f}'" for f in files) + ","
                    + rest)
    return deck


@needs_data
def test_a_deck_writes_the_corrected_records_alike_in_both_front_ends(tmp_path):
    """&estimate corrected: each manoeuvre's record with the fit's corrections
    undone, the same bytes from mlid run and mlid-batch, the values those of
    the rule written out here with numpy (inputs taken back by their delays,
    accelerometers and gyros (a - b)/f, outputs taken back by their delays,
    less their biases, air data (y - b)/f; an output without delay, bias or
    scale as measured, to the bit), read back by the one reader with the
    model's channel names."""
    names = ["elv1.asc", "ail1.asc", "rud1.asc"]
    decks = [_deck_with_corrected(tmp_path / d, names) for d in ("a", "b")]
    runs = [run_both(deck, cwd=deck.parent)[k] for k, deck in enumerate(decks)]
    assert [r.returncode for r in runs] == [0, 0], runs[0].stderr + runs[1].stderr
    assert runs[0].stdout == runs[1].stdout.replace(str(tmp_path / "b"), str(tmp_path / "a"))
    assert runs[0].stdout.count(" corrected record of manoeuvre ") == 3
    for name in names:
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()

    case = mlid.read_deck(decks[0])[0]
    res = mlid.fit(case.model, case.record(), **case.options())
    own = dict(zip(res.model.element_labels()[:res.model.np], res.model.p))
    for name, rec, m in zip(names, case.record(), res.manoeuvres):
        back = mlid.FlightData.load(tmp_path / "a" / name, 1, list(range(2, 11)),
                                    list(range(11, 18)))
        assert back.input_names == list(FLIGHTPATH_INPUTS) and back.output_names[:2] == ["V", "alpha"]
        u, y = rec.u.copy(), rec.y.copy()
        for j, s in enumerate(FLIGHTPATH_INPUTS):
            u[:, j] = np.interp(rec.t - m.udelay[j], rec.t, u[:, j])
            if j < 6:
                u[:, j] = (u[:, j] - own.get(f"b_{s}", 0.0)) / own.get(f"f_{s}", 1.0)
        for i, s in enumerate(back.output_names):
            f, b = {"V": ("f_V", "b_V"), "alpha": ("f_al", "b_al"),
                    "beta": ("f_be", "b_be")}.get(s, ("", ""))
            y[:, i] = (np.interp(rec.t + m.delay[i], rec.t, y[:, i]) - m.bias[i]
                       - own.get(b, 0.0)) / own.get(f, 1.0)
        np.testing.assert_array_equal(back.t, rec.t)
        np.testing.assert_allclose(back.u, u, rtol=1e-14, atol=1e-15)
        np.testing.assert_allclose(back.y, y, rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(back.y[:, 4], rec.y[:, 4])   # theta: nothing to undo
    assert max(abs(d) for d in res.manoeuvres[0].delay) > 0.005   # the delays were used
    assert abs(res.manoeuvres[0].udelay[3]) > 0.001
    assert len({m.bias[3] for m in res.manoeuvres}) == 3          # a bias per manoeuvre


FP = "kind = 'flight_path', constants = 0, 0, 0, 0, 0, 0, 9.81"
FP_CHANNELS = "input_cols = 2, 3, 4, 5, 6, 7, 8, 9, 10, output_cols = 11, 12, 13, 14, 15, 16, 17"
BAD_CORRECTED = [
    ("kind = 'equations', state_names = 'x', input_names = 'u', output_names = 'y', "
     "xdot = '-x + u', outputs = 'x'", "'r.dat', input_cols = 2, output_cols = 3",
     "corrected = 'a.asc'",
     "corrected writes the records with a flight-path fit's corrections undone: it needs "
     "&model kind = 'flight_path'"),
    (FP, f"'r.dat', {FP_CHANNELS}", "corrected = 'a.asc', 'b.asc'",
     "corrected names more files than the case's 1 data files"),
    (FP, f"'r.dat', 's.dat', {FP_CHANNELS}", "corrected(2) = 'b.asc'",
     "corrected has no file for data file 1 (one record written per data file"),
    (FP, f"'r.dat', 's.dat', {FP_CHANNELS}", "corrected = 'a.asc', 'a.asc'",
     "a.asc' twice, or a data file: each record goes to a file of its own"),
    (FP, f"'r.dat', {FP_CHANNELS}", "corrected = 'r.dat'",
     "r.dat' twice, or a data file: each record goes to a file of its own")]


@pytest.mark.parametrize("model, data, entry, message", BAD_CORRECTED)
def test_bad_corrected_is_one_line_in_both_front_ends(tmp_path, model, data, entry, message):
    deck = tmp_path / "bad.nml"
    deck.write_text(f"&case title = 'bad', job = 'estimate' /\n&model {model} /\n"
                    f"&data file = {data}, time_col = 1 /\n&estimate {entry} /\n")
    refused_by_both(deck, message, cwd=tmp_path)


@needs_data
def test_a_corrected_record_that_cannot_be_written_fails_the_case_before_its_fit(tmp_path):
    """Every path is tried before the fit (a long fit is not lost to a
    typo): one line in both front ends, nothing written."""
    deck = _deck_with_corrected(tmp_path / "a", ["elv1.asc", "no/ail1.asc", "rud1.asc"])
    runs = run_both(deck, cwd=deck.parent)
    for run in runs:
        assert run.returncode == 1 and "sigma" not in run.stdout, run.stdout
        assert "cannot write" in run.stderr.splitlines()[0] and "no/ail1.asc" in run.stderr
    assert runs[0].stdout == runs[1].stdout
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == ["deck.nml"]


BAD = [("params = 'b_xx = 0'", "'b_xx' is not a correction; the corrections are b_ax, "),
       ("output_names = 'V', 'gamma'", "output 'gamma' is not one of V, alpha, beta"),
       ("constants = 0, 0, 0, 0, 0, 0, 0", "the constants must be numbers and g > 0"),
       ("constants = 0, 0, 0", "constants needs 7 values: xA, yA, zA, xN, yN, zN, g"),
       ("state_names = 'u'", "kind = 'flight_path' writes its states, inputs and equations")]


@pytest.mark.parametrize("entry, message", BAD)
def test_bad_input_is_one_line_in_both_front_ends(tmp_path, entry, message):
    deck = tmp_path / "bad.nml"
    constants = "" if entry.startswith("constants") else "constants = 0, 0, 0, 0, 0, 0, 9.81,"
    deck.write_text(f"&case title = 'bad', job = 'estimate' /\n"
                    f"&model kind = 'flight_path', {constants} {entry} /\n"
                    f"&data file = 'r.dat', time_col = 1 /\n")
    refused_by_both(deck, message, cwd=tmp_path)
    with pytest.raises(mlid.InputError, match="is not a correction"):
        mlid.FlightPathModel(ATTAS, {"b_xx": 0.0})
    assert len(FLIGHTPATH_INPUTS) == 9


def test_a_renamed_scale_factor_is_still_one_at_neutral():
    m = mlid.FlightPathModel(ATTAS, {"f_al": 1.0}, free=["f_al"], names={"f_al": "K_alpha"})
    assert compatibility._own_names(m, ["K_alpha", "x0(1)#2"]) == ["f_al", "x0(1)"]
