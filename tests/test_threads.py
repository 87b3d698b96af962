"""Reproducible parallel numerics (issue 15): results do not depend on the
number of OpenMP threads.  The filter-error cases, whose gain partials and
per-sample assembly run over threads, through both front ends with one
thread and with two: every estimate, sigma and the cost within 1e-12
relative, and in fact the same report and JSON bytes.  And the X-22 README's
table, which x22.py prints, holds with either."""

import json
import os
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import BIN, REPO

THREADS = ("1", "2")
FRONT_ENDS = {"mlid": ["run"], "mlid-batch": []}
X22 = REPO / "cases" / "x22_vtol"
HFB320 = REPO / "cases" / "hfb320" / "hfb320.nml"


def x22_deck(folder):
    """The X-22 deck (simulate with gusts, then 23 coefficients by the
    extended Kalman filter), in folder: its record is written there."""
    return shutil.copy(X22 / "x22.nml", folder / "x22.nml")


def hfb320_filter_error_deck(folder):
    """The HFB-320 deck's filter-error cases alone (20 parameters, real
    flight data; case 3 the extended Kalman filter, case 4 the steady-state
    gain; the ml_fem2 cases after them: tests/test_hfb320_fem.py), their data
    paths made absolute."""
    text = HFB320.read_text()
    starts = [m.start() for m in re.finditer(r"^&case\b", text, flags=re.M)]
    case = text[starts[2]:starts[4]]
    assert case.count("filter_error") == 2 and "steady_state = .true." in case
    case = re.sub(r"file = '([^']+)'",
                  lambda m: f"file = '{(HFB320.parent / m.group(1)).resolve()}'", case)
    deck = folder / "hfb320_fe.nml"
    deck.write_text(case)
    return deck


DECKS = {"x22": x22_deck, "hfb320_filter_error": hfb320_filter_error_deck}
HFB320_DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"
needs = {"hfb320_filter_error": pytest.mark.skipif(not HFB320_DATA.is_file(),
                                                   reason="real flight data not beside the checkout")}


def run_deck(exe, deck, threads, folder):
    """The deck through one front end with OMP_NUM_THREADS = threads: its
    printed report and its JSON bytes."""
    path = folder / f"{exe}-{threads}.json"
    run = subprocess.run([str(BIN / exe), *FRONT_ENDS[exe], str(deck), "--json", str(path)],
                         capture_output=True, text=True,
                         env={**os.environ, "OMP_NUM_THREADS": threads})
    assert run.returncode == 0, run.stderr
    return run.stdout, path.read_bytes()


@pytest.mark.parametrize("exe", sorted(FRONT_ENDS))
@pytest.mark.parametrize("name", [pytest.param(n, marks=needs.get(n, ())) for n in sorted(DECKS)])
def test_filter_error_decks_do_not_depend_on_the_thread_count(name, exe, tmp_path):
    deck = DECKS[name](tmp_path)
    (report1, json1), (report2, json2) = (run_deck(exe, deck, n, tmp_path) for n in THREADS)
    one, two = json.loads(json1), json.loads(json2)
    assert [c["job"] for c in one] == [c["job"] for c in two]
    fits = [(a, b) for a, b in zip(one, two) if a["job"] == "estimate"]
    assert fits and all(a["converged"] for a, _ in fits)
    for a, b in fits:
        assert a["parameters"] == b["parameters"]
        for key in ("estimate", "sigma", "cost"):
            np.testing.assert_allclose(b[key], a[key], rtol=1e-12, atol=0, err_msg=key)
        assert a["iterations"] == b["iterations"]
    # measured: not only within 1e-12, the same bits
    assert json1 == json2
    assert report1 == report2


def x22_output(threads):
    """x22.py's printout with OMP_NUM_THREADS = threads, run times removed
    (the only thing that may differ)."""
    run = subprocess.run([sys.executable, str(X22 / "x22.py")], capture_output=True, text=True,
                         cwd=X22, env={**os.environ, "OMP_NUM_THREADS": threads})
    assert run.returncode == 0, run.stderr
    return re.sub(r"\d+ ms", "_ ms", run.stdout)


def readme_rows(section):
    """The table rows of one README section, cells stripped, the header and
    the rule left out; minus signs and deltas as x22.py prints them."""
    text = (X22 / "README.md").read_text(encoding="utf-8")
    body = text.split(section, 1)[1].split("\n## ", 1)[0]
    rows = [line for line in body.splitlines() if line.startswith("|")]
    cells = [[c.strip().replace("−", "-").replace("δ", "de")
              for c in row.strip().strip("|").split("|")]
             for row in rows if not set(row) <= set("|-: ")]
    return cells[1:]


def printed_rows(out, start, stop):
    """{label: numbers} of the printed table between the lines that contain
    start and stop."""
    body = out.split(start, 1)[1].split(stop, 1)[0]
    rows = {}
    for line in body.splitlines()[1:]:
        words = line.replace("(", " ").replace(")", " ").split()
        if words:
            rows[words[0]] = words[1:]
    return rows


def test_the_x22_readme_holds_with_one_and_two_threads():
    """x22.py prints the same with one thread and with two, and the README's
    tables of its numbers are that printout: the 23 coefficients against
    Table 5.1 (estimates, sigmas, ratios) and the derivatives at trim."""
    one, two = x22_output("1"), x22_output("2")
    assert one == two
    printed = printed_rows(one, "Table 5.1 against mlid", "multistep sigma / column 3")
    sigma_rows = readme_rows("## Table 5.1 against mlid")
    assert len(sigma_rows) == 23 + 4          # the coefficients, then the summary table
    for row in sigma_rows[:23]:
        words = printed[row[0]]
        for cell in (row[1], row[3], row[4], row[6], row[7]):
            for number in cell.replace("(", " ").replace(")", " ").split():
                assert number in words, (row[0], cell, words)
    printed = printed_rows(one, "derivatives at u =", "report, sigma column 1")
    table = [r for r in readme_rows("## Fits, start-ups and the derivatives at trim")
             if len(r) == 6 and r[0] in printed]
    assert {r[0] for r in table} == {"M_q", "M_w", "M_de", "X_de", "Z_o", "Z_de"}
    for row in table:
        words = " ".join(row[1:]).replace("(", " ").replace(")", " ").split()
        assert words == printed[row[0]], row
