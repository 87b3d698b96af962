"""Decks through both front ends: `mlid run` (Python) and `mlid-batch`
(Fortran) must read a deck the same way, give the same numbers, and turn
every bad input into one line naming deck, case and problem while the rest
of the batch still runs."""

import json
import os
import shutil
import stat
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, REPO, run_both

C8_CASE = REPO / "cases" / "c8_short_period"

SMALL = """
&case title = '{title}', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5,
        -0.8, -2.0,
    g = 1.0, 0.3,
    h = 1, 0,
        0, 1,
    free = 'f(1,1)', 'f(2,1)', 'g(1,1)', names = 'a11', 'a21', 'b1' /
&data file = '{file}', time_col = 1, input_cols = 2, output_cols = 3, 4 /
"""
SIM = """
&case title = 'make data', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.2, 0.5, -1.0, -2.0,   g = 1.5, 0.3,   h = 1, 0, 0, 1 /
&simulate out = 'small.dat', t_end = 4.0, dt = 0.02, seed = 4, noise_std = 0.01, 0.01,
    input_shape = '3211', amplitude = 1.0, t_start = 0.2, pulse_width = 0.2 /
"""


#: A case that runs for many seconds (a million fits), to be killed in.
LONG_MONTE_CARLO = """
&case title = 'long', job = 'monte_carlo' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1, r = 0.0001, 0.0001,
    free = 'f(1,1)', 'f(2,1)', 'g(1,1)' /
&monte_carlo runs = 1000000, seed = 1, input_file = 'small.dat', truth = -1.2, -1.0, 1.5 /
"""


def _run_both(deck, *extra):
    py = subprocess.run([str(BIN / "mlid"), "run", str(deck), *extra], capture_output=True,
                        text=True)
    fo = subprocess.run([str(BIN / "mlid-batch"), str(deck), *extra], capture_output=True,
                        text=True)
    return py, fo


DECKS = {"c8": (C8_CASE / "c8.nml", ["M_q", "M_alpha", "Z_alpha", "M_delta", "Z_delta"]),
         "m2f3": (REPO / "cases" / "m2f3_gusts" / "m2f3.nml",
                  # in the order of the deck's free (its names), not theta's
                  ["L_p", "L_r", "L_beta", "N_p", "N_r", "N_beta", "Y_beta", "L_da", "L_dr",
                   "N_da", "N_dr", "Y_da", "Y_dr", "a_gust", "q_gust", "R_p", "R_r", "R_beta",
                   "R_phi", "R_ay"]),
         "x22": (REPO / "cases" / "x22_vtol" / "x22.nml", list(mlid.model.models.X22_LABELS))}


@pytest.mark.parametrize("name", sorted(DECKS))
def test_python_and_batch_give_the_same_numbers(name, tmp_path):
    deck, labels = DECKS[name]
    c8_deck = tmp_path / deck.name
    shutil.copy(deck, c8_deck)
    # umask 022 (mkstemp's 0600 would then show as a difference, whatever the tests' umask)
    py = subprocess.run([str(BIN / "mlid"), "run", str(c8_deck), "--json",
                         str(tmp_path / "py.json"), "--plots", str(tmp_path / "plots")],
                        capture_output=True, text=True, preexec_fn=lambda: os.umask(0o022))
    assert py.returncode == 0, py.stderr
    fo = subprocess.run([str(BIN / "mlid-batch"), str(c8_deck), "--json",
                         str(tmp_path / "fo.json")], capture_output=True, text=True,
                        preexec_fn=lambda: os.umask(0o022))
    assert fo.returncode == 0, fo.stderr
    # one report and one JSON writer, in the core: the same bytes from both
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "fo.json").read_bytes()
    assert _without_plots(py.stdout) == fo.stdout
    # the files as open() makes them (0666 less the umask), mlid-batch's and the plots alike:
    # a report in a shared folder is readable by whoever the umask lets read it
    made = [tmp_path / "py.json", tmp_path / "fo.json", *(tmp_path / "plots").iterdir()]
    assert {stat.S_IMODE(p.stat().st_mode) for p in made} == {0o644}
    a = json.loads((tmp_path / "py.json").read_text())
    b = json.loads((tmp_path / "fo.json").read_text())
    assert [c["job"] for c in a] == [c["job"] for c in b] == ["simulate", "estimate"]
    fa, fb = a[1], b[1]
    assert fa["parameters"] == fb["parameters"] == labels
    np.testing.assert_allclose(fa["estimate"], fb["estimate"], rtol=1e-10, atol=0)
    np.testing.assert_allclose(fa["sigma"], fb["sigma"], rtol=1e-10, atol=0)
    np.testing.assert_allclose(fa["cost"], fb["cost"], rtol=1e-10)
    assert fa["iterations"] == fb["iterations"] and fa["converged"] and fb["converged"]
    # the printed reports are the same text
    assert py.stdout.split("\n case 2")[1].split(" plot:")[0] == fo.stdout.split("\n case 2")[1]
    assert (tmp_path / "plots" / "case2_fit.png").stat().st_size > 10000


