"""The real ATTAS records fitted with tables in alpha (cases/tables) and the
fit JSON's unreached_cells (issue 46): both front ends, the reference of
the constant-coefficient case, the values no sample reaches named alike in
the printed report, the JSON and Python, and the figure of a fit's tables
with the band from its covariance."""

import html
import json
import subprocess

import numpy as np
import pytest

from conftest import BIN, REPO

CASE = REPO / "cases" / "tables"
DECK = CASE / "attas_alpha_tables.nml"
DATA = REPO.parent / "shared" / "data"
needs_data = pytest.mark.skipif(not DATA.is_dir(),
                                reason="real flight data not found beside the checkout")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("tables")
    out = {}
    for name, cmd in (("run", [str(BIN / "mlid"), "run"]), ("batch", [str(BIN / "mlid-batch")])):
        p = subprocess.run(cmd + [DECK.name, "--json", str(tmp / f"{name}.json")], cwd=CASE,
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        out[name] = (p.stdout, (tmp / f"{name}.json").read_bytes())
    return out


@needs_data
def test_the_deck_gives_the_same_bytes_and_names_the_unreached_values(runs):
    assert runs["run"] == runs["batch"]
    cases = json.loads(runs["run"][1])
    assert [c["unreached_cells"] for c in cases[:2]] == [[], []]
    assert cases[2]["unreached_cells"] == [
        f"{t}[8] (ald = 20; weighted where 17 < ald) is reached by no sample: not identifiable"
        for t in ("CDt", "CLt", "Cmt")]
    # the printed report names all three, though rounding leaves Cmt[8] a sigma of ~1e-16
    assert (" not identifiable, left at the a priori value (no information; a table value: "
            "reached by no sample): CDt[8] CLt[8] Cmt[8]\n") in runs["run"][0]


@needs_data
def test_the_constant_coefficient_case_is_the_reference_and_the_tables_improve_it(runs):
    from mlid.report.reference import read_reference
    ref = read_reference(DATA / "refs" / "attas_aero_reg_tc23_fvsysid_octave.txt")
    c1, c2, c3 = json.loads(runs["run"][1])
    for name, est, sig in zip(c1["parameters"], c1["estimate"], c1["sigma"]):
        v, s = ref.estimates[name]
        assert abs(est - v) < 1e-5 * s and sig == pytest.approx(s, rel=1e-4), name
    np.testing.assert_allclose(np.diag(c1["R"]), ref.diag_r[:3], rtol=1e-6)
    assert c2["det_R"] < 0.7 * c1["det_R"]           # the tables take the lines' curvature
    sig2 = dict(zip(c2["parameters"], c2["sigma"]))
    assert sig2["CLt[5]"] > 5 * sig2["CLt[3]"]        # 7 deg: only the elevator's few samples
    assert c3["rank"] == len(c3["parameters"]) - 3


def test_a_python_fit_with_an_unreached_value_says_it_in_the_json(tmp_path):
    """A synthetic deck (tests/test_tables.py's record): the JSON lists the
    one value no sample reaches, as the model's unreached_cells does."""
    import mlid
    from test_tables import NAMES, START, table_deck, table_model, table_record
    d, deck = table_deck(tmp_path, free=NAMES, estimate="&estimate rank_min = 1 /\n")
    outs = []
    for cmd in ([str(BIN / "mlid"), "run"], [str(BIN / "mlid-batch")]):
        p = subprocess.run(cmd + [str(deck), "--json", str(tmp_path / "o.json")], cwd=tmp_path,
                           capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        outs.append((tmp_path / "o.json").read_bytes())
    assert outs[0] == outs[1]
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES)
    res = mlid.fit(m, table_record(), rank_min=1)
    assert json.loads(outs[0])[0]["unreached_cells"] == m.unreached_cells(res) == [
        "CLt[6] (alpha = 0.5; weighted where 0.4 < alpha) is reached by no sample: "
        "not identifiable"]


def test_the_figure_draws_a_fits_tables_with_the_band_of_its_covariance(tmp_path):
    """FittedTables: the fit's values and Cramer-Rao sigma at the
    breakpoints, NaN for the value no sample reaches; the figure draws."""
    import mlid
    from mlid.report.table_fit_plots import FittedTables, table_fit_figure
    from test_tables import NAMES, START, table_model, table_record
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES)
    res = mlid.fit(m, table_record(), rank_min=1)
    ft = FittedTables(res)
    assert ft.names == NAMES and list(ft.reached) == [True] * 5 + [False]
    np.testing.assert_allclose(np.asarray(ft.values)[:5], res.estimate[:5], rtol=1e-12)
    np.testing.assert_allclose(np.asarray(ft.sigma)[:5], res.sigma[:5], rtol=1e-12)
    value, sd = ft.curve("CLt", [[0.2], [0.25], [0.45]])
    assert value[0] == pytest.approx(res.estimate[2]) and sd[0] == pytest.approx(res.sigma[2])
    # halfway: the mean, its sigma from the covariance (not the mean of the sigmas)
    c = np.asarray(res.covariance)[2:4, 2:4]
    assert sd[1] == pytest.approx(0.5 * np.sqrt(c.sum()), rel=1e-10)
    assert np.isnan(value[2]) and np.isnan(sd[2])        # weighted on the unreached value
    table_fit_figure(res, tmp_path / "t.png")
    assert (tmp_path / "t.png").stat().st_size > 10000


