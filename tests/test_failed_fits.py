"""Failed fits say so cleanly (issue 15 item 5).  A fit that an error ended
(singular information, a diverged simulation, a non-finite cost, an
innovation covariance not positive definite) has no estimates: both front
ends print the same report of it, with the start and the last values
reached and the error, and no sigma, correlations, eigenvalues or cost; its
JSON has null for those.  A fit that ran out of iterations is a result with
a warning: sigma printed, flagged not converged, the case not failed."""

import json
import re
import subprocess

import numpy as np
import pytest

import mlid
import mlid.report.plots
from conftest import BIN, run_both

DATA = "&data file = 'two.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /"


def model(f11=-1.0, g11=1.0, more=""):
    """The &model group: two states, the second never moving (x0 = 0, no input)."""
    return f"&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = {f11}, 0.5, 0.0, -2.0,\n" \
           f"    g = {g11}, 0.0, h = 1, 0, 0, 1{more} /"


def case(title, f11=-1.0, g11=1.0, free="'f(1,1)', 'g(1,1)'", extra="", estimate="",
         job="estimate", data=DATA):
    return "\n".join([f"&case title = '{title}', job = '{job}' /",
                      model(f11, g11, f",{extra}\n    free = {free}"), data,
                      # max_iter once: a name given twice is refused
                      f"&estimate {'' if 'max_iter' in estimate else 'max_iter = 10 '}{estimate}/",
                      ""])


# State 2 never moves: f(1,2) and f(2,2) have no effect on the outputs.
# f(1,1) = 300: the state grows past the largest double within the record; 150: the
# outputs stay finite but the cost does not.  The filter's S = 0.5 with q = 1 and
# r = 1e-4 is no covariance ([q S; S r] indefinite): B is not positive definite at
# the first update after the start.
DECK = "\n".join([
    "&case title = 'simulate', job = 'simulate' /",
    model(),
    "&simulate out = 'two.dat', t_end = 4.0, dt = 0.02, seed = 3, noise_std = 0.01, 0.01,",
    "    input_shape = 'doublet', amplitude = 1.0, t_start = 0.5, pulse_width = 0.5 /", "",
    case("unidentifiable", free="'f(1,2)', 'f(2,2)'"),
    case("diverges", f11=300.0),
    case("cost not finite", f11=150.0),
    case("filter error, B not positive definite", free="'f(1,1)', 'g(1,1)', 'r(1)'",
         extra=" nw = 1, gamma = 1, 0, q = 1, r = 1e-4, 1e-4, s = 0.5, 0,",
         estimate="method = 'filter_error' "),
    case("validate, diverges", f11=300.0, job="validate",
         data="&data file = 'two.dat', 'two.dat', time_col = 1, input_cols = 2, "
              "output_cols = 3, 4, holdout = 2 /"),
    case("not converged", f11=-0.6, g11=1.4, estimate="max_iter = 1 "),
    case("good", f11=-0.6, g11=1.4),
])
# case number: what its failure message says
FAILED = {2: "'f(1,2)' is not identifiable from these data",
          3: "simulation diverged: state non-finite at t =",
          4: "cost is not finite",
          5: "innovation covariance B = C P C' + R is not positive definite at t =",
          6: "simulation diverged: state non-finite at t ="}
