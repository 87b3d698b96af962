"""Model-structure determination in the deck (issue 45 item 5; job =
'stepwise', &stepwise; fortran/case/mlid_job_stepwise.f90): on test case
23's exact regressors (refs/recursive/data_tc23_RLS.csv) both front ends
print and write the same bytes, and each output's selection (path,
terms, estimates, sigma, R^2, PSE) is Python's mlid.stepwise on the same
candidates (mlid.stepwise_candidates); the reference's linear model is
selected with the reference's least-squares values; the selected model
is handed on as &model lines, the same text from the deck and from
ModelStructure.deck_text (the core's); bad settings one line each."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import mlid
from conftest import BIN, REPO, refused_by_both, run_both

REFS = REPO.parent / "shared" / "data" / "refs" / "recursive"
CSV = REFS / "data_tc23_RLS.csv"
needs_refs = pytest.mark.skipif(not CSV.is_file(),
                                reason="the recursive references are not in ../shared")

VARIABLES = ["al", "be", "pn", "qn", "rn", "de", "da", "dr"]
OUTPUTS = ["CD", "CL", "Cm", "CY", "Cl", "Cn"]
ITEMS = ["cd", "cl", "cm", "cy", "croll", "cn"]      # their &model items (Cl's is not cl: CL's)

#: The reference linear model (ref_tc23_RLS.txt's header): each
#: coefficient's regressors besides the constant; the parameter suffixes.
REFERENCE = {"CD": ["al"], "CL": ["al"], "Cm": ["al", "qn", "de"], "CY": ["be"],
             "Cl": ["be", "pn", "rn", "da"], "Cn": ["be", "pn", "rn", "dr"]}
PARAM = {"al": "al", "be": "be", "pn": "p", "qn": "q", "rn": "r", "de": "de", "da": "da",
         "dr": "dr"}


#: The thresholds each method takes (the deck refuses one it does not use).
THRESHOLDS = {"forward": "f_in = 10, f_out = 10, ", "backward": "f_out = 10, ", "mof": ""}


def _deck(method="forward", thresholds=None):
    thresholds = THRESHOLDS[method] if thresholds is None else thresholds
    return f"""&case title = 'TC23 structure ({method})', job = 'stepwise' /
&data file = '{CSV}', time_col = 't',
    input_cols = {', '.join(f"'{v}'" for v in VARIABLES)},
    output_cols = {', '.join(f"'{z}'" for z in OUTPUTS)} /
&stepwise method = '{method}', degree = 2, knot_vars = 'al', 'al', 'be', knots = 0.03, 0.045, 0.0,
    {thresholds}coefficients = 'cd', 'cl', 'cm', 'cy', 'croll', 'cn',
    out = 'start.txt' /
"""


@needs_refs
@pytest.mark.parametrize("method", ["forward", "backward", "mof"])
def test_tc23_deck_is_pythons_stepwise(tmp_path, method):
    """47 candidates (8 variables to degree 2, three linear splines, the
    constant), six coefficients: the same bytes from both front ends; each
    output's path (terms and F), selection, estimates, sigma, R^2, s and PSE
    are mlid.stepwise's on mlid.stepwise_candidates of the same columns
    (the CSV read by the core and by pandas: estimates to 1e-9 relative);
    the model start the deck prints and writes is deck_text's."""
    import pandas as pd
    deck = tmp_path / "sw.nml"
    deck.write_text(_deck(method))
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert runs[0].stderr == runs[1].stderr == ""
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    out = json.loads((tmp_path / "mlid.json").read_text())[0]
    d = pd.read_csv(CSV)
    cands = mlid.stepwise_candidates(d, VARIABLES, degree=2, knots={"al": [0.03, 0.045],
                                                                    "be": [0.0]})
    assert out["candidates"] == ["1"] + list(cands.columns) and len(out["candidates"]) == 48
    starts = []
    for z, item, o in zip(OUTPUTS, ITEMS, out["outputs"]):
        thresholds = {"forward": dict(f_in=10.0, f_out=10.0), "backward": dict(f_out=10.0),
                      "mof": {}}[method]           # the ones the method uses
        r = mlid.stepwise(cands, d[z], method=method, **thresholds)
        assert o["output"] == z and o["selected"] == r.selected, z
        np.testing.assert_allclose(o["estimates"], [r.estimates[n] for n in r.selected],
                                   rtol=1e-9)
        np.testing.assert_allclose(o["sigma"], [r.sigma[n] for n in r.selected], rtol=1e-9)
        np.testing.assert_allclose([o["r2"], o["s"], o["pse"]], [r.r2, r.s, r.pse], rtol=1e-9)
        assert o["path"]["term"] == list(r.path["term"])
        np.testing.assert_allclose(o["path"]["f"], r.path["F"], rtol=1e-7)
        assert o["coefficient"] == item and o["model_start"] == r.deck_text(item)
        assert o["model_start"] in runs[0].stdout
        starts.append(o["model_start"])
    assert (tmp_path / "start.txt").read_text() == "".join(s + "\n" for s in starts)
    # the report and the JSON show the thresholds the method uses, no other
    shown = {"forward": " (F_in 1.000E+01, F_out 1.000E+01): ", "backward": " (F_out 1.000E+01): ",
             "mof": " with PSE: "}[method]
    head = next(line for line in runs[0].stdout.splitlines() if "model structure, " in line)
    assert shown in head and ("F_in" in head) == (method == "forward") \
        and ("F_out" in head) == (method != "mof"), head
    assert ("f_in" in out) == (method == "forward") and ("f_out" in out) == (method != "mof")


