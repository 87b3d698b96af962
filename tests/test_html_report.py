"""The HTML report (python/mlid/report/html_report.py, mlid run DECK --report DIR),
parsed back with the standard library: a section per case, the results
table equal to the fit's numbers, the modes equal to numpy's eigenvalues of
the identified F, every figure inlined (readable offline), a failing case
shown by its one-line error with the others intact, the page written whole."""

import base64
import json
import subprocess
import sys
from html.parser import HTMLParser

import numpy as np
import pytest

from conftest import REPO
from mlid.estimate.table import HEADINGS

DECK = REPO / "cases" / "c8_short_period" / "c8.nml"
# A case whose record is missing: it fails, the report goes on.
FAILING = """
&case title = 'C-8: a record that is not there', job = 'estimate' /
&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1.0, g = 1.0, h = 1.0, free = 'f(1,1)' /
&data file = 'missing.dat', time_col = 1, input_cols = 2, output_cols = 3 /
&estimate max_iter = 5 /
"""
VOID = {"meta", "img", "br", "hr", "link", "input", "col", "wbr", "source"}


class Page(HTMLParser):
    """The parts of the page the tests read: sections with their tables
    (rows of cell texts), images and error boxes; every URL; tag balance."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.sections, self.urls, self.stack, self.tags = {}, [], [], []
        self.styles, self.scripts, self.section = [], 0, None
        self.table = self.row = self.cell = self.error = None
        self.in_style = self.in_status = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if tag not in VOID:
            self.stack.append(tag)
        self.urls += [v for k, v in attrs if k in ("src", "href", "action", "data") and v]
        if tag == "section":
            self.section = {"id": a.get("id"), "tables": [], "imgs": [], "errors": [],
                            "title": None, "status": None}
            self.sections[a.get("id")] = self.section
        elif tag == "table" and self.section is not None:
            self.table = {"class": a.get("class", ""), "rows": []}
            self.section["tables"].append(self.table)
        elif tag == "tr" and self.table is not None:
            self.row = []
            self.table["rows"].append(self.row)
        elif tag in ("td", "th") and self.row is not None:
            self.cell = ""
        elif tag == "img" and self.section is not None:
            self.section["imgs"].append(a["src"])
        elif tag == "div" and "error" in a.get("class", "") and self.section is not None:
            self.error = ""
        elif tag == "span" and "status" in a.get("class", "") and self.section is not None \
                and self.table is None:
            self.in_status = True
        elif tag == "style":
            self.in_style = True
            self.styles.append("")
        elif tag == "script":
            self.scripts += 1

    def handle_endtag(self, tag):
        assert self.stack and self.stack[-1] == tag, f"</{tag}> closes <{self.stack[-1:]}>"
        self.stack.pop()
        if tag in ("td", "th") and self.row is not None:
            self.row.append(self.cell.strip())
            self.cell = None
        elif tag == "table":
            self.table = self.row = None
        elif tag == "div" and self.error is not None:
            self.section["errors"].append(self.error)
            self.error = None
        elif tag == "section":
            self.section = None
        elif tag == "style":
            self.in_style = False

    def handle_data(self, data):
        if self.in_style:
            self.styles[-1] += data
        if self.cell is not None:
            self.cell += data
        if self.error is not None:
            self.error += data
        if self.section is not None and self.stack[-1:] == ["h2"]:
            self.section["title"] = (self.section["title"] or "") + data
        if self.in_status:
            self.section["status"] = data
            self.in_status = False


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """mlid run --report on the C-8 deck (simulate, fit) and a failing case."""
    work = tmp_path_factory.mktemp("deck")
    deck = work / "c8.nml"
    deck.write_text(DECK.read_text() + FAILING)
    out = work / "report"
    p = subprocess.run([sys.executable, "-m", "mlid", "run", str(deck), "--report", str(out),
                        "--json", str(work / "c8.json")], capture_output=True, text=True,
                       cwd=work)
    page = Page()
    text = (out / "c8.html").read_text(encoding="ascii")
    page.feed(text)
    page.close()
    return {"proc": p, "dir": out, "text": text, "page": page,
            "json": json.loads((work / "c8.json").read_text())}


def _table(section, cls=None, first=None):
    """The rows of the section's table with class cls, or whose first head
    cell is first."""
    for t in section["tables"]:
        if (cls and cls in t["class"].split()) or (first and t["rows"][0][0] == first):
            return t["rows"]
    raise AssertionError(f"no table {cls or first} in {section['id']}")


def test_the_page_parses_with_a_section_per_case(run):
    page, p = run["page"], run["proc"]
    assert p.returncode == 1, p.stderr              # the failing case fails the run ...
    assert "report:" in p.stdout                    # ... and the report is written all the same
    assert page.stack == [] and page.tags[0] == "html"
    assert list(page.sections) == ["case-1", "case-2", "case-3"]
    titles = [s["title"] for s in page.sections.values()]
    assert titles == [f"Case {k + 1}: {c['title']}" for k, c in enumerate(run["json"])]
    # the table of contents links every section
    assert sorted(u for u in page.urls if u.startswith("#")) == ["#case-1", "#case-2",
                                                                 "#case-3"]
    assert [s["status"] for s in page.sections.values()] == ["done", "converged", "failed"]


def test_results_table_matches_the_fit(run):
    fit = run["json"][1]
    rows = _table(run["page"].sections["case-2"], cls="estimates")
    assert rows[0] == [*HEADINGS[:2], "Start", *HEADINGS[2:]]
    assert rows[0][:6] == ["Parameter", "Unit", "Start", "Estimate", "CR σ", "Corrected σ"]
    body = rows[1:]
    assert [r[0] for r in body] == fit["parameters"]
    got = np.array([[float(r[k]) for k in (2, 3, 4, 5, 6)] for r in body])
    # written to 5 (start, estimate) and 3 (the sigmas) significant digits
    np.testing.assert_allclose(got[:, 0], fit["start"], rtol=5e-5)
    np.testing.assert_allclose(got[:, 1], fit["estimate"], rtol=5e-5)
    np.testing.assert_allclose(got[:, 2], fit["sigma"], rtol=5e-3)
    np.testing.assert_allclose(got[:, 3], fit["sigma_corrected"], rtol=5e-3)
    rel = 100 * np.array(fit["sigma_corrected"]) / np.abs(fit["estimate"])
    np.testing.assert_allclose(got[:, 4], rel, atol=0.05 + 1e-9)


def test_noise_and_convergence_match_the_fit(run):
    fit = run["json"][1]
    section = run["page"].sections["case-2"]
    noise = _table(section, first="output")
    assert noise[0][:3] == ["output", "σ = √R̂ᵢᵢ", "unit"]
    sigma = np.array([float(r[1]) for r in noise[1:]])
    np.testing.assert_allclose(sigma, np.sqrt(np.diag(fit["R"])), rtol=5e-4)
    conv = {r[0]: r[1] for t in section["tables"] for r in t["rows"]
            if t["rows"][0][0] == "status"}
    assert conv["iterations"] == str(fit["iterations"])
    assert float(conv["final cost"]) == pytest.approx(fit["cost"], rel=1e-7)


def test_modes_table_is_numpy_of_the_identified_f(run):
    """The identified F: the deck's, with the five estimates in place."""
    fit = run["json"][1]
    F = np.array([[-0.02, -32.2, 0.0, 33.74], [0.0, 0.0, 1.0, 0.0],
                  [0.003, 0.0, 0, 0], [-0.004, 0.0, 1.0, 0]])
    F[2, 2], F[2, 3], F[3, 3] = fit["estimate"][:3]
    lam = np.linalg.eigvals(F)
    lam = sorted(lam[lam.imag > 0], key=abs)
    rows = _table(run["page"].sections["case-2"], first="eigenvalue [rad/s]")
    assert rows[0][1:4] == ["ωn [rad/s]", "fn [Hz]", "ζ [-]"]
    got = np.array([[float(r[1]), float(r[2]), float(r[3])] for r in rows[1:]])
    want = np.array([[abs(z), abs(z) / (2 * np.pi), -z.real / abs(z)] for z in lam])
    np.testing.assert_allclose(got, want, rtol=5e-3)


