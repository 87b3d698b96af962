"""The results table a flight-test report can take: per free parameter its
name, unit, estimate, Cramer-Rao sigma, sigma corrected for coloured
residuals, relative sigma and a flag, exported as CSV, LaTeX, JSON, HTML or
a pandas DataFrame.  Files are written whole or not at all."""

import csv
import html
import io
import json
import math
import re

import numpy as np

from ..checks import pandas_for
from ..errors import InputError
from ..files import atomic_write_text
from .outcome import require_estimates

#: Column keys (CSV header, JSON keys, DataFrame columns) and LaTeX headings.
COLUMNS = ("name", "unit", "estimate", "sigma_cr", "sigma_corrected", "relative_sigma_percent",
           "flag")
LATEX_HEADINGS = ("Parameter", "Unit", "Estimate", r"CR $\sigma$", r"Corrected $\sigma$",
                  r"$\sigma$/$|\hat\theta|$ (\%)", "Flag")
#: The same headings as plain text (HTML, Jupyter).
HEADINGS = ("Parameter", "Unit", "Estimate", "CR σ", "Corrected σ", "σ/|θ̂| (%)", "Flag")
#: Significant digits of a number in the HTML table.
HTML_DIGITS = 6
#: A parameter is flagged when its corrected sigma is more than this times the Cramer-Rao one.
FLAG_RATIO = 2.0
FLAG_TEXT = "coloured"
CASE = "case"
NUMERIC = ("estimate", "sigma_cr", "sigma_corrected", "relative_sigma_percent")


GREEK = ("alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "kappa",
         "lambda", "mu", "nu", "xi", "rho", "sigma", "tau", "phi", "chi", "psi", "omega")


def latex_escape(text):
    """text with LaTeX's special characters escaped, as pandas escapes a
    table's text (Styler.format(escape='latex')); a line break is a blank
    (a table cell is one line)."""
    one_line = " ".join(str(text).splitlines())
    return _latex_tabular({"": [one_line]}, "l", header=False).split("\n")[1][:-3]


def _latex_tabular(columns, align, header=True, verbatim=None):
    r"""A booktabs tabular made by pandas (Styler.to_latex): columns
    {heading: cells}, cells text; text escaped by pandas but the headings
    (LaTeX already) and the cells verbatim marks True (math, \si); no
    index."""
    pd = pandas_for("LaTeX tables")
    frame = pd.DataFrame({k: list(v) for k, v in columns.items()})
    styler = frame.style.hide(axis="index").format(escape="latex")
    if not header:
        styler = styler.hide(axis="columns")
    if verbatim is not None and np.any(verbatim):
        mask = pd.DataFrame(verbatim, columns=frame.columns)
        for k, col in enumerate(frame.columns):     # what is LaTeX already goes as it is
            rows = np.flatnonzero(mask.iloc[:, k].to_numpy())
            if rows.size:
                styler = styler.format(str, subset=(frame.index[rows], [col]))
    try:
        return styler.to_latex(column_format=align, hrules=header)
    except ImportError as e:            # pandas' LaTeX is a jinja2 template
        raise InputError(f"LaTeX tables need jinja2 ({e}): pip install jinja2") from None


def _symbol(part):
    if part in GREEK or part[:1].upper() + part[1:] in ("Gamma", "Delta", "Theta", "Phi", "Psi",
                                                         "Omega"):
        return "\\" + part
    return part if len(part) == 1 or part.isdigit() else rf"\mathrm{{{part}}}"


def _math_name(name):
    """A name of words joined by underscores as math (None for any other)."""
    name = str(name)
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9]*(_[A-Za-z0-9]+)*", name):
        return None
    parts = name.split("_")
    if len(parts) == 1 and name not in GREEK:
        return None
    text = _symbol(parts[-1])
    for part in reversed(parts[:-1]):
        text = f"{_symbol(part)}_{{{text}}}"
    return f"${text}$"


def latex_name(name):
    r"""A parameter name as LaTeX: a name of words joined by underscores as
    math with nested subscripts and Greek letters (Z_alpha: $Z_{\alpha}$,
    C_m_de: $C_{m_{\mathrm{de}}}$); any other name as escaped text."""
    math_text = _math_name(name)
    return latex_escape(name) if math_text is None else math_text


def _si_unit(unit):
    r"""A core unit as siunitx's \si in powers; '' for none or '-', None for
    a unit of other characters."""
    unit = str(unit).strip()
    if unit in ("", "-"):
        return ""
    if not re.fullmatch(r"[A-Za-z0-9.]+(/\(?[A-Za-z0-9.]+\)?)?", unit):
        return None
    top, _, bottom = unit.partition("/")
    factors = []
    for sign, group in ((1, top), (-1, bottom.strip("()"))):
        for f in filter(None, group.split(".")):
            sym, power = re.fullmatch(r"([A-Za-z]*)(\d*)", f).groups()
            if not sym:
                continue          # the 1 of 1/s
            p = sign * int(power or 1)
            factors.append(sym if p == 1 else f"{sym}^{{{p}}}")
    return rf"\si{{{'.'.join(factors)}}}" if factors else ""


