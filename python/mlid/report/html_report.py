"""One self-contained HTML page per deck: every case's estimates, noise,
convergence, whiteness and figures, readable offline (figures inlined as
base64 PNG, CSS inline, no external link), written whole or not at all.

The page is a jinja2 template (``templates/report.html.j2``, autoescaped),
so that a test organisation can put its own header and its own order of
the sections: ``write_report(..., template=FILE)`` or
``mlid run DECK --report DIR --report-template FILE``.  A template may
``{% extends "mlid/report.html.j2" %}`` and replace a block (``title``,
``style``, ``header``, ``toc``, ``case``, ``footer``), or be a page of its
own that imports the parts, ``{% import "mlid/macros.html.j2" as m %}``
(``m.toc(cases)``, ``m.case_head(case)``, ``m.sections(case.rows)``,
``m.section(s)``, ``m.block(b)``, ``m.table(t)``, ``m.figure(f)``).  Files
it includes or imports without the ``mlid/`` prefix are looked up beside it.
A name the template uses that the page has not is an error naming the
template's line (no silent blank).

The template's variables
------------------------
deck : str
    The deck's path as given.
deck_name : str
    Its file name.
version : str
    mlid's version.
css : str
    The built-in style sheet (the ``style`` block).
cases : list of case
    One per case of the deck, in order.

A case has ``index`` (from 1), ``title``, ``job``, ``status`` (converged,
not converged, failed, done ...), ``status_class`` (ok, warn or fail),
``message`` (its error or warning, '' if none), ``blocks`` (what a case
that is not a fit shows: the simulated record, a design's or Monte Carlo
run's lines), ``sections`` (its sections in the built-in order),
``section`` (the same by key, e.g. ``case.section.figures``; test with
``'modes' in case.section``) and ``rows`` (the sections in rows, those of
a row side by side).

A section has ``key``, ``id`` (case-K-key), ``heading``, ``blocks`` and
``folded`` (shown closed, the printed report).  The keys of a fit, in the
built-in order (``FIT_SECTIONS``): estimates, noise, convergence,
history (the cost at each iteration, no heading), whiteness, figures, tables (a model with
tables: each against its variables with the band from the fit's covariance, the values with
σ and where each acts, those no sample reaches), validation (a validate case), modes (a
linear model), printed; of a failed fit: last.  A fit of tables alone (a two-step
``mlid.fit_tables`` or a global one, with its consistency test and the files it was exported
to) is a page of its own: ``write_tables_report``.

A block has ``kind``: 'table' (``header``, ``rows`` of cells, ``cls``; a
cell is text or has ``text`` and ``cls``, a flag or a status), 'figure'
(``id``, ``src`` the data: URI, ``width`` and ``height`` in px,
``caption``; or ``error`` when it could not be drawn and ``src`` is ''),
'text', 'note' or 'pre' (``text``).

A figure or section is added to every report in one place: ``FIT_SECTIONS``.
"""

import base64
import functools
import io
import math
import struct
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._version import installed_version
from ..errors import InputError
from ..estimate.table import FLAG_TEXT, HEADINGS, results_table
from ..estimate.table_fit import GlobalTableFit, TableFit
from ..files import atomic_write_text
from . import plots
from . import table_fit_plots

#: Relative Cramér-Rao σ above which an estimate is flagged (when the result
#: carries no flags of its own).
FLAG_RELATIVE_SIGMA = 0.20
#: |correlation| above which an estimate is flagged (the report's 0.9).
FLAG_CORRELATION = 0.9
#: Resolution of the page's figures: a CSS pixel per dot, so a figure is
#: shown at its own size (and drawn in half the time of plots.DPI).
DPI = 96
#: The built-in templates; the page is TEMPLATE, its parts MACROS.
TEMPLATES = Path(__file__).with_name("templates")
TEMPLATE, MACROS = "mlid/report.html.j2", "mlid/macros.html.j2"

