"""The results table (python/mlid/estimate/table.py): CSV and JSON read back to the
result's numbers, the LaTeX is a well-formed tabular, the DataFrame columns,
units, the flag, and mlid run --table."""

import csv
import json
import re
import subprocess
import sys

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import REPO
from mlid.estimate.table import COLUMNS, FLAG_RATIO, ResultsTable, results_table

F0 = np.array([[-0.02, -32.2, 0, 33.74], [0, 0, 1, 0], [0.003, 0, -1.588, -0.562],
               [-0.004, 0, 1, -0.737]])
G0 = np.array([[0.0], [0.0], [-1.658], [0.005]])
FREE = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]
# names with LaTeX's special characters, to be escaped
NAMES = {"f(3,3)": "M_q", "f(3,4)": "M_alpha&#", "f(4,4)": "Z_{alpha}", "g(3,1)": "M_delta%",
         "g(4,1)": "Z$delta"}


@pytest.fixture(scope="module")
def result():
    truth = mlid.LinearModel(F0, G0, np.eye(4), free=FREE, names=NAMES)
    t = np.arange(400) * 0.02
    u = input_signal("3211", 0.08, 1.0, 0.5, 0.02, 400).reshape(-1, 1)
    data, _ = mlid.simulate(truth, t, u, noise_std=[0.35, 0.006, 0.006, 0.009], seed=3)
    return mlid.fit(truth, data)


def _numbers(res):
    return np.column_stack([res.estimate, res.sigma, res.sigma_corrected,
                            100 * res.sigma_corrected / np.abs(res.estimate)])


def test_csv_round_trip(result, tmp_path):
    path = tmp_path / "t.csv"
    result.table().to_csv(path)
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert tuple(rows[0]) == COLUMNS
    assert [r["name"] for r in rows] == list(result.names)
    got = np.array([[float(r[c]) for c in COLUMNS[2:6]] for r in rows])
    np.testing.assert_array_equal(got[:, :3], _numbers(result)[:, :3])     # exact
    np.testing.assert_allclose(got[:, 3], _numbers(result)[:, 3], rtol=1e-15)


def test_json_round_trip(result, tmp_path):
    path = tmp_path / "t.json"
    result.table().to_json(path)
    obj = json.loads(path.read_text())
    assert obj["columns"] == list(COLUMNS)
    got = np.array([[r[c] for c in COLUMNS[2:6]] for r in obj["rows"]])
    np.testing.assert_array_equal(got[:, :3], _numbers(result)[:, :3])
    np.testing.assert_allclose(got[:, 3], _numbers(result)[:, 3], rtol=1e-15)
    assert [r["flag"] for r in obj["rows"]] == list(result.sigma_corrected
                                                    > FLAG_RATIO * result.sigma)


def _strip_escapes(line):
    return re.sub(r"\\[&%$#_{}]", "", line)


def test_latex_parses(result, tmp_path):
    path = tmp_path / "t.tex"
    result.table().to_latex(path)
    text = path.read_text()
    lines = text.strip().split("\n")
    assert lines[0].startswith(r"\begin{tabular}{") and lines[-1] == r"\end{tabular}"
    ncol = len(re.match(r"\\begin\{tabular\}\{(\w+)\}", lines[0]).group(1))
    assert ncol == len(COLUMNS)
    for tag in (r"\toprule", r"\midrule", r"\bottomrule"):
        assert lines.count(tag) == 1
    body = [ln for ln in lines if ln.endswith(r"\\")]
    assert len(body) == 1 + len(result.names)              # heading + one row per parameter
    for ln in body:
        bare = _strip_escapes(ln)
        assert bare.count("&") == ncol - 1, ln
        assert bare.count("{") == bare.count("}"), ln
        assert bare.count("$") % 2 == 0, ln
    assert text.count("{") - text.count(r"\{") == text.count("}") - text.count(r"\}")
    assert r"M\_alpha\&\#" in text and r"Z\_\{alpha\}" in text and r"Z\$delta" in text


def test_frame_and_units(result):
    pd = pytest.importorskip("pandas")
    frame = result.table().to_frame()
    assert isinstance(frame, pd.DataFrame)
    assert list(frame.columns) == list(COLUMNS)
    assert (frame["unit"] == "").all()                      # no param_units: blank
    result.param_units = ["1/s", "1/s^2", "1/s", "1/s^2", "1/s"]
    try:
        frame = result.table().to_frame()
        assert list(frame["unit"]) == result.param_units
        np.testing.assert_array_equal(frame["sigma_corrected"], result.sigma_corrected)
        result.param_units = ["1/s"]
        with pytest.raises(mlid.InputError, match="param_units"):
            result.table()
    finally:
        del result.param_units


