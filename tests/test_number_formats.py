"""Numbers of any size in the reports (issue 41, class 9): a value from
1e100 up, or below 1e-99, was a field of asterisks in the report (an
ESw.dE2 field has two exponent digits).  Now every report column writes a
normal number as before and any other with a three-digit exponent, which
reads back; the JSON has valid numbers, and null for what is not finite (JSON
has no NaN or infinity); both front ends print the same bytes."""

import json
import re

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import run_both

DT, NT = 0.02, 401
#: truth: g(1,1) 1e150 on an input of 1e-150, g(2,2) -1e120 on one of
#: 1e-120, output 2 measured at 1e-75 of its state (R(2,2) near 1e-154)
F = np.array([[-1.0, 0.0], [0.3, -2.0]])
G = np.array([[1e150, 0.0], [0.0, -1e120]])
H = np.array([[1.0, 0.0], [0.0, 1e-75]])
STD = np.array([0.01, 1e-77])
#: outputs scaled by these in the second record: R's diagonal near 1e200 and residuals near
#: 1e100 in rms, det R beyond the largest float
SCALE = np.array([1e102, 1e177])

MODEL = """&model kind = 'linear', nx = 2, nu = 2, ny = 2,
    f = -1.3, 0.0,  0.2, -1.6,   g = 1.2e150, 0.0,  0.0, -0.8e120,
    h = {h1}, 0.0,  0.0, {h2},  r = 1.0e-4, 1.0e-154,
    free = 'f(1,1)', 'f(2,1)', 'f(2,2)', 'g(1,1)', 'g(2,2)' /
"""
DECK = ("&case title = 'huge and tiny numbers', job = 'estimate' /\n"
        + MODEL.format(h1="1.0", h2="1.0e-75")
        + "&data file = 'big.dat', time_col = 1, input_cols = 2, 3, output_cols = 4, 5 /\n"
        "&estimate max_iter = 20 /\n\n"
        "&case title = 'det R beyond the largest float', job = 'estimate' /\n"
        + MODEL.format(h1="1.0e102", h2="1.0e102")
        + "&data file = 'huge.dat', time_col = 1, input_cols = 2, 3, output_cols = 4, 5 /\n"
        "&estimate max_iter = 20 /\n\n"
        "&case title = 'residuals beyond 1e100 in rms', job = 'validate' /\n"
        + MODEL.format(h1="1.0e102", h2="1.0e102")
        + "&data file = 'huge.dat', 'huge2.dat', time_col = 1, input_cols = 2, 3,\n"
        "    output_cols = 4, 5, holdout = 2 /\n"
        "&estimate max_iter = 20 /\n\n"
        "&case title = 'huge and tiny numbers: Monte Carlo', job = 'monte_carlo' /\n"
        + MODEL.format(h1="1.0", h2="1.0e-75")
        + "&monte_carlo runs = 3, seed = 1, input_file = 'big.dat',\n"
        "    truth = -1.0, 0.3, -2.0, 1.0e150, -1.0e120 /\n")
FREE = ["f(1,1)", "f(2,1)", "f(2,2)", "g(1,1)", "g(2,2)"]
NUMBER = r"[-+]?(?:\d+\.\d*(?:E[-+]\d+)?|NaN|Infinity)"


def _strict(text):
    """JSON as the standard has it: NaN and Infinity are not numbers."""
    def refuse(name):
        raise ValueError(f"not JSON: {name}")
    return json.loads(text, parse_constant=refuse)


