"""The Jupyter views (_repr_html_) of FitResult, ResultsTable and Diagnosis:
the HTML parsed back (html.parser) gives the object's own numbers and names,
names are escaped, and the plain reprs say what the object is."""

from html.parser import HTMLParser

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
import scenarios
from conftest import C8_FREE, C8_STD, c8_start, c8_truth
from mlid.estimate.table import FLAG_RATIO, FLAG_TEXT, HEADINGS, HTML_DIGITS

# 6 significant digits shown: a relative error of at most 5e-6
RTOL = 0.5 * 10.0 ** (1 - HTML_DIGITS)
# names with HTML's special characters, to be escaped
NAMES = dict(zip(C8_FREE, ["<b>M_q</b>", "M_alpha & co", "Z_\"alpha\"", "M_delta", "Z_delta"]))
OUTPUTS = ["u [ft/s]", "alpha<rad>", "q", "theta & more"]


class _Tables(HTMLParser):
    """Every table (its class, header cells and rows of cell text) and the
    text of every span by its class."""

    def __init__(self, text):
        super().__init__(convert_charrefs=True)
        self.tables, self.spans, self.paragraphs = [], {}, []
        self._cell = self._span = self._par = None
        self.feed(text)
        self.close()

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "table":
            self.tables.append({"class": attrs.get("class"), "head": [], "rows": []})
        elif tag == "tr" and self.tables:
            self._row = []
        elif tag in ("td", "th"):
            self._cell = ""
        elif tag == "span":
            self._span = (attrs.get("class"), "")
        elif tag == "p":
            self._par = ""

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self._row.append((tag, self._cell))
            self._cell = None
        elif tag == "tr":
            kinds = {k for k, _ in self._row}
            cells = [c for _, c in self._row]
            self.tables[-1]["head" if kinds == {"th"} else "rows"].append(cells)
        elif tag == "span":
            self.spans[self._span[0]] = self._span[1]
            self._span = None
        elif tag == "p":
            self.paragraphs.append(self._par)
            self._par = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        if self._span is not None:
            self._span = (self._span[0], self._span[1] + data)
        if self._par is not None:
            self._par += data


def _number(text):
    return float(text) if text else np.nan


def _table(parsed, cls):
    found = [t for t in parsed.tables if t["class"] == cls]
    assert len(found) == 1, [t["class"] for t in parsed.tables]
    return found[0]


@pytest.fixture(scope="module")
def result():
    t = np.arange(301) * 0.02
    u = input_signal("3211", 0.08, 1.0, 0.5, 0.02, 301).reshape(-1, 1)
    sim, _ = mlid.simulate(c8_truth(), t, u, noise_std=C8_STD, seed=5)
    data = mlid.FlightData(t, u, sim.y, ["de"], OUTPUTS, input_units=["rad"],
                           output_units=["m/s", "rad", "rad/s", "rad"])
    return mlid.fit(c8_start().with_free(C8_FREE, names=NAMES), data)


def test_fit_html_holds_the_results_table(result):
    text = result._repr_html_()
    parsed = _Tables(text)
    table = _table(parsed, "mlid-results")
    assert table["head"] == [list(HEADINGS)]
    rows = table["rows"]
    assert [r[0] for r in rows] == list(result.names) == list(NAMES.values())
    assert "<b>M_q" not in text and "& co" not in text          # escaped, read back whole
    got = np.array([[_number(c) for c in r[2:6]] for r in rows])
    want = np.column_stack([result.estimate, result.sigma, result.sigma_corrected,
                            100 * result.sigma_corrected / np.abs(result.estimate)])
    np.testing.assert_allclose(got, want, rtol=RTOL)
    # the units the fit found from the channels' (mlid_param_units)
    assert [r[1] for r in rows] == list(result.param_units) and all(result.param_units)
    flags = result.sigma_corrected > FLAG_RATIO * result.sigma
    assert [r[6] for r in rows] == [FLAG_TEXT if f else "" for f in flags]


def test_fit_html_states_cost_iterations_convergence_and_noise(result):
    parsed = _Tables(result._repr_html_())
    assert float(parsed.spans["cost"]) == pytest.approx(result.cost, rel=RTOL)
    assert int(parsed.spans["iterations"]) == result.iterations
    assert parsed.spans["converged"] == ("yes" if result.converged else "no")
    assert parsed.spans["reason"] == result.reason
    # the first line is the core report's (method, iterations, why it stopped)
    assert parsed.paragraphs[0] == "FitResult: " + result.report().split("\n")[0].strip()
    noise = _table(parsed, "mlid-noise")
    assert noise["head"] == [["output", "R diagonal"]]
    assert [r[0] for r in noise["rows"]] == OUTPUTS
    np.testing.assert_allclose([float(r[1]) for r in noise["rows"]], np.diag(result.rhat),
                               rtol=RTOL)


def test_fit_html_units_flags_and_undefined_relative_sigma(result):
    res = mlid.FitResult(**vars(result))
    res.param_units = ["1/s", "<1/s^2>", "1/s", "rad/s^2", ""]
    ratio = np.array([FLAG_RATIO * 1.5, 1.0, FLAG_RATIO * 0.99, 3 * FLAG_RATIO, 0.5])
    res.sigma_corrected = result.sigma * ratio
    res.estimate = result.estimate.copy()
    res.estimate[4] = 0.0                                       # relative sigma undefined
    rows = _table(_Tables(res._repr_html_()), "mlid-results")["rows"]
    assert [r[1] for r in rows] == res.param_units
    assert [r[6] for r in rows] == [FLAG_TEXT, "", "", FLAG_TEXT, ""]
    assert rows[4][5] == ""
    np.testing.assert_allclose([float(r[4]) for r in rows], res.sigma_corrected, rtol=RTOL)