def _without_plots(stdout):
    return "".join(ln for ln in stdout.splitlines(keepends=True) if not ln.startswith(" plot:"))


@pytest.mark.parametrize("deck", [REPO / "cases" / "hfb320" / "hfb320.nml",
                                  REPO / "cases" / "user_model" / "cubic_short_period.nml",
                                  REPO / "cases" / "tables" / "attas_alpha_tables.nml"],
                         ids=lambda p: p.parent.name)
def test_every_other_deck_gives_the_same_bytes(deck, tmp_path):
    """The decks of cases/ not run above: report and JSON byte for byte."""
    if "shared/data" in deck.read_text() and not (REPO.parent / "shared" / "data").is_dir():
        pytest.skip("real flight data not found beside the checkout")
    py = subprocess.run([str(BIN / "mlid"), "run", str(deck), "--json", str(tmp_path / "py.json")],
                        capture_output=True, text=True)
    fo = subprocess.run([str(BIN / "mlid-batch"), str(deck), "--json", str(tmp_path / "fo.json")],
                        capture_output=True, text=True)
    assert py.returncode == fo.returncode == 0, (py.stderr, fo.stderr)
    assert (tmp_path / "py.json").read_bytes() == (tmp_path / "fo.json").read_bytes()
    assert py.stdout == fo.stdout
    assert all(c["status"] == 0 for c in json.loads((tmp_path / "py.json").read_text()))


def _bad_deck(tmp_path, bad_case):
    """A batch: simulate data, a bad case, then a good fit that must still run."""
    text = SIM + bad_case + SMALL.format(title="good fit", file="small.dat")
    deck = tmp_path / "batch.nml"
    deck.write_text(text)
    return deck


def _shown(show):
    """The small case with its columns named in rad and show = show."""
    return SMALL.format(title="bad", file="small.dat").replace(
        "output_cols = 3, 4", "output_cols = 3, 4,\n    columns = 't[s]', 'u[rad]', 'a[rad]', "
                              f"'q[rad/s]', show = 'u = deg', '{show}'")


