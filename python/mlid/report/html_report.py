"""One self-contained HTML page per deck: every case's estimates, noise,
convergence, whiteness and figures, readable offline (figures inlined as
base64 PNG, CSS inline, no external link), written whole or not at all."""

import base64
import html
import io
import math
from pathlib import Path

import numpy as np

from .._version import installed_version
from ..errors import InputError
from ..estimate.table import FLAG_TEXT, HEADINGS, results_table
from ..files import atomic_write_text
from . import plots

#: Relative Cramér-Rao σ above which an estimate is flagged (when the result
#: carries no flags of its own).
FLAG_RELATIVE_SIGMA = 0.20
#: |correlation| above which an estimate is flagged (the report's 0.9).
FLAG_CORRELATION = 0.9

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


def _e(x):
    return html.escape(str(x), quote=True)


def _num(v, digits=5):
    if v is None:
        return ""
    v = float(v)
    if not math.isfinite(v):
        return str(v)
    return f"{v:.{digits}g}"


def _table(header, rows, cls=""):
    """An HTML table (no head row when header is None); cells are escaped
    unless given as ('raw', html)."""
    def cell(c, tag):
        text = c[1] if isinstance(c, tuple) and c and c[0] == "raw" else _e(c)
        return f"<{tag}>{text}</{tag}>"
    head = "" if header is None else \
        "<thead><tr>" + "".join(cell(h, "th") for h in header) + "</tr></thead>"
    body = "".join("<tr>" + "".join(cell(c, "td") for c in r) + "</tr>" for r in rows)
    return f'<table class="{cls}">{head}<tbody>{body}</tbody></table>'


def _png(fig):
    """The figure as an <img> with a data: URI (base64 PNG); the figure is closed."""
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", dpi=plots.DPI)
    finally:
        plots.close(fig)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return f'<img alt="" src="data:image/png;base64,{data}">'


def _figure(make, caption):
    """A <figure> of make(), or one line saying why it could not be drawn."""
    try:
        img = _png(make())
    except Exception as exc:          # one figure failing does not lose the page
        return f'<p class="note">figure not drawn ({_e(caption)}): {_e(type(exc).__name__)}: ' \
               f'{_e(exc)}</p>'
    return f"<figure>{img}<figcaption>{_e(caption)}</figcaption></figure>"


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
    """The results table of ``mlid.estimate.table.results_table`` as HTML: name, unit,
    estimate, Cramér-Rao σ, σ corrected for coloured residuals, relative σ
    and flag, with the start value after the unit and the report's own flags
    (relative σ above FLAG_RELATIVE_SIGMA, |correlation| above
    FLAG_CORRELATION) beside the table's.

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
                     ("raw", f'<span class="flag">{_e(", ".join(flags))}</span>') if flags
                     else ""])
    note = "" if any(r[1] for r in rows) else \
        '<p class="note">units of the parameters: not declared to the fit</p>'
    return _table(header, rows, "estimates") + note


def noise_table(result):
    """Per output: σ = √ of the diagonal of R̂ (B̂ for filter error) in the
    declared unit, and the diagonal itself in the core's unit; det R̂."""
    recs = plots._Records.of_result(result)
    sym = plots.noise_symbol(result)
    rows = []
    for i, name in enumerate(result.data.output_names):
        r = float(result.rhat[i, i])
        unit, scale, _ = plots._display(recs.first, "y", i)
        core = recs.first.output_units[i] if recs.first.output_units else ""
        rows.append([name, _num(math.sqrt(max(r, 0.0)) / abs(scale), 4), unit, _num(r, 4),
                     plots.unit_squared(core)])
    return (_table(["output", f"σ = √{sym}ᵢᵢ", "unit", f"{sym}ᵢᵢ", "unit"], rows)
            + f"<p>det {sym} = {_e(_num(result.det_r))}</p>")