def test_every_figure_is_inlined_and_nothing_is_fetched(run):
    page = run["page"]
    fit, simulate, failing = (page.sections[f"case-{k}"] for k in (2, 1, 3))
    # overview, autocorrelation, spectra, measured vs model, residual-input, correlation,
    assert len(fit["imgs"]) == 8                              # s-plane, Bode
    assert simulate["imgs"] == failing["imgs"] == []
    for src in fit["imgs"]:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    assert all(u.startswith(("#", "data:")) for u in page.urls), \
        [u for u in page.urls if not u.startswith(("#", "data:"))]
    assert page.scripts == 0 and "link" not in page.tags
    assert page.styles and not any("url(" in s or "@import" in s for s in page.styles)
    assert "figure not drawn" not in run["text"]


def test_a_failing_case_shows_its_one_line_error(run):
    failing = run["page"].sections["case-3"]
    (error,) = failing["errors"]
    assert "missing.dat" in error and "\n" not in error.strip()
    assert failing["tables"] == []
    assert "missing.dat" in run["proc"].stderr
    # the cases before it are whole
    assert len(run["page"].sections["case-2"]["tables"]) >= 5


def test_the_page_is_written_whole(run, tmp_path):
    assert [p.name for p in run["dir"].iterdir()] == ["c8.html"]      # no temporary left
    assert run["text"].endswith("</html>\n")
    # a run that breaks while the page is made leaves the previous page as it was
    from mlid.report.html_report import write_report
    page = tmp_path / "c8.html"
    page.write_text("previous\n")

    def cases():
        raise RuntimeError("a case broke")
        yield

    with pytest.raises(RuntimeError):
        write_report(tmp_path, tmp_path / "c8.nml", cases())
    assert page.read_text() == "previous\n"
    assert [p.name for p in tmp_path.iterdir()] == ["c8.html"]