BAD = {
    "unknown group": (SMALL.format(title="bad", file="small.dat").replace(
        "&data", "&modle nx = 2 /\n&data"), "unknown group &modle"),
    "unknown name": (SMALL.format(title="bad", file="small.dat").replace("nx = 2,", "nx = 2, fo = 1,"),
                     "fo"),
    "missing data file": (SMALL.format(title="bad", file="nowhere.dat"), "nowhere.dat"),
    "wrong dimensions": (SMALL.format(title="bad", file="small.dat").replace("-0.8, -2.0,", "-0.8,"),
                         "f has 3 values"),
    "NaN in data": (SMALL.format(title="bad", file="nan.dat"), "nan.dat line 3: column 3: 'nan' is not finite"),
    "too few samples": (SMALL.format(title="bad", file="short.dat"), "too few"),
    "free parameter that does not exist": (
        SMALL.format(title="bad", file="small.dat").replace("'f(2,1)'", "'f(3,1)'"),
        "'f(3,1)' does not exist"),
    "bad job": (SMALL.format(title="bad", file="small.dat").replace("'estimate'", "'estimat'"),
                "job must be"),
    "bad rank rule": (SMALL.format(title="bad", file="small.dat")
                      + "&estimate rank_min = 2, rank_rule = 'stagged' /\n", "rank_rule must be"),
    "missing group": ("&case title = 'bad', job = 'estimate' /\n", "group &model is missing"),
    "column out of range": (SMALL.format(title="bad", file="small.dat").replace(
        "output_cols = 3, 4", "output_cols = 3, 9"), "column 9"),
    # limits checked before any work starts: no overflow, no unbounded allocation
    "max_iter beyond its limit": (SMALL.format(title="bad", file="small.dat")
                                  + "&estimate max_iter = 2147483647 /\n", "max_iter must lie in"),
    "substeps beyond its limit": (SMALL.format(title="bad", file="small.dat").replace(
        "nx = 2,", "nx = 2, substeps = 100000000,"), "substeps must lie in"),
    "pulse far beyond the record": (SIM.replace("make data", "bad").replace("t_start = 0.2",
                                                                         "t_start = 1e12"),
                                    "lies outside the record"),
    "record of 1e12 samples": (SIM.replace("make data", "bad").replace("dt = 0.02", "dt = 4e-12"),
                               "samples; at most"),
    "a group given twice": (SMALL.format(title="bad", file="small.dat")
                            + "&model nx = 3 /\n", "group &model given twice"),
    # the unit a channel is shown in: known, convertible, of a channel that exists
    "show an unknown unit": (_shown("a = dgr"), "small.dat: show a: unknown unit 'dgr'"),
    "show a unit that does not convert": (
        _shown("q = deg"), "small.dat: show q = deg: q is in rad/s, deg converts to rad, not "
                           "rad/s"),
    "show an unknown channel": (_shown("b = deg"), "small.dat: show: no channel named b"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_deck_fails_one_case_in_both_front_ends(tmp_path, name):
    bad, phrase = BAD[name]
    deck = _bad_deck(tmp_path, bad)
    rows = ["0 0 0 0", "0.02 1 0.1 0.1", "0.04 1 nan 0.1", "0.06 1 0.2 0.2"]
    (tmp_path / "nan.dat").write_text("\n".join(rows) + "\n")
    (tmp_path / "short.dat").write_text("\n".join(rows[:2]) + "\n")
    py, fo = _run_both(deck, "--json", str(tmp_path / "out.json"))
    # the same problem in the same words, the same report, from both front ends
    assert py.stdout == fo.stdout
    assert [ln.split("': ", 1)[1] for ln in py.stderr.splitlines() if ln.startswith("mlid:")] == \
        [ln.split("': ", 1)[1] for ln in fo.stderr.splitlines() if ln.startswith("mlid-batch:")]
    for out, who in ((py, "mlid"), (fo, "mlid-batch")):
        assert out.returncode == 1, (who, out.stdout, out.stderr)
        assert "Traceback" not in out.stderr and "Error termination" not in out.stderr
        errors = [ln for ln in out.stderr.splitlines() if ln.startswith(who + ":")]
        assert len(errors) == 1, (who, out.stderr)
        assert "case 2 (line" in errors[0] and phrase in errors[0], (who, errors[0])
        assert "1 of 3 cases failed" in out.stderr
        # the cases before and after still ran
        assert "simulated 201 samples" in out.stdout
        assert out.stdout.count("converged (") == 1, (who, out.stdout)


def test_missing_deck_and_empty_deck(tmp_path):
    py, fo = _run_both(tmp_path / "none.nml")
    assert py.returncode == fo.returncode == 1
    assert "file not found" in py.stderr and "file not found" in fo.stderr
    (tmp_path / "empty.nml").write_text("! nothing here\n")
    py, fo = _run_both(tmp_path / "empty.nml")
    assert py.returncode == fo.returncode == 1
    assert "no &case group" in py.stderr and "no &case group" in fo.stderr


def test_read_deck_api_keeps_case_errors(tmp_path):
    import mlid

    deck = _bad_deck(tmp_path, BAD["wrong dimensions"][0])
    cases = mlid.read_deck(deck)
    assert [c.error is None for c in cases] == [True, False, True]
    assert "f has 3 values" in cases[1].error
    runs = mlid.run_deck(deck)
    assert runs[2][2].converged and runs[1][3] is not None


def test_values_from_an_index_fill_the_following_elements(tmp_path):
    """x(i) = a, b sets x(i) and x(i+1), as a Fortran compiler reads it."""
    deck = tmp_path / "d.nml"
    deck.write_text(SMALL.format(title="idx", file="small.dat")
                    + "&estimate lower(2) = -1.0, -2.0 /\n")
    case = mlid.read_deck(deck)[0]
    assert case.options()["bounds"] == {"f(2,1)": (-1.0, None), "g(1,1)": (-2.0, None)}


def test_state_feedback_in_a_deck_through_both_front_ends(tmp_path):
    """k (the SAS: states fed back to the inputs) read, simulated and
    estimated alike by both front ends."""
    sim = SIM.replace("h = 1, 0, 0, 1 /", "h = 1, 0, 0, 1, k = 0.3, 0.0 /")
    est = """
&case title = 'feedback', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.5, -1.0, -2.0,   g = 1.0, 0.3,   h = 1, 0, 0, 1,   k = 0.0, 0.0,
    free = 'f(1,1)', 'g(1,1)', 'g(2,1)', 'k(1,1)', names = 'a11', 'b1', 'b2', 'K_x1' /
&data file = 'small.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
"""
    deck = tmp_path / "feedback.nml"
    deck.write_text(sim + est)
    out = {}
    for who in ("mlid", "mlid-batch"):
        cmd = [str(BIN / who)] + (["run"] if who == "mlid" else []) + [
            str(deck), "--json", str(tmp_path / f"{who}.json")]
        run = subprocess.run(cmd, capture_output=True, text=True)
        assert run.returncode == 0, (who, run.stderr)
        out[who] = json.loads((tmp_path / f"{who}.json").read_text())[1]
    a, b = out["mlid"], out["mlid-batch"]
    assert a["parameters"] == b["parameters"] == ["a11", "b1", "b2", "K_x1"]
    np.testing.assert_allclose(a["estimate"], b["estimate"], rtol=1e-10, atol=0)
    truth = [-1.2, 1.5, 0.3, 0.3]
    z = (np.array(a["estimate"]) - truth) / np.array(a["sigma"])
    assert np.all(np.abs(z) < 4), dict(zip(a["parameters"], z))


@pytest.mark.parametrize("who", ["mlid", "mlid-batch"])
def test_a_killed_run_leaves_the_previous_json_whole(tmp_path, who):
    """Files are written whole or not at all: a run killed in the middle of a
    deck (here in a Monte Carlo of a million runs, after the record case)
    leaves the previous JSON as it was, and the record it wrote before is
    complete.  (A FIFO as the data file held main's runs; it is refused now:
    tests/test_file_kinds.py.)"""
    import signal
    import time

    deck = tmp_path / "deck.nml"
    deck.write_text(SIM + LONG_MONTE_CARLO)
    old = b'[{"previous": "run"}]\n'
    (tmp_path / "out.json").write_bytes(old)
    cmd = [str(BIN / who)] + (["run"] if who == "mlid" else []) + [
        str(deck), "--json", str(tmp_path / "out.json")]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "small.dat").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)                      # now in the Monte Carlo
        assert proc.poll() is None
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    assert (tmp_path / "out.json").read_bytes() == old
    rows = np.loadtxt(tmp_path / "small.dat", comments="#")
    assert rows.shape == (201, 4)
    leftovers = [p.name for p in tmp_path.iterdir()
                 if p.name not in ("deck.nml", "out.json", "small.dat")]
    assert all(".tmp" in name for name in leftovers), leftovers