CSS = """
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;font-size:14px;line-height:1.45;
 color:#1d1d1f;max-width:1180px;margin:0 auto;padding:18px 28px 60px;background:#fff}
h1{font-size:23px;margin:8px 0 4px}h2{font-size:19px;margin:34px 0 6px;padding-top:12px;
 border-top:2px solid #1f5fa8}h3{font-size:15px;margin:20px 0 6px;color:#1f5fa8}
.meta{color:#555;margin:0 0 12px}
table{border-collapse:collapse;margin:6px 0 10px;font-size:13px}
th,td{padding:3px 10px;border-bottom:1px solid #e2e2e2;text-align:right;white-space:nowrap}
th{background:#f2f5f9;font-weight:600;border-bottom:1px solid #bcc7d6}
td:first-child,th:first-child{text-align:left}
tr:hover td{background:#fafbfd}
.status{display:inline-block;padding:2px 9px;border-radius:10px;font-size:12.5px;font-weight:600}
.ok{background:#e3f3e6;color:#1d6b31}.warn{background:#fdf1d8;color:#8a5a00}
.fail{background:#fbe3e1;color:#9b241b}
.error{border-left:4px solid #b2332a;background:#fdf3f2;padding:8px 12px;margin:8px 0;
 font-family:"DejaVu Sans Mono",monospace;font-size:12.5px;white-space:pre-wrap}
.flag{color:#9b241b;font-weight:600}
figure{margin:10px 0 18px}figure img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{color:#555;font-size:12.5px;margin-top:3px}
pre{background:#f7f7f7;padding:8px 10px;font-size:12px;overflow-x:auto}
details summary{cursor:pointer;color:#1f5fa8;margin:8px 0}
.toc td,.toc th{text-align:left}
.estimates td:nth-child(2),.estimates th:nth-child(2),.estimates td:last-child,
.estimates th:last-child{text-align:left}.grid{display:flex;flex-wrap:wrap;gap:28px;align-items:flex-start}
.note{color:#666;font-size:12.5px}
"""


# -- what a template is given ---------------------------------------------------

@dataclass
class Cell:
    """A table cell shown as a span of class cls (a flag, a status)."""
    text: str
    cls: str


@dataclass
class Table:
    """A table: header (None for none), rows of cells, its class.  In a
    template ``{{ t }}`` is the built-in markup (``m.table``)."""
    header: list
    rows: list
    cls: str = ""
    kind: str = "table"

    def __html__(self):
        return _environment(None).get_template(MACROS).module.table(self)

    def __str__(self):
        return str(self.__html__())


@dataclass
class Text:
    """A paragraph ('text'), a note ('note') or preformatted lines ('pre')."""
    text: str
    kind: str = "text"


@dataclass
class Figure:
    """A drawn figure as a data: URI, or why it could not be drawn."""
    id: str
    caption: str
    src: str = ""
    width: int = 0
    height: int = 0
    error: str = ""
    kind: str = "figure"


@dataclass
class Section:
    key: str
    id: str
    heading: str
    blocks: list
    column: bool = False
    folded: bool = False


@dataclass
class Case:
    index: object
    title: str
    job: str
    status: str
    status_class: str
    message: str
    blocks: list = field(default_factory=list)
    sections: list = field(default_factory=list)

    @property
    def section(self):
        return {s.key: s for s in self.sections}

    @property
    def rows(self):
        """The sections in rows: consecutive column sections share one."""
        rows = []
        for s in self.sections:
            if s.column and rows and rows[-1][-1].column:
                rows[-1].append(s)
            else:
                rows.append([s])
        return rows


def _num(v, digits=5):
    if v is None:
        return ""
    v = float(v)
    if not math.isfinite(v):
        return str(v)
    return f"{v:.{digits}g}"


def _png_size(data):
    """(width, height) in px from a PNG's header."""
    return struct.unpack(">II", data[16:24])


def _png(fig):
    """fig as PNG bytes at DPI.  Its layout is made once, at DPI, and then
    fixed (no layout engine): with one, savefig draws the whole figure once
    unseen before the drawing it writes (the same pixels, a fifth less time)."""
    fig.set_dpi(DPI)
    engine = fig.get_layout_engine()
    if engine is not None:
        engine.execute(fig)
        fig.set_layout_engine(None)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    return buf.getvalue()


