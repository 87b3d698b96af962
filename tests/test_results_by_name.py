"""Issue 42, results out keyed by name: a fit's arrays reached by parameter
name (NamedArray) while they stay numpy arrays; whiteness, identifiability,
sensitivity, Monte Carlo and validation results as objects with DataFrame
views, reprs and Jupyter views, still the lists and dicts they were; the
validation lines in the unit each output is shown in, the same in both
front ends."""

import copy
import json
import pickle
import re

import numpy as np
import pytest

import mlid
from mlid.estimate.named import NamedArray
from conftest import C8_STD, c8_record, c8_start, c8_truth, run_both
from test_validate import DECK, manoeuvre, start, write_manoeuvres

pd = pytest.importorskip("pandas")


@pytest.fixture(scope="module")
def res():
    return mlid.fit(c8_start(), c8_record())


@pytest.fixture(scope="module")
def mc():
    d = c8_record()
    return mlid.monte_carlo(c8_truth(), c8_start(), d.t, d.u, C8_STD, runs=8, seed=3,
                            progress=False)


# --- NamedArray -----------------------------------------------------------------------------

def test_a_fits_arrays_are_reached_by_name_and_by_position(res):
    names = res.names
    assert names == ["M_q", "M_alpha", "Z_alpha", "M_delta", "Z_delta"]
    for i, n in enumerate(names):
        for field in ("start", "estimate", "sigma", "sigma_corrected"):
            assert getattr(res, field)[n] == getattr(res, field)[i]
        for j, m in enumerate(names):
            assert res.covariance[n, m] == res.covariance[i, j]
            assert res.correlation[n, m] == res.correlation[i, j]
        np.testing.assert_array_equal(res.information[n], res.information[i])
    np.testing.assert_array_equal(res.estimate[["Z_delta", "M_q"]], res.estimate[[4, 0]])
    assert res.sigma["M_q"] == pytest.approx(np.sqrt(res.covariance["M_q", "M_q"]), rel=1e-12)
    with pytest.raises(KeyError, match="no entry named 'M_x'.*M_q, M_alpha"):
        res.estimate["M_x"]


def test_a_named_array_stays_a_numpy_array(res):
    est = res.estimate
    plain = np.array(est)
    assert isinstance(est, np.ndarray) and type(plain) is np.ndarray
    np.testing.assert_array_equal(est * 2 + 1, plain * 2 + 1)
    assert np.mean(est) == np.mean(plain) and est.sum() == plain.sum()
    assert type(np.sum(est)) is np.float64 and est @ est == plain @ plain
    np.testing.assert_array_equal(est[1:3], plain[1:3])
    assert type(est[1:3]) is np.ndarray                    # a slice: entries no longer the named
    assert type(np.concatenate([est, est])) is np.ndarray
    assert est.tolist() == plain.tolist() and json.dumps(est.tolist())
    assert "M_q" in est and "N_r" not in est and plain[0] in est     # names, and values
    # element by element with the same names keeps them: an error by name
    truth = NamedArray(c8_truth().theta[c8_start().free_indices()], res.names)
    dev = (est - truth) / res.sigma
    assert dev["M_q"] == pytest.approx((plain[0] - truth[0]) / res.sigma[0], rel=1e-14)
    # a derived array refuses a name in one line, not silently
    with pytest.raises(IndexError, match="no names"):
        est.reshape(-1)["M_q"]
    assert np.sort(est).tolist() == sorted(plain.tolist())


def test_names_survive_copies_and_pickles(res):
    for other in (res.estimate.copy(), copy.deepcopy(res.estimate),
                  pickle.loads(pickle.dumps(res.estimate))):
        assert other.names == res.names and other["Z_alpha"] == res.estimate["Z_alpha"]
    a = res.estimate.copy()
    a["M_q"] = 7.0
    a += 1.0
    assert a["M_q"] == 8.0 and a[0] == 8.0 and a.names == res.names
    series = res.estimate.to_series()
    assert list(series.index) == res.names and series["M_delta"] == res.estimate[3]


# --- fit diagnostics --------------------------------------------------------------------------