def _record(seed=3):
    """The truth's response to a 3211 and a doublet on inputs of 1e-150 and
    1e-120, with noise (fixed seed)."""
    t = np.arange(NT) * DT
    u = np.column_stack([1e-150 * input_signal("3211", 1.0, 0.5, 0.3, DT, NT),
                         1e-120 * input_signal("doublet", 1.0, 1.0, 0.6, DT, NT)])
    data, _ = mlid.simulate(mlid.LinearModel(F, G, H), t, u, STD, seed=seed)
    return data


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The deck through both front ends: their runs and JSON texts."""
    where = tmp_path_factory.mktemp("numbers")
    data = _record()
    data.save(where / "big.dat")
    for name, seed in (("huge.dat", 3), ("huge2.dat", 4)):
        _record(seed).save(where / name)
        big = np.loadtxt(where / name)
        big[:, 3:] *= SCALE
        np.savetxt(where / name, big, fmt="%.17e", header="t u1 u2 y1 y2")
    (where / "numbers.nml").write_text(DECK)
    both = run_both(where / "numbers.nml", "--json", str(where / "{exe}.json"), cwd=where)
    texts = [(where / f"{exe}.json").read_text() for exe in ("mlid", "mlid-batch")]
    return both, texts, data


def _values(line):
    return [float(v) for v in re.findall(NUMBER, line)]


def test_both_front_ends_print_the_same_bytes_and_no_asterisks(runs):
    (py, fo), (pyjson, fojson), _ = runs
    assert py.returncode == 0 and fo.returncode == 0, py.stderr + fo.stderr
    assert py.stdout == fo.stdout and pyjson == fojson
    assert "*" not in py.stdout
    # the values that used to be asterisks, with three exponent digits
    for shown in ("E+150", "E+120", "E+147", "E-154", "E-158", "E+200", "E+100 "):
        assert shown in py.stdout, shown


def test_the_json_is_valid_and_not_finite_is_null(runs):
    _, (text, _), _ = runs
    fit, huge, valid, mc = _strict(text)
    assert fit["converged"] and fit["estimate"][3] == pytest.approx(1e150, rel=0.05)
    assert fit["estimate"][4] == pytest.approx(-1e120, rel=0.05)
    assert fit["R"][1][1] == pytest.approx(1e-154, rel=0.2) and 0 < fit["det_R"] < 1e-150
    # R near 1e196 on both outputs: det R is beyond the largest float
    assert huge["converged"] and min(huge["R"][0][0], huge["R"][1][1]) > 1e190
    assert huge["det_R"] is None
    assert mc["failed"] == 0 and mc["truth"][3] == 1e150
    assert max(valid["validation"]["rms"]) > 1e100


def test_the_report_reads_back_as_the_json(runs):
    (py, _), (text, _), _ = runs
    fit, huge, valid, mc = _strict(text)
    fits = py.stdout.split(" case ")[1:]
    for obj, report in ((fit, fits[0]), (huge, fits[1])):
        lines = report.splitlines()
        for k, name in enumerate(FREE):
            row = next(x for x in lines if x.startswith(" " + name + " "))
            start, est, sig, sigc = _values(row[len(name) + 1:])
            assert start == pytest.approx(obj["start"][k], rel=1e-6)
            assert est == pytest.approx(obj["estimate"][k], rel=1e-6)
            assert sig == pytest.approx(obj["sigma"][k], rel=1e-4)
            assert sigc == pytest.approx(obj["sigma_corrected"][k], rel=1e-4)
        diag = _values(next(x for x in lines if x.startswith(" R diagonal:")))
        assert diag == pytest.approx([obj["R"][0][0], obj["R"][1][1]], rel=1e-4)
        cost, det = _values(next(x for x in lines if x.startswith(" cost J = ")))
        assert cost == pytest.approx(obj["cost"], rel=1e-9)
        assert det == (pytest.approx(obj["det_R"], rel=1e-6) if obj["det_R"] is not None
                       else np.inf)
    rows = [x.split() for x in fits[2].splitlines() if x.startswith((" y1 ", " y2 "))]
    assert [_values(" ".join(r[1:])) for r in rows] == [
        pytest.approx([valid["validation"][key][i] for key in ("theil", "rms", "rms_over_sigma")],
                      rel=1e-3) for i in range(2)]
    lines = fits[3].splitlines()
    for k, name in enumerate(FREE):
        row = next(x for x in lines if x.startswith(" " + name + " "))
        want = [mc[key][k] for key in ("truth", "start", "mean", "sample_sigma",
                                       "mean_cr_sigma")]
        assert _values(row[len(name) + 1:]) == pytest.approx(want, rel=1e-5)


def test_the_apis_result_says_the_same(runs):
    _, (text, _), data = runs
    fit = _strict(text)[0]
    start = np.array([[-1.3, 0.0], [0.2, -1.6]]), np.array([[1.2e150, 0.0], [0.0, -0.8e120]])
    res = mlid.fit(mlid.LinearModel(*start, H, free=FREE), data, max_iter=20)
    assert res.estimate.tolist() == fit["estimate"]
    assert "*" not in res.report() and "E+150" in res.report()
    # as_dict is JSON as the core's: None where a number is not finite
    scaled = mlid.FlightData(data.t, data.u, data.y * SCALE)
    huge = mlid.fit(mlid.LinearModel(*start, H * SCALE[:, None], free=FREE), scaled, max_iter=20)
    d = huge.as_dict()
    assert huge.converged and d["det_R"] is None
    json.dumps(d, allow_nan=False)