def noise_heading(result):
    """What the noise table shows: the measurement noise (output error) or
    the innovations (filter error)."""
    return "Innovations (mean covariance B̂)" if plots.noise_symbol(result) == "B̂" \
        else "Measurement noise (R̂)"


def convergence_html(result):
    """How the iteration ended, as a two-column table."""
    state = "converged" if result.converged else "not converged"
    rows = [["status", state], ["stopped because", result.reason],
            ["iterations", result.iterations], ["final cost", _num(result.cost, 8)],
            ["rank", result.rank], ["fit time [s]", _num(result.wall_time, 3)]]
    return _table(None, rows)


def cost_history_html(result):
    """The cost at each iteration, one line that wraps."""
    hist = " → ".join(_num(c, 7) for c in result.cost_history)
    return f'<p class="note">cost history: {_e(hist)}</p>'


def whiteness_html(result):
    rows = []
    for name, w in zip(result.data.output_names, result.whiteness()):
        rows.append([name, _num(w["Q"], 4), _num(w["critical"], 4),
                     ("raw", '<span class="status ok">white</span>') if w["white"] else
                     ("raw", '<span class="status warn">coloured</span>'),
                     f"{100 * w['outside']:.0f}"])
    return (_table(["output", "Ljung-Box Q (20 lags)", "5% critical", "verdict",
                    "lags outside ±1.96/√N [%]"], rows))


def validation_html(v):
    """Per output of the held-out manoeuvres: Theil's U, the rms prediction
    error in the declared unit and its ratio to the identification's σ."""
    recs = plots._Records.of_result(v.prediction)
    rows = []
    for i, name in enumerate(v.output_names):
        unit, scale, _ = plots._display(recs.first, "y", i)
        rows.append([name, _num(v.theil[i], 3), _num(v.rms[i] / abs(scale), 4), unit,
                     _num(v.rms_over_sigma[i], 3)])
    held = ", ".join(str(k) for k in v.holdout)
    return (f"<p>held-out file{'s' * (len(v.holdout) > 1)} {_e(held)}, predicted by the "
            "identified model (refitted there: only the initial state and output biases it fitted)</p>"
            + _table(["output", "Theil U", "rms error", "unit", "rms / σ"], rows))


def modes_html(model):
    rows = []
    for m in plots.modes(model):
        z = m["eigenvalue"]
        lam = f"{z.real:.4g} ± {abs(z.imag):.4g}j" if z.imag else f"{z.real:.4g}"
        if m["time_constant"] is not None:
            rows.append([lam, "", "", "", _num(m["time_constant"], 4)])
        else:
            rows.append([lam, _num(m["omega_n"], 4), _num(m["f_n"], 4), _num(m["zeta"], 3),
                         ""])
    return _table(["eigenvalue [rad/s]", "ωn [rad/s]", "fn [Hz]", "ζ [-]",
                   "time constant [s]"], rows)


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