def test_whiteness_is_its_dicts_with_a_frame(res):
    w = res.whiteness()
    rows = [dict(r) for r in w]
    assert w == rows and [r["output"] for r in w] == ["y1", "y2", "y3", "y4"]
    frame = w.to_frame()
    assert list(frame.index) == w.outputs
    for key in ("Q", "critical", "white", "outside"):
        np.testing.assert_array_equal(frame[key].to_numpy(), [r[key] for r in rows])
        np.testing.assert_array_equal(getattr(w, key), [r[key] for r in rows])
    assert w["y3"] is w[2] and w.Q["y3"] == w[2]["Q"]
    for text in (repr(w), w._repr_html_()):
        assert all(name in text for name in w.outputs) and "Ljung-Box" in text
    assert f"{w[0]['Q']:.6g}" in repr(w)


def test_identifiability_is_the_reports_lines_with_their_numbers(res):
    ident = res.identifiability()
    report = res.report().split("\n")
    assert list(ident) == report[-3:] and ident[0].startswith(" normalised information")
    assert ident.spread == pytest.approx(res.eigenvalues[-1] / res.eigenvalues[0])
    assert f"spread {ident.spread:.3E}".replace("E+0", "E+0") in ident[0]
    frame = ident.to_frame()
    assert list(frame.index) == res.names
    v = res.eigenvectors[:, 0] * np.sign(res.eigenvectors[np.argmax(
        np.abs(res.eigenvectors[:, 0])), 0])
    np.testing.assert_array_equal(frame["weakest_direction"].to_numpy(), v)
    c = np.array(res.correlation)
    for name, row in frame.iterrows():
        i, j = res.names.index(name), res.names.index(row["most_correlated_with"])
        assert i != j and row["correlation"] == c[i, j]
        assert abs(c[i, j]) == max(abs(c[i, k]) for k in range(len(c)) if k != i)
    # the report's weakest direction names the largest component first, with its sign
    first = re.search(r"weakest direction: ([+-]\d\.\d\d) (\S+)", ident[1])
    assert ident.weakest[first.group(2)] == pytest.approx(float(first.group(1)), abs=0.005)
    for text in (repr(ident), ident._repr_html_()):
        assert all(name in text for name in res.names)


def test_sensitivity_is_its_lines_with_a_frame(res):
    s = res.sensitivity_table()
    norms = res.sensitivity_norms()
    assert len(s) == 2 + len(res.names) and s[0].startswith(" output sensitivity norms")
    np.testing.assert_array_equal(s.norms, norms)
    np.testing.assert_array_equal(s.to_frame().to_numpy(), norms.T)
    assert list(s.to_frame().index) == res.names
    assert res.sensitivity_frame().equals(s.to_frame())
    np.testing.assert_array_equal(s["M_delta"], norms[:, 3])
    assert s["M_delta"]["y3"] == norms[2, 3]
    for text in (repr(s), s._repr_html_()):
        assert all(name in text for name in res.names)


# --- Monte Carlo ------------------------------------------------------------------------------

def test_monte_carlo_is_its_dict_with_frames(mc):
    assert isinstance(mc, dict) and set(mc) == {"estimates", "sigma", "information",
                                                "iterations", "status", "names", "truth",
                                                "summary"}
    frame = mc.to_frame()
    assert list(frame.index) == mc["names"]
    np.testing.assert_array_equal(frame["truth"].to_numpy(), mc["truth"])
    for key in ("mean", "sample_sigma", "mean_cr_sigma"):
        np.testing.assert_array_equal(frame[key].to_numpy(), mc["summary"][key])
        assert getattr(mc, key)["M_alpha"] == mc["summary"][key][1]
    ok = mc["status"] == 0
    np.testing.assert_allclose(frame["mean"].to_numpy(), mc["estimates"][ok].mean(axis=0),
                               rtol=1e-12)
    runs = mc.runs_frame()
    np.testing.assert_array_equal(runs[mc["names"]].to_numpy(), mc["estimates"])
    np.testing.assert_array_equal(runs["status"].to_numpy(), mc["status"])
    assert mc.truth["Z_delta"] == mc["truth"][4] and mc.converged == int(ok.sum())
    for text in (repr(mc), mc._repr_html_()):
        assert all(name in text for name in mc["names"])
        assert f"{mc.converged} of 8 runs converged" in text
    again = pickle.loads(pickle.dumps(mc))
    assert type(again) is type(mc) and again.to_frame().equals(frame)


