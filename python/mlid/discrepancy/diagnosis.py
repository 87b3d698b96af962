"""The outcome of mlid.diagnose and its views: the per-output residual
diagnostics, the report, the JSON form, the HTML form for Jupyter and the
plot of the residuals before and after."""

import html
import math

import numpy as np

from ..estimate.result import whiteness
from ..estimate.table import HTML_DIGITS
from ..files import atomic_savefig


def residual_diagnostics(res, lags=20, xcorr_lags=10):
    """Per output: mean and its z, whiteness (Ljung-Box), the strongest
    spectral peak over the median, the largest cross-correlation with each
    input (and its lag), a linear trend's z, and the share of repeated values
    (clipping or quantisation plateaus)."""
    e = res.residuals
    n = len(e)
    white = whiteness(e, lags)
    u = res.data.u - res.data.u.mean(axis=0)
    out = []
    for i in range(e.shape[1]):
        col = e[:, i]
        sd = col.std(ddof=1) or 1.0
        c = col - col.mean()
        spec = np.abs(np.fft.rfft(c))[1:] ** 2
        peak = float(spec.max() / max(np.median(spec), 1e-300)) if spec.size else 0.0
        tt = np.arange(n) - (n - 1) / 2
        slope = float(tt @ c / (tt @ tt))
        slope_z = slope / (sd / math.sqrt(tt @ tt))
        xc = []
        for j in range(u.shape[1]):
            uj = u[:, j]
            den = math.sqrt((c @ c) * (uj @ uj)) or 1.0
            vals = [(float(c[k:] @ uj[:n - k]) / den, k) for k in range(xcorr_lags + 1)]
            xc.append(max(vals, key=lambda v: abs(v[0])))
        y = res.data.y[:, i]
        repeated = float(np.mean(np.diff(y) == 0.0))
        out.append({"output": res.data.output_names[i] if res.data.output_names else f"y{i + 1}",
                    "mean": float(col.mean()), "mean_z": float(col.mean() / (sd / math.sqrt(n))),
                    "rms": float(math.sqrt(np.mean(col**2))), "Q": white[i]["Q"],
                    "Q_critical": white[i]["critical"], "white": white[i]["white"],
                    "spectral_peak": peak, "trend_z": slope_z, "xcorr": xc,
                    "plateaus": repeated})
    return out


#: the rule under coloured residuals, as the report states it (issue 47 item 1)
COLOUR_RULE = ("coloured residuals: each refit's 2dJ and held-out 2dJ are divided by its colour "
               "factor, its refit's (Wald with the coloured-residual covariance over the "
               "Cramer-Rao one), at least 1, and the 2dJ point is widened for the factor's "
               "estimate "
               "(fixed-b); turbulence or a gust must beat coloured measurement noise; the score "
               "(ranking only) is also given for colour (generalised score test); an effect must "
               "explain the spectral peaks and input correlations its fitted change reaches")