def test_a_deck_fit_with_tables_has_a_tables_section(tmp_path):
    """The HTML report of a deck whose model has tables: the tables section
    with its figure, each value and the one no sample reaches flagged."""
    from mlid.cli.deck import iter_deck
    from mlid.report.html_report import write_report
    from test_tables import NAMES, table_deck
    _, deck = table_deck(tmp_path, free=NAMES, estimate="&estimate rank_min = 1 /\n")
    page = write_report(tmp_path / "rep", deck, iter_deck(deck)).read_text()
    assert 'id="case-1-tables"' in page and 'id="case-1-table-figure"' in page
    assert "not identifiable, reached by nothing (1): CLt[6]" in page
    assert page.count("reached by nothing: not identifiable") == 1
    assert "alpha = 0.5; weighted where 0.4 &lt; alpha" in page


def test_a_two_step_fit_page_has_the_consistency_test_and_the_exports(tmp_path):
    """write_tables_report of a two-step fit (tests/table_campaign.py, a
    manoeuvre with a wrong vane bias): the figure, the values, the test
    naming the manoeuvre, and where the tables were exported; the same with
    a global fit and those local estimates on top."""
    import mlid
    import table_campaign as tc
    from mlid.report.html_report import write_tables_report
    conds = tc.grid(5, [0.3, 0.5, 0.7])
    res = tc.campaign(conds, 0, faults={7: "bias"})
    fit = mlid.fit_tables(res, tc.tables(), conds)
    assert fit.disagree and fit.disagree[0] == "manoeuvre 8"
    (tmp_path / "tables.json").write_text("{}")
    page = write_tables_report(tmp_path / "t.html", fit,
                               exports={"table set (JSON)": tmp_path / "tables.json",
                                        "JSBSim aerodynamics": tmp_path / "none.xml"}).read_text()
    assert 'id="case-1-table-figure"' in page and "data:image/png;base64," in page
    assert 'id="case-1-consistency"' in page and "disagrees" in page
    assert str((tmp_path / "tables.json").resolve()) in page and "2 bytes" in page
    assert "not written" in page                  # an export that is not there says so
    assert "local estimates with the two-step tables" in page
    # the global fit of the same records and tables, as a fit's result: the two-step fit
    # of its tables (alpha_trim, the conditions' alpha) drawn on its band and tested,
    # headed as a test against the two-step tables
    recs = [tc.record(c, k, "bias" if k == 7 else None) for k, c in enumerate(conds)]
    glob = mlid.fit_global(tc.global_model(), recs, conds, variables=tc.VARIABLES)
    fit = mlid.fit_tables(res, tc.global_tables(), conds, variables=tc.VARIABLES)
    with pytest.raises(mlid.InputError, match="local must be a TableFit"):
        write_tables_report(tmp_path / "g.html", glob.result, local=res[0])
    page = html.unescape(write_tables_report(tmp_path / "g.html", glob.result).read_text())
    assert "Consistency" not in page and "the ±2σ band of the fit's covariance" in page
    page = html.unescape(write_tables_report(tmp_path / "g.html", glob.result,
                                             local=fit).read_text())
    assert 'id="case-1-consistency"' in page and 'id="case-1-table-figure"' in page
    assert "data:image/png;base64," in page and "disagrees" in page
    assert "the local estimates ±2σ (of the two-step fit)" in page
    assert "local estimates with the two-step tables (mlid.fit_tables" in page
    # a global fit given the local fits: its own test, against the global tables
    page = write_tables_report(tmp_path / "g.html", mlid.fit_global(
        tc.global_model(), recs, conds, variables=tc.VARIABLES, local=res)).read_text()
    assert "local estimates with the global tables" in page and "disagrees" in page
    assert "two-step" not in page


def test_local_estimates_of_other_tables_are_refused(tmp_path):
    """A two-step fit whose tables are not the fit's (other names, other
    breakpoints, other variables) is refused with one line naming what differs, not drawn
    or tested beside the fit's tables."""
    import mlid
    import table_campaign as tc
    from mlid.report.html_report import write_tables_report
    from test_tables import NAMES, START, table_model, table_record
    conds = tc.grid(4, [0.3, 0.7])
    res = tc.campaign(conds, 0)
    fit = mlid.fit_tables(res, tc.tables(), conds)
    one = mlid.fit(table_model(values=START, x0=[0.09, 0.0], free=NAMES[:5]), table_record())
    with pytest.raises(mlid.InputError) as err:
        write_tables_report(tmp_path / "g.html", one, local=fit)
    assert str(err.value) == ("local: its tables (M_alpha, M_q, Z_alpha, Z_de, M_de) are not "
                              "the fit's (CLt)")
    other = mlid.fit_tables(res, tc.tables(extra_q_breakpoint=0.2), conds)
    with pytest.raises(mlid.InputError) as err:
        write_tables_report(tmp_path / "g.html", fit, local=other)
    assert str(err.value) == ("local: its table M_q has breakpoints 0 0.09 0.18 0.2, the "
                              "fit's 0 0.09 0.18")
    glob = mlid.fit_global(tc.global_model(), [tc.record(c, k) for k, c in enumerate(conds)],
                           conds, variables=tc.VARIABLES)
    with pytest.raises(mlid.InputError) as err:
        write_tables_report(tmp_path / "g.html", glob.result, local=fit)
    assert str(err.value) == ("local: its table M_alpha is over alpha, Mach, the fit's over "
                              "alpha_trim, Mach")
    assert not (tmp_path / "g.html").exists()