@needs_refs
def test_tc23_reference_model_is_selected_with_its_values(tmp_path):
    """A case per coefficient, its reference regressors the variables
    (degree 1): every method keeps them all, the estimates the reference's
    least-squares values (X\\Y) to 1e-8 relative (its table's ten digits);
    the start lines name them as the deck names the coefficient."""
    ls, rows = {}, False
    for line in (REFS / "ref_tc23_RLS.txt").read_text().splitlines():
        rows = line.startswith("# [final]") or (rows and not line.startswith("#"))
        if rows and not line.startswith("#") and line.split():
            f = line.split()
            ls[f[0]] = float(f[3])
    text = ""
    for z, regs in REFERENCE.items():
        for method in ("forward", "backward", "mof"):
            text += f"""&case title = '{z} {method}', job = 'stepwise' /
&data file = '{CSV}', time_col = 't', input_cols = {', '.join(f"'{v}'" for v in regs)},
    output_cols = '{z}' /
&stepwise method = '{method}', coefficients = 'c_{z}' /
"""
    deck = tmp_path / "ref.nml"
    deck.write_text(text)
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    cases = json.loads((tmp_path / "mlid.json").read_text())
    assert len(cases) == 18
    for case in cases:
        z = case["title"].split()[0]
        o = case["outputs"][0]
        assert o["selected"] == ["1"] + REFERENCE[z], case["title"]
        want = [ls[z + ("0" if n == "1" else PARAM[n])] for n in o["selected"]]
        np.testing.assert_allclose(o["estimates"], want, rtol=1e-8)
        assert o["model_start"].startswith(f"    c_{z}_regressors = '1', ")


def test_knots_and_values_are_written_as_python_writes_them():
    """The core writes a knot as %g and a start value as %.10g (the
    candidates' names and the model start come from the core for both
    front ends): the same text as Python's formats."""
    knots = [0.03, -0.2, 1e-5, 1.5e7, 123456.7, 1234567.0, 0.0001, 2.5, -8.0, 1e-300]
    y = np.linspace(-1.0, 1.0, 20)
    c = mlid.stepwise_candidates({"al": y}, ["al"], degree=1, knots={"al": knots})
    assert list(c.columns)[1:] == [f"(al-{k:g})+" for k in knots]
    rng = np.random.default_rng(3)
    X = rng.standard_normal((300, 3))
    r = mlid.stepwise(X, 1e-7 + 3.3e6 * X[:, 0] - 1 / 3 * X[:, 1] + rng.standard_normal(300),
                      f_in=10.0, f_out=10.0)
    values = ", ".join(f"{r.estimates[n]:.10g}" for n in r.selected)
    assert r.deck_text("cm").splitlines()[1] == f"    cm = {values},"


