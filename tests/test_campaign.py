"""Campaigns (issue 18): `mlid run` over several decks gives the same
printout and JSON with 1 and 2 local worker processes and on a local Dask
cluster; a failing case does not stop the others; the campaign table has one
row per case with its flight condition and the estimates with sigma."""

import csv
import json
import subprocess

import numpy as np
import pytest

from conftest import BIN, REPO

C8 = REPO / "cases" / "c8_short_period" / "c8.nml"
SIMULATE, ESTIMATE = C8.read_text().split("&case title = 'C-8 short period: output-error fit'")
ESTIMATE = ESTIMATE[ESTIMATE.index("\n&model"):]              # the groups after &case
MACHS = (0.3, 0.4, 0.5)


def _decks(folder):
    """Three one-case decks, each the C-8 fit on its own window of the
    record (which c8.nml's simulate case writes first, into a subfolder that
    holds no campaign deck), at its own Mach number; a fourth case that
    cannot run."""
    sim = folder / "record"                   # the record, made by c8.nml's simulate case
    sim.mkdir()
    (sim / "sim.nml").write_text(SIMULATE)
    subprocess.run([str(BIN / "mlid-batch"), str(sim / "sim.nml")], check=True,
                   capture_output=True, timeout=120)
    body = ESTIMATE.replace("file = 'c8_doublet.dat'", f"file = '{sim / 'c8_doublet.dat'}'")
    for k, (mach, t_end) in enumerate(zip(MACHS, (4.0, 5.0, 6.0)), 1):
        text = (f"&case title = 'window {t_end}', job = 'estimate', mach = {mach}, "
                f"altitude = {1000 * k}., config = 'clean', tags = 'short period, doublet' /"
                + body.replace("output_cols = 3, 4, 5, 6 /",
                               f"output_cols = 3, 4, 5, 6, t_end = {t_end} /"))
        if k == 3:
            text += "\n&case title = 'broken', job = 'estimate', mach = -1 /\n"
        (folder / f"d{k}.nml").write_text(text)
    return folder


def _run(args):
    out = subprocess.run([str(BIN / "mlid"), "run", "-q", *map(str, args)],
                         capture_output=True, text=True, timeout=600)
    return out.returncode, out.stdout, out.stderr


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = _decks(tmp_path_factory.mktemp("campaign"))
    got = {}
    for name, extra in (("serial", ["--workers", "1"]), ("two", ["--workers", "2"])):
        js, table = folder / f"{name}.json", folder / f"{name}.csv"
        got[name] = _run([folder, *extra, "--json", js, "--campaign", table]) + (
            js.read_text(), table.read_text())
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        js, table = folder / "dask.json", folder / "dask.csv"
        got["dask"] = _run([folder, "--scheduler", cluster.scheduler_address, "--json", js,
                            "--campaign", table]) + (js.read_text(), table.read_text())
    return folder, got


def test_workers_and_a_dask_cluster_give_the_serial_run(runs):
    _, got = runs
    assert got["serial"][0] == 1                        # the broken case fails, alone
    for name in ("two", "dask"):
        assert got[name] == got["serial"], name
    assert got["serial"][1].count("converged") >= 3


def test_a_failed_case_does_not_stop_the_others(runs):
    _, got = runs
    code, out, err, js, _ = got["serial"]
    cases = json.loads(js)
    assert len(cases) == 4 and [c["status"] for c in cases[:3]] == [0, 0, 0]
    assert "mach must be >= 0" in err and "1 of 4 cases failed" in err


def test_campaign_table_has_conditions_and_estimates(runs):
    folder, got = runs
    rows = list(csv.DictReader(got["serial"][4].splitlines()))
    assert [float(r["mach"]) for r in rows[:3]] == list(MACHS)
    assert [r["status"] for r in rows] == ["converged"] * 3 + ["failed"]
    assert rows[0]["config"] == "clean" and rows[0]["tags"] == "short period; doublet"
    fits = json.loads(got["serial"][3])
    for r, fit in zip(rows[:3], fits):
        k = fit["parameters"].index("M_q")
        assert float(r["M_q"]) == pytest.approx(fit["estimate"][k], rel=1e-12)
        assert float(r["M_q_sigma"]) == pytest.approx(fit["sigma"][k], rel=1e-12)
        assert r["M_q_unit"] == fit["units"][k]          # the unit the plots put on the axis
    # a longer window: a smaller sigma
    assert np.all(np.diff([float(r["M_q_sigma"]) for r in rows[:3]]) < 0)


def test_campaign_plots_and_bad_options(runs, tmp_path):
    folder, _ = runs
    code, out, err = _run([folder / "d1.nml", folder / "d2.nml", "--campaign-plots",
                           tmp_path / "plots", "--against", "altitude"])
    assert code == 0 and (tmp_path / "plots" / "M_q_vs_altitude.png").stat().st_size > 1000
    code, _, err = _run([folder, "--campaign", tmp_path / "t.txt"])
    assert code == 1 and err.strip().endswith("the suffix must be .csv or .json")
    code, _, err = _run([folder, "--scheduler", "localhost"])
    assert code == 1 and "give an address" in err
    code, _, err = _run([folder / "nothing.nml"])
    assert code == 1 and "file not found" in err           # the core's words, as mlid-batch


def test_a_deck_whose_cases_depend_on_each_other_runs_in_order(tmp_path):
    """c8.nml's estimate case reads the record its simulate case writes: on
    two workers, two such decks give the serial run's output."""
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "c8.nml").write_text(C8.read_text())
    serial = _run([tmp_path / "a", tmp_path / "b", "--workers", "1"])
    assert serial[0] == 0 and serial[1].count("converged") >= 2
    assert _run([tmp_path / "a", tmp_path / "b", "--workers", "2"]) == serial


def test_plots_of_several_decks_are_each_decks_own(tmp_path):
    """Issue 42: `mlid run FOLDER --plots p` over several decks left one
    case2_fit.png, each deck's replacing the last; now each deck has a
    folder of its own in p (one deck keeps p itself)."""
    from conftest import two_case_deck
    for name in ("a", "b"):
        folder = tmp_path / name
        folder.mkdir()
        (folder / f"{name}.nml").write_text(two_case_deck())
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / "a.nml").write_text(two_case_deck())    # a second deck named a
    run = subprocess.run([str(BIN / "mlid"), "run", "a/a.nml", "b/b.nml", "c/a.nml", "--plots",
                          "p", "-q"], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert run.returncode == 0, run.stderr
    made = sorted(str(p.relative_to(tmp_path / "p")) for p in (tmp_path / "p").rglob("*_fit.png"))
    assert made == ["a_a/case2_fit.png", "b/case2_fit.png", "c_a/case2_fit.png"], made
    run = subprocess.run([str(BIN / "mlid"), "run", "b/b.nml", "--plots", "q", "-q"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert (tmp_path / "q" / "case2_fit.png").is_file()