def test_monte_carlo_parallel_gives_the_same_object(mc):
    d = c8_record()
    par = mlid.monte_carlo_parallel(c8_truth(), c8_start(), d.t, d.u, runs=8, seed=3, workers=2,
                                    chunk=3, noise_std=C8_STD, progress=False)
    assert type(par) is type(mc) and par.to_frame().equals(mc.to_frame())


# --- validation -------------------------------------------------------------------------------

DEG = np.pi / 180


def _rows(report):
    """{output: the words of its line} of a validation's printed lines."""
    lines = report.split("\n")
    k = next(i for i, ln in enumerate(lines) if ln.split()[:2] == ["output", "Theil"])
    assert lines[k].split() == ["output", "Theil", "U", "rms", "error", "unit", "rms/sigma"]
    out = {}
    for ln in lines[k + 1:]:
        if ln.startswith(" Theil U:"):
            break
        words = ln.split()
        out[words[0]] = words[1:]
    return out


def test_validation_lines_are_in_the_shown_unit_with_a_frame():
    res = mlid.fit(start(), manoeuvre(1))
    d = manoeuvre(2, x0=(0.02, -0.01))
    held = mlid.FlightData(d.t, d.u, d.y, d.input_names, d.output_names,
                           input_units=d.input_units, output_units=d.output_units,
                           output_display=[("deg", DEG, 0.0), ("deg/s", DEG, 0.0)])
    v = mlid.validate(res, held)
    rows = _rows(v.report())
    for k, (name, unit) in enumerate((("alpha", "deg"), ("q", "deg/s"))):
        theil, rms, shown, ratio = rows[name]
        assert shown == unit and float(rms) == pytest.approx(v.rms[k] / DEG, rel=1e-4)
        assert float(theil) == pytest.approx(v.theil[k], abs=1e-4)
        assert float(ratio) == pytest.approx(v.rms_over_sigma[k], abs=1e-3)
    frame = v.to_frame()
    assert list(frame.index) == ["alpha", "q"] and list(frame["unit"]) == ["deg", "deg/s"]
    np.testing.assert_array_equal(frame["theil"].to_numpy(), v.theil)
    np.testing.assert_array_equal(frame["rms"].to_numpy(), v.rms / DEG)
    np.testing.assert_array_equal(frame["rms_over_sigma"].to_numpy(), v.rms_over_sigma)
    assert v.theil["q"] == v.theil[1]
    # the JSON keeps the core's units
    member = json.loads("{" + v.json_member() + "}")["validation"]
    assert member["rms"] == pytest.approx(list(v.rms), rel=1e-14)
    for text in (repr(v), v._repr_html_()):
        assert "alpha" in text and "deg/s" in text


def test_a_validate_deck_prints_the_shown_unit_in_both_front_ends(tmp_path):
    """The deck declares alpha in deg and shows q (core rad/s) in deg/s."""
    write_manoeuvres(tmp_path)
    deck = tmp_path / "v.nml"
    deck.write_text(DECK.replace("'alpha = deg', holdout = 2",
                                 "'alpha = deg', 'q = rad/s', holdout = 2, show = 'q = deg/s'"))
    py, fo = run_both(deck, "--json", str(tmp_path / "{exe}.json"), cwd=tmp_path)
    assert py.returncode == 0 and py.stdout == fo.stdout, py.stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    member = json.loads((tmp_path / "mlid.json").read_text())[0]["validation"]
    rows = _rows(py.stdout)
    for k, (name, unit) in enumerate((("alpha", "deg"), ("q", "deg/s"))):
        assert rows[name][2] == unit
        assert float(rows[name][1]) == pytest.approx(member["rms"][k] / DEG, rel=1e-4)