BAD = [
    ("method = 'forward'", "method = 'sideways'",
     "group &stepwise: method must be 'forward', 'backward' or 'mof', not 'sideways'"),
    ("f_in = 10, f_out = 10", "f_in = 2, f_out = 10",
     "f_in and f_out (the partial F to enter and to stay) must be > 0 and finite with "
     "f_out <= f_in"),
    ("knot_vars = 'al', 'al', 'be'", "knot_vars = 'al', 'alpha', 'be'",
     "knot_vars 'alpha' is not one of &data's input_cols (the variables)"),
    ("knots = 0.03, 0.045, 0.0", "knots = 0.03, 0.045",
     "knot_vars and knots take one entry per knot, given 3 and 2"),
    ("degree = 2", "degree = 0", "degree and spline_degree must be 1 to 10"),
    ("\n    out = 'start.txt'", "\n    forced = 'al*gamma', out = 'start.txt'",
     "forced term 'al*gamma' is not among the 48 candidates"),
    ("'croll', 'cn',", "'croll',",
     "coefficients takes one name per output (6, the model start's &model items), got 5"),
    ("'croll', 'cn',", "'cm', 'cn',",
     "outputs 'Cm' and 'Cl' both start &model item 'cm': name each output's item in "
     "coefficients"),
    ("coefficients = 'cd', 'cl', 'cm', 'cy', 'croll', 'cn',", "",
     "outputs 'CL' and 'Cl' both start &model item 'cl': name each output's item in "
     "coefficients"),
    ("\n    out = 'start.txt'", "\n    sig2_max = -1, out = 'start.txt'", "sig2_max must be >= 0"),
    ("&stepwise", "&model kind = 'linear' /\n&stepwise",
     "group &model is not read by job 'stepwise' (it reads &case, &data, &stepwise)"),
    (",\n    output_cols = 'CD', 'CL', 'Cm', 'CY', 'Cl', 'Cn' /", " /",
     "group &data: a stepwise case needs output_cols (the measured coefficients whose model "
     "structure it finds)"),
    ("input_cols = 'al'", "input_cols = '1', 'al'",
     "a variable is named '1', the constant's name: set intercept = F"),
]


def test_a_64_byte_name_is_whole_everywhere(tmp_path):
    """A candidate's name of 64 bytes, CANDLEN (two channels of 32 and 31
    bytes at degree 2), forced and entering: whole in the report, in the
    JSON (its path's '+name' is 65 bytes) and in the model start, from both
    front ends alike."""
    a, b = "a" * 32, "b" * 31
    rng = np.random.default_rng(6)
    t = np.arange(300) * 0.02
    va, vb = rng.standard_normal(300), rng.standard_normal(300)
    y = 0.5 + 2.0 * va * vb + 0.01 * rng.standard_normal(300)
    np.savetxt(tmp_path / "ab.csv", np.column_stack([t, va, vb, y]), delimiter=",",
               header=f"t,{a},{b},y", comments="")
    deck = tmp_path / "ab.nml"
    deck.write_text(f"""&case title = 'long names', job = 'stepwise' /
&data file = 'ab.csv', time_col = 't', input_cols = '{a}', '{b}', output_cols = 'y' /
&stepwise degree = 2, f_in = 10, f_out = 10, out = 'start.txt' /
&case title = 'long names forced', job = 'stepwise' /
&data file = 'ab.csv', time_col = 't', input_cols = '{a}', '{b}', output_cols = 'y' /
&stepwise degree = 2, f_in = 10, f_out = 10, forced = '{a}*{b}' /
""")
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    name = f"{a}*{b}"
    assert len(name) == 64
    for case in json.loads((tmp_path / "mlid.json").read_text()):
        o = case["outputs"][0]
        assert name in case["candidates"] and o["selected"] == ["1", name], case["title"]
        assert o["model_start"].startswith(f"    y_regressors = '1', '{name}',\n")
    path = json.loads((tmp_path / "mlid.json").read_text())[0]["outputs"][0]["path"]["term"]
    assert path[:2] == ["start", "+" + name]
    assert f"+{name} " in runs[0].stdout and f"\n   {name} " in runs[0].stdout


@pytest.mark.skipif(sys.platform != "linux", reason="ulimit -v as on Linux")
def test_candidates_too_large_for_memory_are_one_line(tmp_path):
    """60,000 samples of 8 variables to degree 5: 1,286 candidates (617 MB)
    fit under a 1 GB address limit, the candidates with the constant (617 MB
    more) do not: one line from each front end, not the Fortran runtime's
    abort, and the next case runs (OpenMP one thread: every thread's stack
    takes address space)."""
    rng = np.random.default_rng(7)
    n, names = 60_000, [f"v{k}" for k in range(8)]
    v = rng.standard_normal((n, 8))
    np.savetxt(tmp_path / "big.csv", np.column_stack([np.arange(n) * 0.01, v, v[:, 0]]),
               delimiter=",", fmt="%.6g", header="t," + ",".join(names) + ",y", comments="")
    cols = ", ".join(f"'{k}'" for k in names)
    (tmp_path / "big.nml").write_text(f"""&case title = 'many candidates', job = 'stepwise' /
&data file = 'big.csv', time_col = 't', input_cols = {cols}, output_cols = 'y' /
&stepwise degree = 5, f_in = 1e9, f_out = 1e9 /
&case title = 'a few', job = 'stepwise' /
&data file = 'big.csv', time_col = 't', input_cols = 'v0', 'v1', output_cols = 'y' /
&stepwise /
""")
    for exe, pre in (("mlid", "run "), ("mlid-batch", "")):
        run = subprocess.run(["bash", "-c", f"ulimit -v 1000000 && exec {BIN / exe} {pre}big.nml"],
                             cwd=tmp_path, capture_output=True, text=True, timeout=300,
                             env=dict(os.environ, OMP_NUM_THREADS="1"))
        assert run.returncode == 1 and run.stderr.splitlines() == [
            f"{exe}: big.nml case 1 (line 1) 'many candidates': not enough memory for the "
            "candidates and the constant (617.8 MB)", "1 of 2 cases failed"], run.stderr[-2000:]
        assert "case 2: a few" in run.stdout and "y_regressors = '1', 'v0'," in run.stdout