def latex_unit(unit):
    r"""A core unit ('rad/s', '1/s2', 'm/(rad.s)', '-') as siunitx's \si in
    powers (\si{rad.s^{-1}}); '' for none or '-'; a unit of other
    characters as escaped text."""
    si = _si_unit(unit)
    return latex_escape(str(unit).strip()) if si is None else si


def results_table(result, case=None):
    """The results table of a fit.

    Parameters
    ----------
    result : FitResult
        A fit (``mlid.fit`` or a deck case); units from ``result.param_units``
        when it has them (one string per free parameter, '' unknown).
    case : int or str, optional
        A case label for every row (a ``case`` column).

    Returns
    -------
    ResultsTable

    Raises
    ------
    InputError
        If param_units does not have one entry per free parameter, or the
        fit failed (no estimates).
    """
    require_estimates(result, "results table")
    names = list(result.names)
    units = getattr(result, "param_units", None)
    if units is None:
        units = [""] * len(names)
    units = ["" if u is None else str(u) for u in units]
    if len(units) != len(names):
        raise InputError(f"param_units has {len(units)} entries for {len(names)} free "
                         "parameters")
    rows = []
    for k, name in enumerate(names):
        est = float(result.estimate[k])
        cr = float(result.sigma[k])
        col = float(result.sigma_corrected[k])
        rel = 100.0 * col / abs(est) if est != 0 else math.nan
        row = {"name": name, "unit": units[k], "estimate": est, "sigma_cr": cr,
               "sigma_corrected": col, "relative_sigma_percent": rel,
               "flag": bool(col > FLAG_RATIO * cr)}
        if case is not None:
            row = {CASE: case, **row}
        rows.append(row)
    return ResultsTable(rows)