def figure(key, draw, caption):
    """A section item: the figure draw(result) inlined as a PNG at DPI,
    captioned caption (text, or a function of the result); a figure that
    fails is one line saying why, the page goes on."""
    def item(result):
        text = caption(result) if callable(caption) else caption
        block = Figure(key, text)
        try:
            fig = draw(result)
            try:
                data = _png(fig)
            finally:
                plots.close(fig)
        except Exception as exc:          # one figure failing does not lose the page
            block.error = f"{type(exc).__name__}: {exc}"
            return block
        block.width, block.height = _png_size(data)
        block.src = "data:image/png;base64," + base64.b64encode(data).decode("ascii")
        return block
    return item


# -- tables of a fit -------------------------------------------------------------

def _flags(result, k, rel):
    """The report's own flags of estimate k: a large relative σ, a large
    correlation with another estimate."""
    out = []
    if rel is not None and math.isfinite(rel) and rel > FLAG_RELATIVE_SIGMA:
        out.append(f"σ > {FLAG_RELATIVE_SIGMA:.0%}")
    c = np.array(result.correlation, dtype=float)
    if c.shape[0] > 1:
        others = np.abs(np.delete(c[k], k))
        if others.max() > FLAG_CORRELATION:
            out.append(f"|ρ| {others.max():.2f}")
    return out


def estimates_table(result):
    """The results table of ``mlid.estimate.table.results_table``: name, unit,
    estimate, Cramér-Rao σ, σ corrected for coloured residuals, relative σ
    and flag, with the start value after the unit and the report's own flags
    (relative σ above FLAG_RELATIVE_SIGMA, |correlation| above
    FLAG_CORRELATION) beside the table's.

    Returns
    -------
    Table

    Raises
    ------
    InputError
        If the result's param_units do not fit its parameters.
    """
    header = [*HEADINGS[:2], "Start", *HEADINGS[2:]]
    rows = []
    for k, r in enumerate(results_table(result).rows):
        rel = r["relative_sigma_percent"] / 100
        flags = ([FLAG_TEXT] if r["flag"] else []) + _flags(result, k, rel)
        rows.append([r["name"], r["unit"], _num(result.start[k]), _num(r["estimate"]),
                     _num(r["sigma_cr"], 3), _num(r["sigma_corrected"], 3),
                     f"{100 * rel:.1f}" if math.isfinite(rel) else "–",
                     Cell(", ".join(flags), "flag") if flags else ""])
    return Table(header, rows, "estimates")


def _units_note(result):
    units = getattr(result, "param_units", None) or []
    return None if any(units) else Text("units of the parameters: not declared to the fit",
                                        "note")


def _identifiability(result):
    try:
        ident = result.identifiability()
    except Exception:
        return None
    text = "\n".join(ident) if isinstance(ident, (list, tuple)) else str(ident)
    return Text(text, "pre") if text.strip() else None


def noise_table(result):
    """Per output: σ = √ of the diagonal of R̂ (B̂ for filter error) in the
    declared unit, and the diagonal itself in the core's unit.

    Returns
    -------
    Table
    """
    recs = plots._Records.of_result(result)
    sym = plots.noise_symbol(result)
    rows = []
    for i, name in enumerate(result.data.output_names):
        r = float(result.rhat[i, i])
        unit, scale, _ = plots._display(recs.first, "y", i)
        core = recs.first.output_units[i] if recs.first.output_units else ""
        rows.append([name, _num(math.sqrt(max(r, 0.0)) / abs(scale), 4), unit, _num(r, 4),
                     plots.unit_squared(core)])
    return Table(["output", f"σ = √{sym}ᵢᵢ", "unit", f"{sym}ᵢᵢ", "unit"], rows)


def _det(result):
    return Text(f"det {plots.noise_symbol(result)} = {_num(result.det_r)}")


def noise_heading(result):
    """What the noise table shows: the measurement noise (output error) or
    the innovations (filter error)."""
    return "Innovations (mean covariance B̂)" if plots.noise_symbol(result) == "B̂" \
        else "Measurement noise (R̂)"


def convergence_table(result):
    """How the iteration ended, as a two-column table."""
    state = "converged" if result.converged else "not converged"
    rows = [["status", state], ["stopped because", result.reason],
            ["iterations", result.iterations], ["final cost", _num(result.cost, 8)],
            ["rank", result.rank], ["fit time [s]", _num(result.wall_time, 3)]]
    return Table(None, rows)