@needs_refs
@pytest.mark.parametrize("method, thresholds, message", [
    ("backward", "f_in = 10, f_out = 10, ",
     "group &stepwise: f_in (the partial F to enter) is for method 'forward', not 'backward'"),
    ("mof", "f_in = 10, ",
     "group &stepwise: f_in (the partial F to enter) is for method 'forward', not 'mof'"),
    ("mof", "f_out = 10, ", "group &stepwise: f_out (the partial F to stay) is for methods "
     "'forward' and 'backward', not 'mof'"),
    ("backward", "f_out = -1, ", "group &stepwise: f_out (the partial F to stay) must be > 0 "
     "and finite"),
])
def test_a_threshold_the_method_does_not_use_is_refused(tmp_path, method, thresholds, message):
    """Backward elimination takes no f_in (terms only leave), MOF neither
    threshold (the model of least PSE): given, one line from both front
    ends, as a setting that did nothing would otherwise show in the report;
    backward's own f_out is checked alone (4, f_in's default, is no bound
    on it)."""
    deck = tmp_path / "unused.nml"
    deck.write_text(_deck(method, thresholds))
    refused_by_both(deck, message, cwd=tmp_path)
    assert not (tmp_path / "start.txt").exists()


@needs_refs
@pytest.mark.parametrize("change, new, message", BAD)
def test_bad_stepwise_settings_one_line(tmp_path, change, new, message):
    """Each bad setting: one line from both front ends, nothing written."""
    text = _deck()
    assert change in text
    text = text.replace(change, new)
    deck = tmp_path / "bad.nml"
    deck.write_text(text)
    refused_by_both(deck, message, cwd=tmp_path)
    assert not (tmp_path / "start.txt").exists()


@needs_refs
def test_a_failed_selection_names_the_candidate(tmp_path):
    """Backward elimination needs candidates that are not combinations of
    the others; here a variable is given twice: the one line names the
    output and the candidate, as mlid.stepwise's message does, and the
    case after it still runs."""
    text = _deck("backward").replace("input_cols = 'al',", "input_cols = 'al', 'al',")
    deck = tmp_path / "twice.nml"
    deck.write_text(text + _deck("forward").replace("out = 'start.txt'", "out = 'next.txt'"))
    for run in run_both(deck, cwd=tmp_path):
        assert run.returncode == 1
        lines = run.stderr.splitlines()
        assert lines[1:] == ["1 of 2 cases failed"] and "stepwise: output CD: backward elimination: candidate " \
            "'al' is (nearly) a combination of the candidates before it" in lines[0], lines
        assert "case 2: TC23 structure (forward)" in run.stdout
    assert not (tmp_path / "start.txt").exists() and (tmp_path / "next.txt").exists()


@needs_refs
def test_case_deck_tc23_stepwise(tmp_path):
    """cases/online/tc23_stepwise.nml in both front ends alike: the terms
    per coefficient its README gives (forward, F 20: 15, 11, 10, 15, 13,
    11 of 48), Cl's model start under its own item 'croll', and the start
    file the JSON's model starts."""
    text = (REPO / "cases" / "online" / "tc23_stepwise.nml").read_text()
    deck = tmp_path / "tc23.nml"
    deck.write_text(text.replace("../../../shared", str(REPO.parent / "shared")))
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    out = json.loads((tmp_path / "mlid.json").read_text())[0]
    assert [len(o["selected"]) for o in out["outputs"]] == [15, 11, 10, 15, 13, 11]
    assert out["outputs"][4]["model_start"].startswith("    croll_regressors = '1', 'be', ")
    assert (tmp_path / "tc23_stepwise_start.dat").read_text() == \
        "".join(o["model_start"] + "\n" for o in out["outputs"])