class ResultsTable:
    """Rows of a results table (dicts keyed by ``columns``); the exports.

    ``ResultsTable.concat(tables)`` joins the tables of several cases (each
    made with its ``case`` label) into one.  In Jupyter it shows as HTML.

    Parameters
    ----------
    rows : iterable of dict
        As ``results_table`` makes them.
    """

    def __init__(self, rows):
        self.rows = list(rows)

    @property
    def columns(self):
        """The column keys, ``case`` first when the rows carry one."""
        return ((CASE,) if self.rows and CASE in self.rows[0] else ()) + COLUMNS

    @classmethod
    def concat(cls, tables):
        """One table of the rows of several.

        Parameters
        ----------
        tables : iterable of ResultsTable

        Returns
        -------
        ResultsTable
        """
        return cls([row for t in tables for row in t.rows])

    def __len__(self):
        return len(self.rows)

    def __repr__(self):
        return f"ResultsTable({len(self.rows)} rows)"

    # --- text forms ---------------------------------------------------------------------

    def csv_text(self):
        """CSV with a header line; numbers as Python writes them back exactly,
        an undefined relative sigma (zero estimate) empty, flag ``coloured`` or empty.

        Returns
        -------
        str
        """
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(self.columns)
        for row in self.rows:
            w.writerow([_csv_cell(c, row[c]) for c in self.columns])
        return buf.getvalue()

    def json_text(self):
        """A JSON object {"columns": [...], "rows": [{...}, ...]}; an undefined
        relative sigma is null.

        Returns
        -------
        str
        """
        rows = [{c: (None if isinstance(row[c], float) and not math.isfinite(row[c])
                     else row[c]) for c in self.columns} for row in self.rows]
        return json.dumps({"columns": list(self.columns), "rows": rows}, indent=1) + "\n"

    def text(self):
        """A fixed-width table for a terminal or a plain-text report.

        Returns
        -------
        str
        """
        heads = {CASE: "case", "name": "parameter", "unit": "unit", "estimate": "estimate",
                 "sigma_cr": "CR sigma", "sigma_corrected": "corr. sigma",
                 "relative_sigma_percent": "rel. %", "flag": "flag"}
        widths = {CASE: 5, "name": 16, "unit": 10, "estimate": 14, "sigma_cr": 12,
                  "sigma_corrected": 12, "relative_sigma_percent": 8, "flag": 9}
        left = (CASE, "name", "unit", "flag")

        def cell(c, v):
            if c == "flag":
                v = FLAG_TEXT if v else ""
            elif c == "relative_sigma_percent":
                v = f"{v:.2f}" if math.isfinite(v) else "--"
            elif isinstance(v, float):
                v = f"{v:.6e}" if c == "estimate" else f"{v:.4e}"
            return f"{v:<{widths[c]}}" if c in left else f"{v:>{widths[c]}}"

        lines = [" ".join(f"{heads[c]:<{widths[c]}}" if c in left else
                          f"{heads[c]:>{widths[c]}}" for c in self.columns)]
        lines += [" ".join(cell(c, row[c]) for c in self.columns) for row in self.rows]
        lines.append(f"corr. sigma: Cramer-Rao sigma corrected for coloured residuals; "
                     f"'{FLAG_TEXT}' where it exceeds {FLAG_RATIO:g} times the CR sigma")
        return "\n".join(ln.rstrip() for ln in lines) + "\n"

    def __str__(self):
        return self.text()

    def latex_text(self):
        """A booktabs tabular (needs \\usepackage{booktabs} and siunitx),
        made by pandas (Styler.to_latex, which escapes the text); numbers
        plain, to 4 significant digits; names as math (latex_name), units by
        siunitx (latex_unit).

        Returns
        -------
        str

        Raises
        ------
        InputError
            If pandas (or jinja2, which its LaTeX needs) is not installed.
        """
        cols = self.columns
        align = "".join("l" if c in (CASE, "name", "unit", "flag") else "r" for c in cols)
        heads = ((("Case",) if CASE in cols else ()) + LATEX_HEADINGS)
        cells, verbatim = {}, []
        for head, c in zip(heads, cols):
            texts = [_latex_cell(c, row[c]) for row in self.rows]
            cells[head] = [t for t, _ in texts]
            verbatim.append([v for _, v in texts])
        return _latex_tabular(cells, align, verbatim=np.array(verbatim, dtype=bool).T
                              if self.rows else None)

    def html_text(self):
        """An HTML table (no styling): names, units and flags escaped,
        numbers to HTML_DIGITS significant digits, an undefined relative
        sigma (zero estimate) empty; the flag column says ``coloured``.

        Returns
        -------
        str
        """
        cols = self.columns
        heads = (("Case",) if CASE in cols else ()) + HEADINGS
        head = "".join(f"<th>{html.escape(h)}</th>" for h in heads)
        body = []
        for row in self.rows:
            cells = "".join(_html_cell(c, row[c]) for c in cols)
            body.append(f"<tr>{cells}</tr>")
        return (f'<table class="mlid-results"><thead><tr>{head}</tr></thead>'
                f"<tbody>{''.join(body)}</tbody></table>")

    def _repr_html_(self):
        return self.html_text()

    # --- exports ------------------------------------------------------------------------

    def to_csv(self, path):
        """Write the CSV form to path (whole or not at all).

        Parameters
        ----------
        path : str or Path
        """
        _write(path, self.csv_text())

    def to_json(self, path):
        """Write the JSON form to path (whole or not at all).

        Parameters
        ----------
        path : str or Path
        """
        _write(path, self.json_text())

    def to_latex(self, path):
        """Write the LaTeX tabular to path (whole or not at all).

        Parameters
        ----------
        path : str or Path
        """
        _write(path, self.latex_text())

    def to_frame(self):
        """A pandas DataFrame with ``columns``.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        InputError
            If pandas is not installed.
        """
        pd = pandas_for("ResultsTable.to_frame")
        return pd.DataFrame([[row[c] for c in self.columns] for row in self.rows],
                            columns=list(self.columns))

    def write(self, path):
        """Write path in the format its suffix names (.csv, .tex, .json).

        Parameters
        ----------
        path : str or Path

        Raises
        ------
        InputError
            For another suffix.
        """
        writer = WRITERS.get(str(path).rsplit(".", 1)[-1].lower() if "." in str(path) else "")
        if writer is None:
            raise InputError(f"table file {path}: the suffix must be one of "
                             f"{', '.join('.' + s for s in WRITERS)}")
        writer(self, path)


WRITERS = {"csv": ResultsTable.to_csv, "tex": ResultsTable.to_latex,
           "json": ResultsTable.to_json}


def _write(path, text):
    atomic_write_text(path, text)


def _csv_cell(col, value):
    if col == "flag":
        return FLAG_TEXT if value else ""
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ""
    return value


def _html_cell(col, value):
    if col == "flag":
        return f"<td>{FLAG_TEXT if value else ''}</td>"
    if isinstance(value, (float, np.floating)):
        text = f"{value:.{HTML_DIGITS}g}" if math.isfinite(value) else ""
        return f'<td style="text-align:right">{text}</td>'
    return f"<td>{html.escape(str(value))}</td>"


def _latex_cell(col, value):
    """A cell of the LaTeX table: its text, and whether it is LaTeX already
    (math names, siunitx units, numbers) rather than text to escape."""
    if col == "flag":
        return (FLAG_TEXT if value else ""), False
    if col == "name":
        math_text = _math_name(value)
        return (str(value), False) if math_text is None else (math_text, True)
    if col == "unit":
        si = _si_unit(value)
        return (str(value).strip(), False) if si is None else (si, True)
    if isinstance(value, (float, np.floating)):
        return (f"{value:.4g}" if math.isfinite(value) else "--"), True
    return str(value), False