def test_a_file_size_limit_leaves_every_file_whole_in_both_front_ends(tmp_path):
    """Under a file size limit (ulimit -f, which fails a write as a full disk
    does), the record of the simulate case and the JSON cannot be written:
    one line each, the same from both front ends; the previous files stay
    as they were and nothing is left beside them.  (The Fortran runtime
    reports no error when a buffered write fails at the close: this is
    the check that the writer asks the file's size.)"""
    import resource

    deck = tmp_path / "c8.nml"
    shutil.copy(C8_CASE / "c8.nml", deck)
    made = subprocess.run([str(BIN / "mlid-batch"), str(deck)], capture_output=True, text=True,
                          cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    record = (tmp_path / "c8_doublet.dat").read_bytes()
    assert len(record) > 20000

    def limited():
        resource.setrlimit(resource.RLIMIT_FSIZE, (2000, 2000))

    lines = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        (tmp_path / "out.json").write_text("old\n")
        run = subprocess.run([str(BIN / exe), *pre, "c8.nml", "--json", "out.json"],
                             capture_output=True, text=True, cwd=tmp_path, preexec_fn=limited)
        assert run.returncode == 1
        assert (tmp_path / "c8_doublet.dat").read_bytes() == record
        assert (tmp_path / "out.json").read_text() == "old\n"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["c8.nml", "c8_doublet.dat",
                                                              "out.json"]
        lines.append([line.split(": ", 1)[1] for line in run.stderr.splitlines()
                      if line.startswith(f"{exe}: ")])
    assert lines[0] == lines[1]
    assert lines[0] == ["c8.nml case 1 (line 7) 'C-8 short period: simulate a doublet record': "
                        "cannot write c8_doublet.dat (the disk is full, a file size limit was reached, or the file went away)",
                        "cannot write out.json (the disk is full, a file size limit was reached, or the file went away)"]


def test_several_decks_run_one_after_another_in_both_front_ends(tmp_path):
    """mlid-batch runs every deck named (it ran the last alone), as `mlid run`
    does: the same report and JSON; a deck that cannot be read is one line,
    the others still run, and the closing lines count cases and decks."""
    shutil.copy(C8_CASE / "c8.nml", tmp_path / "a.nml")
    text = (C8_CASE / "c8.nml").read_text().replace("c8_doublet.dat", "c8_b.dat")
    (tmp_path / "b.nml").write_text(text)
    runs = [subprocess.run([str(BIN / exe), *pre, "a.nml", "b.nml", "none.nml", "--json",
                            f"{exe}.json"], capture_output=True, text=True, cwd=tmp_path)
            for exe, pre in (("mlid", ["run"]), ("mlid-batch", []))]
    assert [r.returncode for r in runs] == [1, 1]
    assert runs[0].stdout == runs[1].stdout
    assert runs[0].stdout.count(" case 2: C-8 short period: output-error fit") == 2
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    assert len(json.loads((tmp_path / "mlid.json").read_text())) == 4
    for run, exe in zip(runs, ("mlid", "mlid-batch")):
        assert run.stderr.splitlines() == [f"{exe}: file not found: none.nml",
                                           "1 of 3 decks could not be read"]


def test_json_onto_a_folder_is_refused_before_any_case_runs(tmp_path):
    shutil.copy(C8_CASE / "c8.nml", tmp_path / "c8.nml")
    (tmp_path / "out").mkdir()
    for run, exe in zip(run_both(tmp_path / "c8.nml", "--json", str(tmp_path / "out")),
                        ("mlid", "mlid-batch")):
        assert run.returncode == 1 and run.stdout == ""
        assert run.stderr.splitlines() == [f"{exe}: cannot write --json {tmp_path / 'out'} "
                                           "(a folder of that name)"]
    assert not (tmp_path / "c8_doublet.dat").exists()


def test_workers_zero_is_refused(tmp_path):
    shutil.copy(C8_CASE / "c8.nml", tmp_path / "c8.nml")
    run = subprocess.run([str(BIN / "mlid"), "run", "c8.nml", "--workers", "0"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 1 and run.stdout == ""
    assert run.stderr.splitlines() == ["mlid: --workers must be >= 1, got 0"]


def test_against_truth_reads_the_simulating_case_at_the_free_elements(tmp_path):
    """FitResult.against_truth: the simulate case's values at the estimate
    case's free elements (f(3,3) ... g(4,1), in the fit's order), and
    (estimate - truth)/sigma from them."""
    shutil.copy(C8_CASE / "c8.nml", tmp_path / "c8.nml")
    (sim_case, _, _, e1), (fit_case, _, res, e2) = mlid.run_deck(tmp_path / "c8.nml")
    assert e1 is None and e2 is None
    values, z = res.against_truth(sim_case.model)
    f, g = np.asarray(sim_case.model.F), np.asarray(sim_case.model.G)
    np.testing.assert_array_equal(values, [f[2, 2], f[2, 3], f[3, 3], g[2, 0], g[3, 0]])
    np.testing.assert_array_equal(z, (res.estimate - values) / res.sigma)
    assert np.all(np.abs(z) < 3)          # the fit is within 3 Cramer-Rao sigma of the truth



def test_outputs_that_would_overwrite_a_deck_or_name_a_folder_are_refused(tmp_path):
    """--json naming a deck of the run replaced the deck; 'new/' wrote a
    file 'new' from mlid run.  Both front ends refuse, before any case."""
    shutil.copy(C8_CASE / "c8.nml", tmp_path / "c8.nml")
    deck = (tmp_path / "c8.nml").read_bytes()
    for target, reason in (("c8.nml", "a deck this run reads"),
                           ("./c8.nml", "a deck this run reads"),
                           ("new/", "its folder is missing or not writable")):
        for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
            for json_args in (["--json", target], [f"--json={target}"]):
                run = subprocess.run([str(BIN / exe), *pre, "c8.nml", *json_args],
                                     capture_output=True, text=True, cwd=tmp_path)
                assert run.returncode == 1 and run.stdout == "", (exe, json_args)
                assert run.stderr.splitlines() == [f"{exe}: cannot write --json {target} "
                                                   f"({reason})"], (exe, run.stderr)
    assert (tmp_path / "c8.nml").read_bytes() == deck
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c8.nml"]


def test_a_folder_of_decks_with_one_unreadable_runs_the_others(tmp_path):
    fold = tmp_path / "fold"
    fold.mkdir()
    for name, out in (("a", "c8_a.dat"), ("c", "c8_c.dat")):
        (fold / f"{name}.nml").write_text((C8_CASE / "c8.nml").read_text()
                                          .replace("c8_doublet.dat", out))
    (fold / "b.nml").write_text("no groups here\n")
    run = subprocess.run([str(BIN / "mlid"), "run", "fold", "--workers", "1"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 1
    assert run.stdout.count(" case 2: C-8 short period: output-error fit") == 2
    assert run.stderr.splitlines()[-1] == "1 of 3 decks could not be read"


def test_parameters_come_in_the_order_of_free(tmp_path):
    """The report, the JSON and the API list the free parameters as the deck
    lists them, whatever their place in theta; the fit is the same fit."""
    text = (C8_CASE / "c8.nml").read_text()
    given = ("free  = 'f(3,3)', 'f(3,4)', 'f(4,4)', 'g(3,1)', 'g(4,1)',\n"
             "    names = 'M_q',    'M_alpha', 'Z_alpha', 'M_delta', 'Z_delta',")
    assert given in text
    mixed = ("free = 'g(3,1)', 'f(4,4)', 'f(3,3)', 'g(4,1)', 'f(3,4)',\n"
             "    names = 'M_delta', 'Z_alpha', 'M_q', 'Z_delta', 'M_alpha',")
    fits = {}
    for name, deck_text in (("theta", text), ("mixed", text.replace(given, mixed))):
        deck = tmp_path / name / "c8.nml"
        deck.parent.mkdir()
        deck.write_text(deck_text)
        py, fo = _run_both(deck, "--json", str(deck.parent / "out.json"))
        assert py.returncode == 0 and fo.returncode == 0, py.stderr + fo.stderr
        fits[name] = json.loads((deck.parent / "out.json").read_text())[1]
        rows = [line.split()[0] for line in fo.stdout.split("sigma col.\n")[1].splitlines()[:5]]
        assert rows == fits[name]["parameters"]
    assert fits["mixed"]["parameters"] == ["M_delta", "Z_alpha", "M_q", "Z_delta", "M_alpha"]
    by_name = dict(zip(fits["theta"]["parameters"], fits["theta"]["estimate"]))
    np.testing.assert_allclose(fits["mixed"]["estimate"],
                               [by_name[n] for n in fits["mixed"]["parameters"]], rtol=1e-9)