def _fit_sections(result):
    if result.failed:            # no estimates, statistics or figures: the report says why
        return ["<h3>Last values reached (not estimates)</h3>",
                f"<pre>{_e(result.report())}</pre>"]
    parts = ["<h3>Estimates</h3>", estimates_table(result)]
    try:
        ident = result.identifiability()
    except Exception:
        ident = []
    if ident:
        parts.append(f"<pre>{_e(chr(10).join(ident))}</pre>")
    parts += [f'<div class="grid"><div><h3>{_e(noise_heading(result))}</h3>',
              noise_table(result),
              "</div><div><h3>Convergence</h3>", convergence_html(result), "</div></div>",
              cost_history_html(result),
              "<h3>Whiteness of the residuals</h3>", whiteness_html(result),
              "<h3>Figures</h3>",
              _figure(lambda: plots.fit_overview(result), f"{plots.outputs_title(result)} "
                      "with the inputs; residuals with ±2σ bands, σ from "
                      f"{plots.noise_symbol(result)}"),
              _figure(lambda: plots.autocorrelation(result), "residual autocorrelation against "
                      "lag, ±1.96/√N band"),
              _figure(lambda: plots.spectra(result), "residual power spectra, white-noise level "
                      "of the same variance dashed"),
              _figure(lambda: plots.correlation(result), "correlation matrix of the estimates")]
    checked = getattr(result, "validation", None)
    if checked is not None:
        parts += ["<h3>Validation on held-out manoeuvres</h3>", validation_html(checked),
                  _figure(lambda: plots.validation(checked), "held-out manoeuvres: measured "
                          "outputs and the identified model's prediction")]
    if getattr(result.model, "kind", None) == 1:
        parts += ["<h3>Modes of the identified model</h3>", modes_html(result.model),
                  _figure(lambda: plots.s_plane(result), "eigenvalues of A; the cloud: models "
                          f"drawn from N(θ̂, Cramér-Rao covariance), {plots.BAND_SAMPLES} "
                          f"draws, seed {plots.BAND_SEED}"),
                  _figure(lambda: plots.bode(result), "frequency response per input-output "
                          "pair; band: 2.5-97.5 percentiles of the sampled models (≈ ±2σ)")]
    parts.append(f"<details><summary>the printed report</summary><pre>{_e(result.report())}"
                 "</pre></details>")
    return parts


def case_html(case, out, result, error):
    """The <section> of one case: title, job, status, and what it produced."""
    k = getattr(case, "index", "")
    cls, text = _status(out, result, error)
    parts = [f'<section id="case-{_e(k)}"><h2>Case {_e(k)}: {_e(case.title)}</h2>',
             f'<p class="meta">job: <b>{_e(case.job)}</b> &nbsp; '
             f'<span class="status {cls}">{_e(text)}</span></p>']
    message = str(error) if error is not None else (
        (out or {}).get("message") or (getattr(result, "message", "") if result else ""))
    if message:
        parts.append(f'<div class="error">{_e(message)}</div>')
    if out is not None and out.get("job") == "simulate" and "samples" in out:
        parts.append(f"<p>simulated {_e(out['samples'])} samples to "
                     f"<code>{_e(Path(out['out']).name)}</code></p>")
    elif getattr(out, "report", None) and result is None and error is None:
        parts.append(f"<pre>{_e(out.report)}</pre>")   # a design or Monte Carlo: its lines
    if result is not None:
        parts += _fit_sections(result)
    parts.append("</section>")
    return "\n".join(parts)


def _toc(entries):
    rows = []
    for case, out, result, error in entries:
        cls, text = _status(out, result, error)
        k = getattr(case, "index", "")
        rows.append([k, ("raw", f'<a href="#case-{_e(k)}">{_e(case.title)}</a>'), case.job,
                     ("raw", f'<span class="status {cls}">{_e(text)}</span>')])
    return _table(["case", "title", "job", "status"], rows, "toc")


def report_html(deck_path, cases):
    """The whole page as text (see write_report)."""
    entries = list(cases)
    name = Path(deck_path).name
    body = [f"<h1>mlid report: {_e(name)}</h1>",
            f'<p class="meta">deck {_e(deck_path)} &middot; {len(entries)} cases &middot; '
            f"mlid {_e(installed_version())}</p>", _toc(entries)]
    body += [case_html(*entry) for entry in entries]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>mlid: {_e(name)}</title><style>{CSS}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")


def write_report(folder, deck_path, cases):
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

    Returns
    -------
    Path
        The page written (whole or not at all).

    Raises
    ------
    InputError
        If the folder cannot be made or written.
    """
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot make report folder {folder}: {exc.strerror}") from None
    path = folder / f"{Path(deck_path).stem}.html"
    # ASCII with character references: the same bytes whatever the locale
    text = report_html(deck_path, cases).encode("ascii", "xmlcharrefreplace").decode("ascii")
    atomic_write_text(path, text)
    return path