def test_filter_error_html_says_innovation_covariance():
    # one state with process noise: x' = a x + b u + w, y = x
    truth = mlid.LinearModel([[-1.5]], [[2.0]], [[1.0]], Gamma=[[1.0]], q=[0.04], r=[0.01],
                             free=["f(1,1)", "g(1,1)"])
    t = np.arange(200) * 0.05
    u = input_signal("doublet", 1.0, 1.0, 1.0, 0.05, 200).reshape(-1, 1)
    data, _ = mlid.simulate(truth, t, u, seed=2)
    res = mlid.fit(truth, data, method="filter_error")
    label, rows = res.noise_diagonal()
    assert label == "B diagonal (mean)"
    assert any(ln.startswith(" " + label) for ln in res.report().split("\n"))
    noise = _table(_Tables(res._repr_html_()), "mlid-noise")
    assert noise["head"] == [["output", label]]
    assert float(noise["rows"][0][1]) == pytest.approx(res.rhat[0, 0], rel=RTOL)


def test_plain_reprs(result):
    assert repr(result) == (f"FitResult(cost={result.cost:.6g}, iterations={result.iterations}, "
                            f"converged={result.converged})")
    table = result.table()
    assert repr(table) == f"ResultsTable({len(result.names)} rows)"
    assert table._repr_html_() == table.html_text()


def test_results_table_html_of_several_cases(result):
    both = mlid.estimate.table.ResultsTable.concat(
        [mlid.estimate.table.results_table(result, case=k) for k in ("a<1>", "b")])
    table = _Tables(both.html_text()).tables[0]
    assert table["head"] == [["Case"] + list(HEADINGS)]
    assert [r[0] for r in table["rows"]] == ["a<1>"] * 5 + ["b"] * 5


@pytest.fixture(scope="module")
def diagnosis():
    model, data = scenarios.make("bias", 1)
    outs = ["p", "r", "<beta & co>", "phi"]
    data = mlid.FlightData(data.t, data.u, data.y, data.input_names, outs)
    return mlid.diagnose(model, data, families=("bias",))


def test_diagnosis_html_verdict_and_effects(diagnosis):
    d = diagnosis
    assert d.effects and d.effects[0].name == "bias on <beta & co>"
    text = d._repr_html_()
    assert "<beta" not in text
    parsed = _Tables(text)
    assert parsed.spans["verdict"] == d.verdict == "effects found: bias on <beta & co>"
    assert float(parsed.spans["cost-before"]) == pytest.approx(d.base.cost, rel=RTOL)
    assert float(parsed.spans["cost-after"]) == pytest.approx(d.fit.cost, rel=RTOL)
    effects = _table(parsed, "mlid-effects")
    quantities = [(c, q) for c in d.effects for q in c.quantities]
    assert [r[:3] + r[5:7] for r in effects["rows"]] == [
        [c.family, c.name, q[0], q[3], q[4]] for c, q in quantities]
    np.testing.assert_allclose([[float(x) for x in r[3:5] + r[7:]] for r in effects["rows"]],
                               [[q[1], q[2], c.lr, c.holdout] for c, q in quantities],
                               rtol=RTOL)


def test_diagnosis_html_rounds_match_the_report(diagnosis):
    d = diagnosis
    parsed = _Tables(d._repr_html_())
    rounds = [t for t in parsed.tables if t["class"] == "mlid-candidates"]
    assert len(rounds) == len(d.rounds)
    report = d.report().split("\n")
    for k, (table, rnd) in enumerate(zip(rounds, d.rounds), 1):
        header = next(p for p in parsed.paragraphs if p.startswith(f"round {k}:"))
        assert " " + header in report                         # the same words as the text
        listed = d._listed(rnd)
        assert [r[1] for r in table["rows"]] == [c.name for c in listed]
        for row, c in zip(table["rows"], listed):
            assert row[6].startswith(c.decision)
            for text, value in zip(row[2:6], (c.score, c.signature, c.lr, c.holdout)):
                if value is None:
                    assert text == ""
                else:
                    assert float(text) == pytest.approx(value, rel=RTOL, abs=1e-300)
    resid = _table(parsed, "mlid-residuals")
    assert [r[0] for r in resid["rows"]] == [b["output"] for b in d.before]
    np.testing.assert_allclose(
        [[float(x) for x in r[1:]] for r in resid["rows"]],
        [[b["rms"], a["rms"], b["Q"], a["Q"], b["Q_critical"]]
         for b, a in zip(d.before, d.after)], rtol=RTOL)


def test_diagnosis_plain_repr_and_nothing_missing(diagnosis):
    d = diagnosis
    assert repr(d).startswith(f"Diagnosis(1 effects ['bias on <beta & co>'], {len(d.rounds)} "
                              "rounds")
    model, data = scenarios.make("null", 1)
    quiet = mlid.diagnose(model, data, families=("bias",))
    assert not quiet.effects
    parsed = _Tables(quiet._repr_html_())
    assert parsed.spans["verdict"] == "nothing missing at this significance"
    assert not [t for t in parsed.tables if t["class"] == "mlid-effects"]
    assert " nothing missing at this significance" in quiet.report().split("\n")