def cost_history(result):
    """The cost at each iteration, one line that wraps."""
    return Text("cost history: " + " → ".join(_num(c, 7) for c in result.cost_history),
                "note")


def whiteness_table(result):
    """Per output: Ljung-Box Q over 20 lags, its 5% critical value, the
    verdict and the share of lags outside ±1.96/√N."""
    rows = []
    for name, w in zip(result.data.output_names, result.whiteness()):
        rows.append([name, _num(w["Q"], 4), _num(w["critical"], 4),
                     Cell("white", "status ok") if w["white"] else
                     Cell("coloured", "status warn"), f"{100 * w['outside']:.0f}"])
    return Table(["output", "Ljung-Box Q (20 lags)", "5% critical", "verdict",
                  "lags outside ±1.96/√N [%]"], rows)


def _held_out(v):
    held = ", ".join(str(k) for k in v.holdout)
    return Text(f"held-out file{'s' * (len(v.holdout) > 1)} {held}, predicted by the "
                "identified model (refitted there: only the initial state and output "
                "biases it fitted)")


def validation_table(v):
    """Per output of the held-out manoeuvres: Theil's U, the rms prediction
    error in the declared unit and its ratio to the identification's σ."""
    recs = plots._Records.of_result(v.prediction)
    rows = []
    for i, name in enumerate(v.output_names):
        unit, scale, _ = plots._display(recs.first, "y", i)
        rows.append([name, _num(v.theil[i], 3), _num(v.rms[i] / abs(scale), 4), unit,
                     _num(v.rms_over_sigma[i], 3)])
    return Table(["output", "Theil U", "rms error", "unit", "rms / σ"], rows)


def modes_table(model):
    """Eigenvalues of the identified model with ωn, fn, ζ or time constant."""
    rows = []
    for m in plots.modes(model):
        z = m["eigenvalue"]
        lam = f"{z.real:.4g} ± {abs(z.imag):.4g}j" if z.imag else f"{z.real:.4g}"
        if m["time_constant"] is not None:
            rows.append([lam, "", "", "", _num(m["time_constant"], 4)])
        else:
            rows.append([lam, _num(m["omega_n"], 4), _num(m["f_n"], 4), _num(m["zeta"], 3),
                         ""])
    return Table(["eigenvalue [rad/s]", "ωn [rad/s]", "fn [Hz]", "ζ [-]",
                  "time constant [s]"], rows)


# -- tables over the flight condition ----------------------------------------------

def has_tables(result):
    """Whether a fit's model has tables (and the fit estimates)."""
    return bool(getattr(getattr(result, "model", None), "table_names", None)) \
        and not getattr(result, "failed", False)


def table_values_table(fit):
    """Each table value: where it acts, the estimate and its σ (the
    fit's Cramér-Rao σ, or the two-step fit's), or that nothing reaches it.

    Parameters
    ----------
    fit : TableFit, FitResult with tables, or a global fit's result

    Returns
    -------
    Table
    """
    fit = table_fit_plots.tables_of(fit)
    fixed = set(getattr(fit, "fixed", ()))
    rows = []
    for name, cell, v, sd, r in zip(fit.names, fit.cells, fit.values, fit.sigma, fit.reached):
        where = cell[len(name):].strip().strip("()") if cell.startswith(name) else cell
        rows.append([name, where, _num(v) if r else "–",
                     "fixed" if name in fixed else _num(sd, 3) if r else "–",
                     "" if r else Cell("reached by nothing: not identifiable", "flag")])
    return Table(["value", "where it acts", "estimate", "σ", ""], rows, "estimates")


def _unreached_note(fit):
    fit = table_fit_plots.tables_of(fit)
    gone = [n for n, r in zip(fit.names, fit.reached) if not r]
    if not gone:
        return Text("every table value is reached", "note")
    return Text(f"not identifiable, reached by nothing ({len(gone)}): {', '.join(gone)}",
                "note")


