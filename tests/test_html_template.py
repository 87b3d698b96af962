"""The HTML report's template (python/mlid/report/templates): a test
organisation's own template puts its header and its order of the sections
(write_report template=, mlid run --report-template FILE); every value is
escaped; a bad template is one line naming its file and line, said before
any case runs, and no page is written."""

import subprocess
import sys
from types import SimpleNamespace

import pytest

from conftest import REPO
from test_html_report import Page

import mlid
from mlid.errors import InputError
from mlid.report import html_report

DECK = REPO / "cases" / "c8_short_period" / "c8.nml"

# The organisation's page: its own header, the figures before the estimates,
# only three sections, and a line per section listing its blocks' kinds.
ACME = """{% extends "mlid/report.html.j2" %}
{% block header %}<h1 class="acme">ACME flight test: {{ deck_name }}</h1>{% endblock %}
{% block case %}{{ m.case_head(case) }}
{%- for key in ["figures", "estimates", "modes"] if key in case.section %}
{{ m.section(case.section[key]) }}
<p class="kinds">{{ key }}: {{ case.section[key].blocks|map(attribute="kind")|join(",") }}</p>
{%- endfor %}{% endblock %}
"""


def _deck_copy(tmp_path):
    deck = tmp_path / "c8.nml"
    deck.write_text(DECK.read_text())
    return deck


def test_an_organisations_template_puts_its_header_and_order(tmp_path):
    deck = _deck_copy(tmp_path)
    (tmp_path / "acme.html.j2").write_text(ACME)
    cases = mlid.run_deck(deck)
    import matplotlib
    matplotlib.use("Agg")
    page_path = html_report.write_report(tmp_path / "out", deck, cases,
                                         template=tmp_path / "acme.html.j2")
    text = page_path.read_text(encoding="ascii")
    page = Page()
    page.feed(text)
    page.close()
    assert page.stack == []
    assert '<h1 class="acme">ACME flight test: c8.nml</h1>' in text
    assert "mlid report:" not in text                       # the built-in header replaced
    # the sections in the organisation's order, the others left out
    order = [text.index(f'id="case-2-{k}"') for k in ("figures", "estimates", "modes")]
    assert order == sorted(order)
    assert 'id="case-2-whiteness"' not in text and 'id="case-2-noise"' not in text
    assert "figures: figure,figure,figure,figure" in text
    assert "estimates: table" in text and "modes: table,figure,figure" in text
    # what it shows is the built-in's: the estimates, the inlined figures
    fit = page.sections["case-2"]
    assert len(fit["imgs"]) == 6 and all(s.startswith("data:image/png;base64,")
                                         for s in fit["imgs"])
    est = next(t["rows"] for t in fit["tables"] if t["class"] == "estimates")
    assert [r[0] for r in est[1:]] == list(cases[1][2].names)


def _simulated(title):
    """A case that simulated a record (no fit): enough for a page."""
    case = SimpleNamespace(index=1, title=title, job="simulate")
    return [(case, {"job": "simulate", "samples": 3, "out": "a<b>.dat", "status": 0}, None,
             None)]


def test_every_value_is_escaped(tmp_path):
    title = '<script>alert("x")</script> & <b>bold</b>'
    text = html_report.report_html(tmp_path / "d<1>.nml", _simulated(title))
    assert "<script>" not in text and "<b>bold" not in text
    assert "&lt;script&gt;alert(&#34;x&#34;)&lt;/script&gt; &amp; &lt;b&gt;bold&lt;/b&gt;" in text
    assert "a&lt;b&gt;.dat" in text and "d&lt;1&gt;.nml" in text
    # the style sheet is mlid's own, not escaped (a quoted font name stays quoted)
    style = text.split("<style>", 1)[1].split("</style>", 1)[0]
    assert '"DejaVu Sans"' in style and "&#34;" not in style and "&amp;" not in style


@pytest.mark.parametrize("body, where, problem", [
    ("{% block header %}<h1>{{ deck_name }</h1>{% endblock %}", "line 2", "unexpected '}'"),
    ("{% block header %}\n\n{{ case_count }}{% endblock %}", "line 4", "case_count"),
    ("{% block header %}{% include 'missing.j2' %}{% endblock %}", "line 2", "missing.j2"),
])
def test_a_bad_template_is_one_line_naming_file_and_line(tmp_path, body, where, problem):
    tpl = tmp_path / "bad.html.j2"
    tpl.write_text('{% extends "mlid/report.html.j2" %}\n' + body)
    with pytest.raises(InputError) as err:
        html_report.write_report(tmp_path / "out", tmp_path / "d.nml", _simulated("t"),
                                 template=tpl)
    msg = str(err.value)
    assert "\n" not in msg and "bad.html.j2" in msg and where in msg and problem in msg, msg
    assert not (tmp_path / "out" / "d.html").exists()


def test_a_missing_or_binary_template_is_one_line(tmp_path):
    with pytest.raises(InputError, match=r"cannot read report template .*nope\.j2: no such file"):
        html_report.load_template(tmp_path / "nope.j2")
    (tmp_path / "bin.j2").write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(InputError, match=r"report template .*bin\.j2: not UTF-8 text"):
        html_report.load_template(tmp_path / "bin.j2")


def test_the_command_line_checks_the_template_before_any_case(tmp_path):
    deck = _deck_copy(tmp_path)
    (tmp_path / "bad.j2").write_text("{% block header %}{{ deck_name }{% endblock %}")
    mlid_cmd = [sys.executable, "-m", "mlid", "run", str(deck)]
    p = subprocess.run(mlid_cmd + ["--report", str(tmp_path / "out"), "--report-template",
                                   str(tmp_path / "bad.j2")],
                       capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode != 0 and p.stdout == ""                 # no case ran
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.j2, line 1" in lines[0], p.stderr
    assert not (tmp_path / "c8_doublet.dat").exists()
    assert not (tmp_path / "out" / "c8.html").exists()
    p = subprocess.run(mlid_cmd + ["--report-template", str(tmp_path / "bad.j2")],
                       capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode != 0 and "--report-template needs --report" in p.stderr
    # a good one through the command line
    (tmp_path / "acme.j2").write_text(ACME)
    p = subprocess.run(mlid_cmd + ["--report", str(tmp_path / "out"), "--report-template",
                                   str(tmp_path / "acme.j2")],
                       capture_output=True, text=True, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "ACME flight test: c8.nml" in (tmp_path / "out" / "c8.html").read_text()


def test_the_built_in_sections_are_listed_once():
    """FIT_SECTIONS is where a section or figure is added: its keys are
    unique and what the module's docstring lists."""
    keys = [p.key for p in html_report.FIT_SECTIONS]
    assert len(keys) == len(set(keys))
    doc = html_report.__doc__
    for key in keys:
        assert key in doc, key