NOT_CONVERGED, GOOD = 7, 8
# what a report of a failed fit must not hold: any statistic of the fit
STATISTICS = re.compile(r"sigma +sigma col\.|sigma col\.:|correlations above|eigenvalue|"
                        r"weakest direction|cost J|[RB] diagonal|det [RB]")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The deck through both front ends: their processes, JSON and stdout by case."""
    folder = tmp_path_factory.mktemp("failed")
    deck = folder / "failed.nml"
    deck.write_text(DECK)
    procs = run_both(deck, "--json", str(folder / "{exe}.json"), cwd=folder)
    objs = [json.loads((folder / f"{exe}.json").read_text()) for exe in ("mlid", "mlid-batch")]
    sections = dict(zip(range(1, 9), procs[0].stdout.split("\n case ")[1:]))
    return {"procs": procs, "json": objs, "sections": sections, "folder": folder, "deck": deck}


def test_both_front_ends_print_and_write_the_same(runs):
    py, fo = runs["procs"]
    assert py.stdout == fo.stdout
    assert runs["json"][0] == runs["json"][1]
    assert (runs["folder"] / "mlid.json").read_bytes() == \
        (runs["folder"] / "mlid-batch.json").read_bytes()
    # the failures, and only they, are counted; the not-converged fit is a warning
    for proc in (py, fo):
        assert proc.returncode == 1
        assert proc.stderr.splitlines()[-1] == f"{len(FAILED)} of 8 cases failed"
    assert py.stderr.replace("mlid: ", "mlid-batch: ") == fo.stderr


@pytest.mark.parametrize("k", sorted(FAILED))
def test_a_failed_fit_reports_last_values_and_the_error_only(runs, k):
    text = runs["sections"][k]
    lines = text.rstrip("\n").split("\n")
    assert re.fullmatch(r" [\w -]+ML, .*: failed after \d+ iterations, no estimates", lines[1])
    assert lines[2].split() == ["parameter", "unit", "start", "last", "value"]
    # between the first line (the method: 'R diagonal' is its option) and the error
    assert not STATISTICS.search("\n".join(lines[2:-1])), text
    # one statement of what failed, the last line, naming the item, sample or time
    failed = [ln for ln in lines if "FAILED" in ln]
    assert failed == [lines[-1]] and FAILED[k] in lines[-1]
    assert "last value: where the fit stopped, not an estimate" in text
    # a row per free parameter: its start and last value, nothing else
    obj = runs["json"][0][k - 1]
    rows = lines[3:3 + len(obj["parameters"])]
    for row, name, start, last in zip(rows, obj["parameters"], obj["start"],
                                      obj["last_values"]):
        label, *numbers = row.split()
        assert label == name and [float(x) for x in numbers] == pytest.approx([start, last],
                                                                              rel=1e-6)


@pytest.mark.parametrize("k", sorted(FAILED))
def test_a_failed_fit_has_nulls_in_its_json(runs, k):
    obj = runs["json"][0][k - 1]
    assert obj["failed"] is True and obj["status"] not in (0, 1) and FAILED[k] in obj["message"]
    for key in ("estimate", "sigma", "sigma_corrected", "colored_lag", "correlation", "R",
                "det_R", "cost", "cost_history", "rank"):
        assert obj[key] is None, key
    assert obj["converged"] is False
    assert len(obj["last_values"]) == len(obj["parameters"]) == len(obj["start"])
    assert all(np.isfinite(obj["last_values"]))
    assert "validation" not in obj


def test_a_failure_at_the_start_stops_at_the_start_values(runs):
    for k in (3, 4, 5):
        obj = runs["json"][0][k - 1]
        assert obj["iterations"] == 0 and obj["last_values"] == obj["start"]


def test_not_converged_is_a_result_with_a_warning(runs):
    text = runs["sections"][NOT_CONVERGED]
    assert "NOT converged (iteration limit reached)" in text and "FAILED" not in text
    assert "sigma col." in text and "correlations above" in text
    obj = runs["json"][0][NOT_CONVERGED - 1]
    assert obj["failed"] is False and obj["status"] == 4 and obj["converged"] is False
    assert all(s > 0 for s in obj["sigma"]) and np.isfinite(obj["cost"])
    for proc in runs["procs"]:
        warned = [ln for ln in proc.stderr.splitlines() if "'not converged'" in ln]
        assert len(warned) == 1 and warned[0].endswith(
            "warning: not converged after 1 iterations: iteration limit reached")


def test_the_rest_of_the_batch_still_runs(runs):
    obj = runs["json"][0][GOOD - 1]
    assert obj["status"] == 0 and obj["failed"] is False and obj["converged"] is True
    assert obj["estimate"] == pytest.approx([-1.0, 1.0], abs=0.05)
    assert "converged (relative cost change" in runs["sections"][GOOD]


def test_no_plot_table_or_html_statistics_of_a_failed_fit(runs, tmp_path):
    proc = subprocess.run([str(BIN / "mlid"), "run", str(runs["deck"]), "--plots",
                           str(tmp_path / "plots"), "--table", str(tmp_path / "t.csv"),
                           "--report", str(tmp_path / "html")],
                          capture_output=True, text=True, cwd=runs["folder"])
    assert proc.returncode == 1
    for k in FAILED:                    # the same text, nothing added
        assert f" case {runs['sections'][k]}" in proc.stdout
    drawn = {p.name.split("_")[0] for p in (tmp_path / "plots").iterdir()}
    assert drawn == {f"case{NOT_CONVERGED}", f"case{GOOD}"}
    assert (tmp_path / "plots" / f"case{GOOD}_fit.png").is_file()
    cases = {line.split(",")[0] for line in (tmp_path / "t.csv").read_text().splitlines()[1:]}
    assert cases == {str(NOT_CONVERGED), str(GOOD)}
    page = (tmp_path / "html" / "failed.html").read_text()
    for k in FAILED:
        section = page.split(f'id="case-{k}"')[1].split("<section")[0]
        assert "Last values reached (not estimates)" in section and "failed" in section
        assert "<img" not in section and "&#963;" not in section   # no figure, no sigma


@pytest.fixture(scope="module")
def two_states():
    truth = mlid.LinearModel([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2))
    t = np.arange(200) * 0.02
    return mlid.simulate(truth, t, np.sin(3 * t)[:, None], [0.01, 0.01], seed=3)[0]


def failed_fit(model, data, error):
    with pytest.raises(error) as exc:
        mlid.fit(model, data)
    assert exc.value.result is not None and exc.value.result.failed
    return exc.value


def test_python_objects_of_a_failed_fit_show_no_statistics(two_states):
    model = mlid.LinearModel([[-0.6, 0.5], [0.0, -2.0]], [[1.4], [0.0]], np.eye(2),
                             free=["f(1,1)", "f(1,2)", "g(1,1)"])
    exc = failed_fit(model, two_states, mlid.SingularInformationError)
    res = exc.result
    assert res.iterations >= 1 and not res.converged
    assert repr(res) == f"FitResult(failed after {res.iterations} iterations: {exc})"
    assert "\u03c3" not in res._repr_html_() and "FAILED: " in res._repr_html_()
    assert res.report().split("\n")[-1] == f" FAILED: {exc}"
    for name in mlid.estimate.result.NOT_IN_A_FAILED_FIT:
        assert np.all(np.isnan(getattr(res, name))), name
    d = res.as_dict()
    assert d["failed"] and d["sigma"] is None and d["correlation"] is None
    assert d["last_values"] == res.estimate.tolist() and d["estimate"] is None
    obj = json.loads(res.json())
    assert obj["failed"] is True and obj["sigma"] is None and obj["message"] == str(exc)
    assert res.identifiability() == []
    for make in (res.table, res.whiteness, res.noise_diagonal,
                 lambda: mlid.report.plots.fit_overview(res),
                 lambda: mlid.report.plots.correlation(res),
                 lambda: mlid.report.plots.bode(res)):
        with pytest.raises(mlid.InputError, match="of a failed fit"):
            make()


def test_every_failure_of_a_fit_carries_its_last_values(two_states):
    for f11, error in ((150.0, mlid.SingularInformationError),   # cost not finite
                       (1000.0, mlid.DivergenceError)):
        model = mlid.LinearModel([[f11, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2),
                                 free=["f(1,1)"])
        res = failed_fit(model, two_states, error).result
        assert res.estimate.tolist() == res.start.tolist() == [f11]


def test_a_fit_that_runs_out_of_iterations_keeps_its_sigma(two_states):
    model = mlid.LinearModel([[-0.6, 0.5], [0.0, -2.0]], [[1.4], [0.0]], np.eye(2),
                             free=["f(1,1)", "g(1,1)"])
    res = mlid.fit(model, two_states, max_iter=1)
    assert not res.failed and not res.converged and res.status == 4
    assert np.all(res.sigma > 0) and np.isfinite(res.cost)
    assert "sigma col." in res.report() and res.as_dict()["sigma"] == res.sigma.tolist()