def consistency_table(fit):
    """A two-step fit's chi-square test of each manoeuvre against the
    tables, the worst named first in its caption; None for a fit with none.

    Returns
    -------
    list of blocks, or None
    """
    if not hasattr(fit, "chi2") or not hasattr(fit, "disagree"):
        return None
    rows = []
    for lab, c, d, lim, p in zip(fit.labels, fit.chi2, fit.dof, fit.limit, fit.p_value):
        verdict = Cell("disagrees", "status fail") if lab in fit.disagree else (
            "alone decides its values" if d == 0 else Cell("agrees", "status ok"))
        rows.append([lab, _num(c, 4), int(d), _num(lim, 4), _num(p, 3), verdict])
    total = (f"total: χ² = {_num(fit.chi2_total, 4)} on {fit.dof_total} degrees of freedom "
             f"(limit {_num(fit.limit_total, 4)}, p = {_num(fit.p_total, 3)}); level "
             f"{fit.level:g}; disagree: {', '.join(fit.disagree) or 'none'}")
    return [Table(["manoeuvre", "χ²", "dof", f"limit ({fit.level:g})", "p-value", ""], rows),
            Text(total, "note")]


def exports_table(exports):
    """Where the tables were exported: what, the file, its size; None when
    none were.

    Parameters
    ----------
    exports : dict
        {what: path}, e.g. {'JSBSim aerodynamics': 'aero.xml'}.
    """
    if not exports:
        return None
    rows = []
    for what, path in dict(exports).items():
        path = Path(path)
        size = f"{path.stat().st_size} bytes" if path.is_file() else \
            Cell("not written", "flag")
        rows.append([str(what), str(path.resolve()), size])
    return Table(["export", "file", "size"], rows)


def _drawn_local(fit, local=None):
    """The TableFit whose local estimates the figure draws (as
    table_fit_plots does: a TableFit's own, else local's), or None when it
    has none."""
    loc = fit if isinstance(fit, TableFit) else local
    return loc if loc is not None and len(loc.entries) else None


def _tables_caption(fit, local=None):
    loc = _drawn_local(fit, local)
    route = "global fit" if isinstance(fit, GlobalTableFit) else \
        "two-step" if isinstance(fit, TableFit) else "the fit's covariance"
    what = ("the local estimates ±2σ" + ("" if loc is fit else " (of the two-step fit)") +
            f", the fitted table and its ±2σ band ({route})") if loc is not None else \
        ("the fitted values at the breakpoints and the ±2σ band of the fit's covariance")
    return f"each table against its first variable: {what}; a breakpoint nothing reaches dashed"


def _bps(table):
    return " × ".join(" ".join(f"{v:g}" for v in b) for b in table.breakpoints)


def _same_tables(fit, local):
    """Refuse local (a TableFit) whose tables are not the fit's: the same
    names, variables and breakpoints (the figure finds each local estimate's
    place by the variables' names: fit_tables(..., variables=) names a
    global model's alpha_trim for the conditions' alpha)."""
    mine = fit.tables if isinstance(getattr(fit, "tables", None), dict) else \
        table_fit_plots.FittedTables(fit).tables
    theirs = local.tables
    if set(mine) != set(theirs):
        raise InputError(f"local: its tables ({', '.join(theirs)}) are not the fit's "
                         f"({', '.join(mine)})")
    for q, tab in mine.items():
        other = theirs[q]
        if tuple(other.variables) != tuple(tab.variables):
            raise InputError(f"local: its table {q} is over {', '.join(other.variables)}, the "
                             f"fit's over {', '.join(tab.variables)}")
        if len(other.breakpoints) != len(tab.breakpoints) or not all(
                a.shape == b.shape and np.array_equal(a, b)
                for a, b in zip(other.breakpoints, tab.breakpoints)):
            raise InputError(f"local: its table {q} has breakpoints {_bps(other)}, the fit's "
                             f"{_bps(tab)}")


def _consistency(fit, local):
    """The consistency test to show and its heading: a two-step fit's own,
    a global fit's of its local fits, or local's against its own (two-step)
    tables; (None, None) when there is none."""
    own = isinstance(fit, TableFit) and not (isinstance(fit, GlobalTableFit) and
                                             fit.local is None)
    if own:
        where = "the global tables" if isinstance(fit, GlobalTableFit) else \
            "the two-step tables"
        return fit, f"Consistency of each manoeuvre's local estimates with {where}"
    if local is not None:
        return local, ("Consistency of each manoeuvre's local estimates with the two-step "
                       "tables (mlid.fit_tables: the same breakpoints, not the values above)")
    return None, None