class Diagnosis:
    """The outcome of ``diagnose``: accepted effects, every candidate tried,
    the gap between the first and the last fit.

    Parameters
    ----------
    base : FitResult
        The fit of the model as given.
    final : FitResult
        The fit with every accepted effect (``base`` when none was).
    model : Model
        The model of ``final``.
    effects : list of Candidate
        The accepted effects, in the order they were accepted.
    rounds : list of dict
        Per round: its starting ``cost``, the ``candidates`` ranked and the
        likelihood-ratio ``threshold``.
    alpha : float
        The significance level, before the Bonferroni division.
    held_out : str or None
        The part of the data the effects were checked on ('the last third
        of the record', 'the last manoeuvre'); None: too short to hold out.
    unexplained : list of Structure
        The structures the final residuals still hold that no accepted
        effect explains (mlid.discrepancy.structure): a spectral peak's
        channel and frequency, an input correlation's channel and input.
    colour : Candidate or None
        Coloured measurement noise when it explained the residuals' colour
        better than turbulence or a gust (mlid.discrepancy.noise_colour).

    Attributes
    ----------
    fit : FitResult
        ``final``.
    before, after : list of dict
        ``residual_diagnostics`` of ``base`` and of ``final``.
    """

    def __init__(self, base, final, model, effects, rounds, alpha, held_out=None,
                 unexplained=(), colour=None):
        self.base, self.fit, self.model = base, final, model
        self.effects, self.rounds, self.alpha = effects, rounds, alpha
        self.held_out = held_out
        self.unexplained, self.colour = list(unexplained), colour
        self.before = residual_diagnostics(base)
        self.after = residual_diagnostics(final)

    def _round_header(self, k, rnd):
        widen = rnd.get("widen", 1.0)
        wide = (f"; over its colour factor > {widen * rnd['threshold']:.2f}, widened "
                f"x{widen:.2f} for the factor's estimate" if widen > 1.0 else "")
        return (f"round {k}: cost {rnd['cost']:.2f}, {len(rnd['candidates'])} candidates, "
                f"threshold 2dJ > {rnd['threshold']:.2f} (chi-square, alpha "
                f"{self.alpha}/{len(rnd['candidates'])}{wide})")

    @staticmethod
    def _listed(rnd):
        """The candidates a round lists: every one refitted (largest 2dJ
        first), then the best of the rest, eight in all."""
        tried = sorted([c for c in rnd["candidates"]
                        if c.lr is not None
                        or c.decision.startswith(("refit failed", "untested"))],
                       key=lambda c: -math.inf if c.lr is None else c.lr, reverse=True)
        rest = sorted([c for c in rnd["candidates"] if c.decision == "not refitted"],
                      key=_rank_key, reverse=True)
        return tried + rest[:max(0, 8 - len(tried))]

    @property
    def held_out_text(self):
        """What the held-out checks used."""
        if self.held_out is None:
            return "no held-out checks (the record is too short to hold a part out)"
        return f"effects checked on {self.held_out}, held out from their fits"

    @property
    def coloured(self):
        """A warning when the final fit's residuals are still not white
        (Ljung-Box), else ''."""
        bad = [a["output"] for a in self.after if not a["white"]]
        if not bad:
            return ""
        return (f"the residuals of {', '.join(bad)} are still not white (Ljung-Box, 5%): an "
                "effect is still missing or the noise is coloured; the Cramer-Rao sigmas are "
                "then optimistic (use the coloured-residual sigmas)")

    @property
    def not_explained(self):
        """One line per structure no candidate explains (first-class: in the
        verdict, the report, the JSON and the HTML)."""
        return [f"{s.text} not explained by any candidate" for s in self.unexplained]

    @property
    def colour_text(self):
        """The residuals' colour as coloured measurement noise, with its
        quantities, or ''."""
        c = self.colour
        if c is None:
            return ""
        qs = "; ".join(f"{q} {v:.3g} +- {sd:.2g}{' ' + u if u else ''}"
                       for q, v, sd, u, _ in c.quantities or [])
        return (f"the residuals' colour is coloured measurement noise on "
                f"{c.spec['channel']} ({qs}), not turbulence or a gust")

    @property
    def verdict(self):
        """One line: the effects found, or that nothing is missing; then
        what is not explained, and coloured measurement noise when named."""
        if not self.effects:
            text = ("nothing missing at this significance" if not self.unexplained
                    else "no effect of the library explains the residuals")
        else:
            text = "effects found: " + ", ".join(c.title for c in self.effects)
        if self.not_explained:
            text += "; " + "; ".join(self.not_explained)
        if self.colour is not None:
            text += "; residual colour: coloured measurement noise"
        return text

    def report(self):
        """The diagnosis as printed lines: each round's candidates with their
        statistic, likelihood ratio and decision, the effects found, and the
        residual RMS and whiteness before and after.

        Returns
        -------
        str
        """
        lines = [" model-discrepancy diagnosis; " + self.held_out_text,
                 " " + COLOUR_RULE]
        for k, rnd in enumerate(self.rounds, 1):
            lines.append(" " + self._round_header(k, rnd))
            for c in self._listed(rnd):
                stat = (f"score {c.score:9.2f}" + (f" ({c.score_corrected:.2f} for colour)"
                                                   if c.score_corrected is not None else "")
                        if c.score is not None
                        else f"signature {c.signature:6.3f}" if c.signature is not None
                        else " " * 15)
                lr = f"2dJ {c.lr:9.2f}" if c.lr is not None else " " * 13
                ho = f"held out {c.holdout:+8.2f}" if c.holdout is not None else " " * 17
                note = f" ({c.note})" if c.note else ""
                lines.append(f"   {c.family:<20} {c.name:<28} {stat}  {lr}  {ho}  "
                             f"{c.decision}{note}")
            confounded = [c.name for c in rnd["candidates"] if c.confounded]
            if confounded:
                lines.append("   confounded with the free parameters, not tried: "
                             + ", ".join(confounded))
        if self.effects:
            lines.append(" effects found (their quantities from the final fit):")
            for c in self.effects:
                held = "" if c.holdout is None else f", held out {c.holdout:+.1f}"
                lines.append(f"   {c.family}: {c.title} (round {c.round}: 2dJ {c.lr:.1f}{held})")
                for q, v, sd, unit, meaning in c.quantities or []:
                    lines.append(f"      {q} = {v:.5g} +- {sd:.2g}{' ' + unit if unit else ''}"
                                 f"  ({meaning})")
        else:
            lines.append(" " + self.verdict)
        for text in self.not_explained:
            lines.append(" NOT EXPLAINED: " + text)
        if self.colour_text:
            lines.append(" " + self.colour_text)
        lines.append(f" cost {self.base.cost:.2f} -> {self.fit.cost:.2f}")
        if self.coloured:
            lines.append(" warning: " + self.coloured)
        for b, a in zip(self.before, self.after):
            lines.append(f"   {b['output']:<8} residual rms {b['rms']:.4g} -> {a['rms']:.4g},  "
                         f"Ljung-Box Q {b['Q']:.1f} -> {a['Q']:.1f} (5% point {b['Q_critical']:.1f})")
        return "\n".join(lines)

    def as_dict(self):
        """Plain types for JSON (``mlid diagnose --json``): the verdict, the
        effects with value and sigma (None where the candidate has none, a
        profiled delay, lag or scale factor) from the final fit and the round
        that accepted each, each round's candidates as the report lists them
        (with their own refit's quantities), and the residuals before and
        after.

        Returns
        -------
        dict
        """
        def num(x):
            return None if x is None or not math.isfinite(x) else float(x)

        def cand(c, final=True):
            qs = c.quantities if final or c.refit_quantities is None else c.refit_quantities
            value, sigma = (qs[0][1], qs[0][2]) if qs else (None, None)
            return {"family": c.family, "name": c.name, "score": num(c.score),
                    "score_corrected": num(getattr(c, "score_corrected", None)),
                    "colour_factor": num(getattr(c, "colour", None)),
                    "colour_factor_refit": num(getattr(c, "colour_refit", None)),
                    "colour_factor_null": num(getattr(c, "colour_null", None)),
                    "signature": num(c.signature), "lr": num(c.lr),
                    "holdout_lr": num(c.holdout), "explained": num(c.explained),
                    "value": num(value), "sigma": num(sigma),
                    "quantities": [{"quantity": q, "value": num(v), "sigma": num(sd),
                                    "unit": unit, "meaning": meaning}
                                   for q, v, sd, unit, meaning in qs or []],
                    "decision": c.decision, "note": c.note,
                    "equivalent": [{"family": e.family, "name": e.name} for e in c.equivalent]}
        return {"verdict": self.verdict, "alpha": self.alpha, "warning": self.coloured,
                "colour_rule": COLOUR_RULE,
                "held_out": self.held_out,
                "not_explained": [dict(s.as_dict(), statement=t)
                                  for s, t in zip(self.unexplained, self.not_explained)],
                "noise_colour": None if self.colour is None else dict(
                    cand(self.colour), statement=self.colour_text),
                "cost_before": num(self.base.cost), "cost_after": num(self.fit.cost),
                "effects": [dict(cand(c), round=c.round) for c in self.effects],
                "rounds": [{"cost": num(r["cost"]), "threshold": num(r["threshold"]),
                            "candidates_tried": len(r["candidates"]),
                            "listed": [cand(c, final=False) for c in self._listed(r)],
                            "confounded": [c.name for c in r["candidates"] if c.confounded]}
                           for r in self.rounds],
                "residuals": [{"output": b["output"], "rms_before": num(b["rms"]),
                               "rms_after": num(a["rms"]), "Q_before": num(b["Q"]),
                               "Q_after": num(a["Q"]), "Q_critical": num(b["Q_critical"])}
                              for b, a in zip(self.before, self.after)]}

    def _repr_html_(self):
        """Jupyter's view: the verdict, the effects, each round's candidates
        and the residuals before and after, as tables."""
        parts = [f'<div class="mlid-diagnosis"><p><b>Diagnosis</b>: '
                 f'<span class="verdict">{_esc(self.verdict)}</span>; cost '
                 f'<span class="cost-before">{_g(self.base.cost)}</span> &rarr; '
                 f'<span class="cost-after">{_g(self.fit.cost)}</span></p>']
        if self.unexplained:
            parts.append('<p class="not-explained"><b>Not explained</b></p>')
            parts.append(_html_table(
                "mlid-not-explained", ("kind", "channel", "frequency [Hz]", "statistic",
                                       "point", "its test", "what remains"),
                [(s.kind, s.channel, s.frequency, s.size, s.point, s.test, t)
                 for s, t in zip(self.unexplained, self.not_explained)]))
        if self.colour_text:
            parts.append(f'<p class="noise-colour">{_esc(self.colour_text)}</p>')
        if self.coloured:
            parts.append(f'<p class="warning">warning: {_esc(self.coloured)}</p>')
        if self.effects:
            parts.append("<p>the effects' quantities from the final fit; 2dJ and held-out 2dJ "
                         "from the round that accepted each ("
                         + _esc(", ".join(f"{c.name}: round {c.round}" for c in self.effects))
                         + ")</p>")
            parts.append(_html_table(
                "mlid-effects", ("family", "effect", "quantity", "value", "σ", "unit",
                                 "meaning", "2dJ", "held-out 2dJ"),
                [(c.family, c.title, q, v, sd, unit, meaning, c.lr, c.holdout)
                 for c in self.effects for q, v, sd, unit, meaning in c.quantities or []]))
        for k, rnd in enumerate(self.rounds, 1):
            parts.append(f"<p>{_esc(self._round_header(k, rnd))}</p>")
            parts.append(_html_table(
                "mlid-candidates", ("family", "candidate", "score", "signature", "2dJ",
                                    "held-out 2dJ", "decision", "score for colour",
                                    "colour factor"),
                [(c.family, c.name, c.score, c.signature, c.lr, c.holdout,
                  c.decision + (f" ({c.note})" if c.note else ""),
                  getattr(c, "score_corrected", None), getattr(c, "colour", None))
                 for c in self._listed(rnd)]))
            confounded = [c.name for c in rnd["candidates"] if c.confounded]
            if confounded:
                parts.append("<p>confounded with the free parameters, not tried: "
                             f"{_esc(', '.join(confounded))}</p>")
        parts.append(_html_table(
            "mlid-residuals", ("output", "rms before", "rms after", "Ljung-Box Q before",
                               "Q after", "5% point"),
            [(b["output"], b["rms"], a["rms"], b["Q"], a["Q"], b["Q_critical"])
             for b, a in zip(self.before, self.after)]))
        return "".join(parts) + "</div>"

    def __repr__(self):
        return (f"Diagnosis({len(self.effects)} effects {[c.name for c in self.effects]}, "
                f"{len(self.rounds)} rounds, cost {self.base.cost:.6g} -> {self.fit.cost:.6g})")

    def plot(self, folder):
        """Write ``figure()`` to FOLDER/diagnosis.png.

        Parameters
        ----------
        folder : str or Path
            Where to write diagnosis.png (made if missing).

        Returns
        -------
        Path
            The figure's path.
        """
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from pathlib import Path
        Path(folder).mkdir(parents=True, exist_ok=True)
        fig = self.figure()
        path = Path(folder) / "diagnosis.png"
        atomic_savefig(fig, path, dpi=100)
        plt.close(fig)
        return path

    def figure(self):
        """Residuals, their autocorrelation and power spectrum, before and
        after the accepted effects, per output in its declared unit: time
        in s, lag in s with the ±1.96/√N band, spectrum in Hz (Welch, Hann
        windows, one-sided) in unit²/Hz.

        Returns
        -------
        matplotlib.figure.Figure
            A row per output: residuals, autocorrelation, spectrum.
        """
        import matplotlib.pyplot as plt
        from scipy.signal import welch
        data = self.base.data
        ny = self.base.residuals.shape[1]
        dt = float(np.median(np.diff(data.t))) if data.nt > 1 else 1.0
        n = len(self.base.residuals)
        lags = min(30, n - 1)
        fig, axes = plt.subplots(ny, 3, figsize=(11, 2.0 * ny + 1.2), squeeze=False)
        for i in range(ny):
            unit, scale, _ = data.output_display[i]
            unit = unit or data.output_units[i]
            for res, label, color in ((self.base, "before", "C3"), (self.fit, "after", "C0")):
                e = res.residuals[:, i] / scale
                axes[i, 0].plot(res.data.t, e, color=color, lw=0.7, label=label)
                c = e - e.mean()
                ac = [1.0] + [float(c[k:] @ c[:-k] / (c @ c)) for k in range(1, lags + 1)]
                axes[i, 1].plot(dt * np.arange(lags + 1), ac, "o-", ms=2, color=color,
                                label=label)
                f, p = welch(c, fs=1.0 / dt, window="hann", nperseg=min(256, max(8, n // 4)))
                axes[i, 2].semilogy(f[1:], p[1:], color=color, lw=0.7, label=label)
            bound = 1.96 / math.sqrt(n)
            axes[i, 1].axhspan(-bound, bound, color="0.9", label="±1.96/√N")
            name = self.before[i]["output"]
            axes[i, 0].set_ylabel(f"Δ{name} [{unit}]" if unit else f"Δ{name}")
            axes[i, 1].set_ylabel("autocorrelation [-]")
            axes[i, 2].set_ylabel(f"PSD [{unit}²/Hz]" if unit else "PSD [1/Hz]")
        for ax, label in zip(axes[-1], ("t [s]", "lag [s]", "frequency [Hz]")):
            ax.set_xlabel(label)
        axes[0, 0].set_title("residuals")
        axes[0, 1].set_title("autocorrelation")
        axes[0, 2].set_title("power spectrum (Welch, Hann)")
        axes[0, 0].legend(fontsize=7)
        axes[0, 1].legend(fontsize=7)
        fig.suptitle("residuals before and after the accepted effects", fontsize=10)
        fig.tight_layout()
        return fig


def _esc(text):
    return html.escape(str(text))


def _g(value):
    """A number in the HTML views (as the results table: HTML_DIGITS
    significant digits), NaN and None empty."""
    if value is None or not math.isfinite(value):
        return ""
    return f"{value:.{HTML_DIGITS}g}"


def _html_table(cls, heads, rows):
    """An HTML table: text cells escaped, numbers right-aligned by _g."""
    def cell(v):
        if isinstance(v, (int, float, np.floating)) and not isinstance(v, bool) or v is None:
            return f'<td style="text-align:right">{_g(None if v is None else float(v))}</td>'
        return f"<td>{_esc(v)}</td>"
    head = "".join(f"<th>{_esc(h)}</th>" for h in heads)
    body = "".join("<tr>" + "".join(cell(v) for v in row) + "</tr>" for row in rows)
    return f'<table class="{cls}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _rank_key(c):
    if c.confounded:
        return -1.0
    if c.score is not None:
        return c.score
    return 1e3 * (c.signature or 0.0)