def test_a_validate_case_shows_its_prediction(tmp_path):
    """The deck job 'validate': Theil's U, the rms error in the declared unit
    (alpha in deg) and rms/σ of the held-out file, as mlid.validate has them,
    and its figure."""
    import matplotlib
    matplotlib.use("Agg")
    import mlid
    from mlid.report.html_report import write_report
    from test_validate import DECK as VALIDATE, write_manoeuvres
    write_manoeuvres(tmp_path)
    deck = tmp_path / "v.nml"
    deck.write_text(VALIDATE)
    cases = mlid.run_deck(deck)
    v = cases[0][2].validation
    page = Page()
    page.feed(write_report(tmp_path / "out", deck, cases).read_text(encoding="ascii"))
    section = page.sections["case-1"]
    rows = [r for t in section["tables"] if t["rows"][0][:2] == ["output", "Theil U"]
            for r in t["rows"]]
    assert rows[0] == ["output", "Theil U", "rms error", "unit", "rms / σ"]
    # the deck declares alpha in deg and nothing for q
    assert [r[0] for r in rows[1:]] == ["alpha", "q"] and [r[3] for r in rows[1:]] == ["deg", ""]
    got = np.array([[float(r[1]), float(r[2]), float(r[4])] for r in rows[1:]])
    np.testing.assert_allclose(got[:, 0], v.theil, rtol=5e-3)
    np.testing.assert_allclose(got[:, 1], v.rms * [180 / np.pi, 1.0], rtol=5e-4)
    np.testing.assert_allclose(got[:, 2], v.rms_over_sigma, rtol=5e-3)
    assert len(section["imgs"]) == 9        # the fit's eight and the prediction
    # the parameters' units, from the channels' (Z_a in 1/s, a0 in rad; '' where not known)
    est = _table(section, cls="estimates")
    assert [r[1] for r in est[1:]] == list(cases[0][2].param_units)
    assert "1/s" in cases[0][2].param_units