def table_fit_sections(fit, local=None, exports=None, case_id="tables"):
    """The sections of a fit of tables: the figure (the local estimates of
    local, a TableFit, on top of a global fit), the values, the
    consistency test and the exports.  The test shown is a two-step
    fit's (its local estimates against its tables), a global fit's of the
    local fits given to mlid.fit_global (against the global tables), or
    else local's (its local estimates against its own two-step tables),
    each headed as what it is.

    Parameters
    ----------
    fit : TableFit, FitResult with tables, or a global fit's result
    local : TableFit, optional
    exports : dict, optional
        {what: path} of the files the tables were exported to.
    case_id : str
        The sections' id prefix.

    Returns
    -------
    list of Section

    Raises
    ------
    InputError
        local is no TableFit, or its tables are not the fit's (names,
        variables or breakpoints).
    """
    if local is not None:
        if not isinstance(local, TableFit):
            raise InputError(f"local must be a TableFit (mlid.fit_tables), got "
                             f"{type(local).__name__}")
        _same_tables(fit, local)
    figure_item = figure("table-figure", lambda f: table_fit_plots.table_fit_figure(f, local=local),
                         lambda f: _tables_caption(f, local))
    out = [Section("tables", f"{case_id}-tables", "Tables",
                   [b for b in (figure_item(fit), table_values_table(fit), _unreached_note(fit))
                    if b is not None])]
    tested, heading = _consistency(fit, local)
    test = consistency_table(tested) if tested is not None else None
    if test:
        out.append(Section("consistency", f"{case_id}-consistency", heading, test))
    table = exports_table(exports)
    if table is not None:
        out.append(Section("exports", f"{case_id}-exports", "Exported", [table]))
    for sec in out:
        for b in sec.blocks:
            if isinstance(b, Figure):
                b.id = f"{case_id}-{b.id}"
    return out


# -- the sections of a fit, in one place ----------------------------------------

@dataclass(frozen=True)
class Part:
    """A section of a fit's report: its key, heading (text or a function
    of the result), items (functions of the result giving a block, a list
    of blocks, or None for nothing), when it is shown (a function of the
    result; always when None), whether it stands beside its neighbour
    (column) and whether it is shown closed (folded)."""
    key: str
    heading: object             # None: no heading of its own
    items: tuple
    when: object = None
    column: bool = False
    folded: bool = False


def _validated(result):
    return getattr(result, "validation", None) is not None


def _only(when, item):
    """A section item shown only when when(result)."""
    return lambda result: item(result) if when(result) else None


#: The sections of a fit, in order; a figure is one ``figure(key, draw,
#: caption)`` line in a section's items.
FIT_SECTIONS = (
    Part("estimates", "Estimates", (estimates_table, _units_note, _identifiability)),
    Part("noise", noise_heading, (noise_table, _det), column=True),
    Part("convergence", "Convergence", (convergence_table,), column=True),
    Part("history", None, (cost_history,)),
    Part("whiteness", "Whiteness of the residuals", (whiteness_table,)),
    Part("figures", "Figures", (
        figure("fit", plots.fit_overview,
               lambda r: f"{plots.outputs_title(r)} with the inputs; residuals with ±2σ "
                         f"bands, σ from {plots.noise_symbol(r)}"),
        figure("autocorrelation", plots.autocorrelation,
               "residual autocorrelation against lag, ±1.96/√N band"),
        figure("spectra", plots.spectra,
               "residual power spectra, white-noise level of the same variance dashed"),
        _only(plots.time_domain, figure(
            "measured-vs-model", plots.measured_vs_model,
            "each output measured against the model, the 1:1 line; R² and fit % in each title")),
        _only(plots.inputs_move, figure(
            "residual-input", plots.residual_input,
            "cross-correlation of each output's residual with each input against lag, "
            "±1.96/√N (95%) band: a term the model misses shows outside it")),
        figure("correlation", plots.correlation, "correlation matrix of the estimates"))),
    Part("tables", "Tables", (
        figure("table-figure", table_fit_plots.table_fit_figure, _tables_caption),
        table_values_table, _unreached_note), when=has_tables),
    Part("validation", "Validation on held-out manoeuvres", (
        lambda r: _held_out(r.validation), lambda r: validation_table(r.validation),
        figure("validation", lambda r: plots.validation(r.validation),
               "held-out manoeuvres: measured outputs and the identified model's "
               "prediction")), when=_validated),
    Part("modes", "Modes of the identified model", (
        lambda r: modes_table(r.model),
        figure("s-plane", plots.s_plane,
               "eigenvalues of A; the cloud: models drawn from N(θ̂, Cramér-Rao covariance), "
               f"{plots.BAND_SAMPLES} draws, seed {plots.BAND_SEED}"),
        figure("bode", plots.bode,
               lambda r: "frequency response per input-output pair; "
                         f"{plots.band_label('model', 'Cramér-Rao')} band (delta method)")),
        when=plots.linear_model),
    Part("printed", "the printed report", (lambda r: Text(r.report(), "pre"),), folded=True),
)
#: What a failed fit shows: no estimates, statistics or figures; why.
FAILED_SECTIONS = (
    Part("last", "Last values reached (not estimates)", (lambda r: Text(r.report(), "pre"),)),
)