def test_flag_and_zero_estimate(result):
    fake = type("R", (), {})()
    fake.names = ["a", "b"]
    fake.estimate = np.array([2.0, 0.0])
    fake.sigma = np.array([0.1, 0.1])
    fake.sigma_corrected = np.array([0.25, 0.15])
    t = results_table(fake, case=3)
    assert [r["flag"] for r in t.rows] == [True, False]
    assert t.rows[0]["relative_sigma_percent"] == pytest.approx(12.5)
    assert t.columns[0] == "case"
    assert json.loads(t.json_text())["rows"][1]["relative_sigma_percent"] is None
    assert "--" in t.latex_text() and "coloured" in t.csv_text()
    with pytest.raises(mlid.InputError, match="suffix"):
        t.write("out.xlsx")


def test_files_whole_or_not_at_all(result, tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("old\n")
    with pytest.raises(mlid.InputError):
        result.table().to_csv(tmp_path / "missing" / "t.csv")
    assert path.read_text() == "old\n"
    assert list(tmp_path.iterdir()) == [path]


def test_cli_table(tmp_path):
    deck = REPO / "cases" / "c8_short_period" / "c8.nml"
    work = tmp_path / "c8.nml"
    work.write_text(deck.read_text())
    for suffix in ("csv", "json", "tex"):
        out = tmp_path / f"t.{suffix}"
        p = subprocess.run([sys.executable, "-m", "mlid", "run", str(work), "--table", str(out)],
                           capture_output=True, text=True, cwd=tmp_path)
        assert p.returncode == 0, p.stderr
    rows = list(csv.DictReader(open(tmp_path / "t.csv", newline="")))
    assert [r["case"] for r in rows] == ["2"] * 5       # case 1 simulates: no table rows
    assert json.loads((tmp_path / "t.json").read_text())["rows"][0]["case"] == 2
    p = subprocess.run([sys.executable, "-m", "mlid", "run", str(work), "--table",
                        str(tmp_path / "t.xlsx")], capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode != 0 and "suffix" in p.stderr and p.stderr.count("\n") == 1


def test_concat():
    a = ResultsTable([{"case": 1, **dict.fromkeys(COLUMNS, 0.0)}])
    assert len(ResultsTable.concat([a, a])) == 2


def test_text_table_holds_every_row_at_its_printed_precision():
    from mlid.estimate.table import ResultsTable
    rows = [{"name": "C_Lalpha", "unit": "1/rad", "estimate": 3.21174, "sigma_cr": 0.0394,
             "sigma_corrected": 0.128, "relative_sigma_percent": 3.987, "flag": True},
            {"name": "C_D0", "unit": "-", "estimate": 0.0, "sigma_cr": 1e-3,
             "sigma_corrected": 1.2e-3, "relative_sigma_percent": float("nan"), "flag": False}]
    lines = ResultsTable(rows).text().splitlines()
    assert lines[0].split() == ["parameter", "unit", "estimate", "CR", "sigma", "corr.", "sigma",
                                "rel.", "%", "flag"]
    first, second = lines[1].split(), lines[2].split()
    assert first[:2] == ["C_Lalpha", "1/rad"] and first[-1] == "coloured"
    assert [float(x) for x in first[2:6]] == [3.21174, 0.0394, 0.128, 3.99]
    assert second[-1] == "--" and len(lines) == 4


@pytest.mark.parametrize("name, tex", [("Z_alpha", r"$Z_{\alpha}$"), ("C_m_de", r"$C_{m_{\mathrm{de}}}$"),
                                       ("M_q", "$M_{q}$"), ("alpha", r"$\alpha$"), ("Mq", "Mq"),
                                       ("f(1,1)", "f(1,1)"), ("x0(1)#2", r"x0(1)\#2")])
def test_latex_names_are_math(name, tex):
    """Issue 42: the LaTeX table printed Z\\_alpha for Z_alpha."""
    from mlid.estimate.table import latex_name
    assert latex_name(name) == tex


@pytest.mark.parametrize("unit, tex", [("1/s2", r"\si{s^{-2}}"), ("rad/s", r"\si{rad.s^{-1}}"),
                                       ("m/(rad.s)", r"\si{m.rad^{-1}.s^{-1}}"), ("-", ""),
                                       ("deg%", r"deg\%")])
def test_latex_units_are_siunitx_powers(unit, tex):
    """Issue 42: the LaTeX table printed 1/s2 for s^-2."""
    from mlid.estimate.table import latex_unit
    assert latex_unit(unit) == tex


def test_latex_escape_keeps_a_cell_on_one_line():
    from mlid.estimate.table import latex_escape
    assert latex_escape("a_b & 50%\nnext") == r"a\_b \& 50\% next"