def fit_sections(result, case_id):
    """The sections of a fit (FIT_SECTIONS, or FAILED_SECTIONS when it failed)."""
    out = []
    for part in FAILED_SECTIONS if result.failed else FIT_SECTIONS:
        if part.when is not None and not part.when(result):
            continue
        blocks = []
        for item in part.items:
            got = item(result)
            blocks += [] if got is None else got if isinstance(got, list) else [got]
        for b in blocks:
            if isinstance(b, Figure):
                b.id = f"{case_id}-{b.id}"
        heading = part.heading(result) if callable(part.heading) else part.heading
        out.append(Section(part.key, f"{case_id}-{part.key}", heading, blocks, part.column,
                           part.folded))
    return out


# -- a case ------------------------------------------------------------------------

def _status(out, result, error):
    if error is not None:
        return "fail", "failed"
    if result is not None and not result.converged:   # a result, with a warning
        return "warn", "not converged"
    if out is not None and out.get("status", 0) != 0:
        return "fail", "failed"
    if result is not None and str(result.message).startswith("warning:"):
        return "warn", "converged, with a warning"
    return "ok", "converged" if result is not None else "done"


def case_view(case, out, result, error):
    """What the template is given of one case (see the module's docstring)."""
    k = getattr(case, "index", "")
    cls, text = _status(out, result, error)
    message = str(error) if error is not None else (
        (out or {}).get("message") or (getattr(result, "message", "") if result else ""))
    view = Case(k, str(case.title), str(case.job), text, cls, str(message or ""))
    if out is not None and out.get("job") == "simulate" and "samples" in out:
        view.blocks.append(Text(f"simulated {out['samples']} samples to "
                                f"{Path(out['out']).name}"))
    elif getattr(out, "report", None) and result is None and error is None:
        view.blocks.append(Text(out.report, "pre"))   # a design or Monte Carlo: its lines
    if result is not None:
        view.sections = fit_sections(result, f"case-{k}")
    return view


# -- the page -----------------------------------------------------------------------

@functools.lru_cache(maxsize=8)
def _environment(folder):
    """The templates: mlid's own under 'mlid/', then those in folder (a
    custom template's); autoescaped, an unknown name an error."""
    import jinja2
    loaders = [jinja2.PrefixLoader({"mlid": jinja2.FileSystemLoader(str(TEMPLATES))})]
    if folder is not None:
        loaders.append(jinja2.FileSystemLoader(folder))
    return jinja2.Environment(loader=jinja2.ChoiceLoader(loaders), autoescape=True,
                              undefined=jinja2.StrictUndefined, keep_trailing_newline=True)


def _template_line(exc, fallback):
    """'FILE, line N' of the template frame where exc was raised."""
    frames = [f for f in traceback.extract_tb(exc.__traceback__)
              if not f.filename.endswith(".py") and not f.filename.startswith("<")]
    if getattr(exc, "lineno", None):
        return f"{getattr(exc, 'filename', None) or fallback}, line {exc.lineno}"
    if frames:
        return f"{frames[-1].filename}, line {frames[-1].lineno}"
    return str(fallback)


def load_template(template=None):
    """The page's template: mlid's own (None), or the file template.

    Raises
    ------
    InputError
        One line naming the file (and line) if it cannot be read or parsed.
    """
    if template is None:
        return _environment(None).get_template(TEMPLATE)
    import jinja2
    path = Path(template)
    if not path.is_file():
        raise InputError(f"cannot read report template {template}: "
                         f"{'a folder' if path.is_dir() else 'no such file'}")
    try:
        return _environment(str(path.resolve().parent)).get_template(path.name)
    except UnicodeDecodeError:
        raise InputError(f"report template {template}: not UTF-8 text") from None
    except OSError as exc:
        raise InputError(f"cannot read report template {template}: {exc.strerror}") from None
    except jinja2.TemplateError as exc:
        raise InputError(f"report template {_template_line(exc, template)}: "
                         f"{getattr(exc, 'message', None) or exc}") from None


def report_html(deck_path, cases, template=None):
    """The whole page as text (see write_report)."""
    return _page(deck_path, [case_view(*entry) for entry in cases], template)


def _page(deck_path, entries, template=None):
    """The page of case views entries."""
    from markupsafe import Markup    # the style sheet is mlid's own: not escaped

    page = load_template(template)
    names = {"deck": str(deck_path), "deck_name": Path(deck_path).name,
             "version": installed_version(), "css": Markup(CSS), "cases": entries}
    if template is None:
        return page.render(names)
    try:
        return page.render(names)
    except Exception as exc:              # the organisation's template: its line
        raise InputError(f"report template {_template_line(exc, template)}: "
                         f"{type(exc).__name__}: {exc}") from None


def write_report(folder, deck_path, cases, template=None):
    """Write FOLDER/<deck stem>.html, one self-contained page for a deck.

    Parameters
    ----------
    folder : str or Path
        Where to write (made if missing).
    deck_path : str or Path
        The deck; its stem names the page.
    cases : iterable
        What ``mlid.cli.deck.iter_deck`` yields: (case, out dict or None,
        FitResult or None, error or None).  A failing case shows its error;
        a figure that cannot be drawn shows why; the rest goes on.
    template : str or Path, optional
        A jinja2 template of the page in place of mlid's own (its
        variables: this module's docstring).

    Returns
    -------
    Path
        The page written (whole or not at all).

    Raises
    ------
    InputError
        If the folder cannot be made or written, or the template cannot be
        read, parsed or rendered (one line naming its file and line).
    """
    load_template(template)            # a bad template is said before any figure is drawn
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot make report folder {folder}: {exc.strerror}") from None
    path = folder / f"{Path(deck_path).stem}.html"
    # ASCII with character references: the same bytes whatever the locale
    text = report_html(deck_path, cases, template).encode("ascii", "xmlcharrefreplace") \
        .decode("ascii")
    atomic_write_text(path, text)
    return path


def write_tables_report(path, fit, local=None, exports=None, title="tables",
                        template=None):
    """Write one self-contained page of a fit of tables: each table
    against its variables with the band (and the local estimates ± σ),
    the values, the consistency test and where the tables were exported.

    Parameters
    ----------
    path : str or Path
        The page (written whole or not at all).
    fit : TableFit, FitResult with tables, or a global fit's result
    local : TableFit, optional
        A two-step fit of the same tables (names, variables, breakpoints): its local
        estimates drawn on a fit that has none, and their consistency test
        against its own tables (shown when fit has no test of its own).
    exports : dict, optional
        {what: path} of the exported files (JSBSim, JSON, CSV).
    title : str
        The page's heading.
    template : str or Path, optional
        As write_report's.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        fit has no tables, local is no TableFit or has other tables (names,
        variables or breakpoints) than fit, the page cannot be written.
    """
    load_template(template)
    view = Case(1, str(title), "tables", "done", "ok", "")
    view.sections = table_fit_sections(fit, local, exports, "case-1")
    text = _page(title, [view], template).encode("ascii", "xmlcharrefreplace").decode("ascii")
    path = Path(path)
    atomic_write_text(path, text)
    return path
