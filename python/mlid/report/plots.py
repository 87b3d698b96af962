"""Plots a flight-test engineer expects of a record, a fit and a Monte Carlo.

Every plot is a function that returns a matplotlib Figure and, given
``path``, also writes it (whole or not at all).  No backend is chosen here:
a notebook shows the figures inline; the command line selects Agg before it
draws (see ``use_file_backend``).  Channels are drawn in the unit the record
declared (``FlightData.shown``), labelled ``name [unit]``; several
manoeuvres share one time axis with a gap (no line) at each join.
"""

import functools
from pathlib import Path

import numpy as np

from ..data.flight_data import FlightData
from ..errors import InputError
from ..estimate.outcome import require_estimates
from ..files import atomic_savefig
from ..frequency.responses import model_response, record_response
from ..model.maneuvers import join

#: One colour per role, in every plot.
COLORS = {"measured": "0.30", "model": "#1f5fa8", "input": "#2a8a3e", "residual": "#b2332a",
          "band": "#1f5fa8", "truth": "black", "mean": "#d98c00", "grid": "0.88"}
#: Readable, consistent text in every figure (applied while a figure is drawn).
STYLE = {"font.size": 9, "axes.titlesize": 9.5, "axes.labelsize": 9, "xtick.labelsize": 8,
         "ytick.labelsize": 8, "legend.fontsize": 8, "axes.grid": True,
         "grid.color": COLORS["grid"], "grid.linewidth": 0.6, "axes.axisbelow": True,
         "axes.spines.top": False, "axes.spines.right": False, "figure.dpi": 100,
         "lines.linewidth": 1.2}
DPI = 120
#: Draws and seed of the Cramér-Rao cloud of the s-plane plot.
BAND_SAMPLES, BAND_SEED = 300, 0
#: Width in σ of every band and error bar of a frequency response (the model's
#: Cramér-Rao band, the record's random error), stated in the legend (band_label).
BAND_SIGMAS = 2
#: Opacity of a band's fill (its edge is drawn in full).
BAND_ALPHA = 0.25
#: Coherence below which the Bode plot draws a measured point hollow (less trusted).
COHERENCE_SHOWN = 0.6


def band_label(what, source):
    """The legend entry of a band or error bars of width BAND_SIGMAS σ:
    'model ±2σ (Cramér-Rao)'."""
    return f"{what} ±{BAND_SIGMAS}σ ({source})"


def use_file_backend():
    """Select matplotlib's Agg backend (files only, no display): for the
    command line, before any figure is drawn.  Notebooks keep their own."""
    import matplotlib
    matplotlib.use("Agg")


def _figure(nrows, ncols, width, row_height, sharex=False, **kw):
    """A constrained-layout figure and its axes (2-D array), in STYLE."""
    import matplotlib
    import matplotlib.pyplot as plt
    with matplotlib.rc_context(STYLE):
        fig, axes = plt.subplots(nrows, ncols, figsize=(width, row_height * nrows + 0.7),
                                 sharex=sharex, squeeze=False, layout="constrained", **kw)
    return fig, axes


def _styled(fn):
    """Run a drawing function in STYLE (fonts and grids are set as artists
    are made); matplotlib is imported when a plot is drawn, not when mlid is
    (it costs an import of mlid some 100 ms)."""
    @functools.wraps(fn)
    def wrapper(*args, **kw):
        import matplotlib
        with matplotlib.rc_context(STYLE):
            return fn(*args, **kw)
    return wrapper


def _finish(fig, path, dpi=DPI):
    """Write fig to path (whole or not at all) when a path is given; return fig."""
    if path is not None:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_savefig(fig, path, dpi=dpi)
    return fig


def close(fig):
    """Release a figure made by these functions (needed in batch loops)."""
    import matplotlib.pyplot as plt
    plt.close(fig)


# -- channels, units and manoeuvres -----------------------------------------

def axis_label(name, unit):
    """The one label of a channel: 'name [unit]', or the name alone when the
    unit is unknown."""
    return f"{name} [{unit}]" if unit else str(name)


def _grouped(unit):
    """unit in parentheses when it is compound ('rad/s' -> '(rad/s)'), so that
    a power or a quotient of it reads one way."""
    return f"({unit})" if any(c in unit for c in "/*· ") else unit


def unit_ratio(num, den):
    """The unit of num per den ('(rad/s)/deg'); '' when neither is known,
    '-' standing for an unknown one."""
    if not (num or den):
        return ""
    return f"{_grouped(num) if num else '-'}/{_grouped(den) if den else '-'}"


def unit_squared(unit):
    """The unit of a variance of a channel in unit ('deg²', '(rad/s)²'); ''
    when the channel's unit is unknown."""
    return f"{_grouped(unit)}²" if unit else ""


def psd_unit(unit):
    """The unit of a power spectral density of a channel in unit ('deg²/Hz',
    '(rad/s)²/Hz'); '' when the channel's unit is unknown."""
    return f"{unit_squared(unit)}/Hz" if unit else ""


def noise_symbol(result):
    """What result.rhat is, as the core's report says it
    (``FitResult.noise_diagonal``): 'R̂' (output error: the measurement-noise
    covariance) or 'B̂' (filter error: the mean covariance of the
    innovations, which the residuals are).  A bare prediction (``mlid.validate``
    of a model with nothing to fit) estimated no noise: 'R̂'."""
    if not hasattr(result, "flat_options"):
        return "R̂"
    return "B̂" if result.noise_diagonal()[0].startswith("B") else "R̂"


def model_label(result):
    """The legend entry of the fitted outputs: the model's outputs (output
    error) or the filter's one-step predictions (filter error)."""
    return "filter prediction" if noise_symbol(result) == "B̂" else "model"


def outputs_title(result):
    """The title of the measured and fitted outputs (``model_label``)."""
    return "measured outputs and filter predictions" if noise_symbol(result) == "B̂" \
        else "measured and model outputs"


def _display(record, which, i):
    """(unit, scale, offset) of channel i: declared = (core - offset) / scale."""
    table = getattr(record, "input_display" if which == "u" else "output_display", None)
    return tuple(table[i]) if table else ("", 1.0, 0.0)


class _Records:
    """A record or several manoeuvres as the plots see them: the records,
    the time axis cut into one piece per manoeuvre (each manoeuvre on its
    own time when the manoeuvres follow one another, as windows of one
    flight do; else joined, each after the one before), and each channel in
    its declared unit."""

    def __init__(self, records, t=None):
        records = list(records) if isinstance(records, (list, tuple)) else [records]
        if not records or not all(isinstance(r, FlightData) for r in records):
            raise InputError("plots need a FlightData or a list of them")
        self.records = records
        own = np.concatenate([r.t for r in records])
        if len(records) > 1 and np.all(np.diff(own) > 0):
            t = own         # windows of one flight in order: each on its own time
        elif len(records) > 1 and t is None:
            t = join(records)[0].t
        t = records[0].t if t is None else np.asarray(t, dtype=float)
        self.cuts = np.cumsum([r.nt for r in records])[:-1]
        self.t = t
        self.first = records[0]
        self.dt = float(np.median(np.diff(records[0].t))) if records[0].nt > 1 else 1.0

    @classmethod
    def of_result(cls, result):
        require_estimates(result, "plot")
        given = getattr(result, "evaluate_args", (result.data,))[0]
        return cls(given, result.data.t)

    def names(self, which):
        return self.first.input_names if which == "u" else self.first.output_names

    def shown(self, which, i):
        """Measured channel i in its declared unit, NaN at each join; and the unit."""
        pieces = [r.shown(which, i)[0] if hasattr(r, "shown") else
                  (r.u if which == "u" else r.y)[:, i] for r in self.records]
        return self.broken(np.concatenate(pieces)), _display(self.first, which, i)[0]

    def convert(self, which, i, x, difference=False):
        """Joined values x of channel i (core units) in the declared unit, NaN at joins."""
        _, scale, offset = _display(self.first, which, i)
        return self.broken((np.asarray(x) - (0.0 if difference else offset)) / scale)

    def broken(self, x):
        """x (joined samples) with a NaN between manoeuvres, so no line bridges a join."""
        return np.insert(np.asarray(x, dtype=float), self.cuts, np.nan)

    @property
    def time(self):
        return self.broken(self.t)

    def label(self, which, i):
        return axis_label(self.names(which)[i], _display(self.first, which, i)[0])

    def mark_joins(self, ax):
        for k in self.cuts:
            ax.axvline(0.5 * (self.t[k - 1] + self.t[k]), color="0.6", lw=0.7, ls=(0, (4, 3)))

    def segments(self):
        """Slices of the joined samples, one per manoeuvre."""
        edges = [0, *self.cuts, len(self.t)]
        return [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]


def _panels(n, width=4.2, row_height=1.9):
    """n axes in two columns (one for two or fewer), sharing x; the spare
    cell removed.  Returns (fig, axes list, ncols)."""
    ncols = 2 if n > 2 else 1
    fig, grid = _figure((n + ncols - 1) // ncols, ncols, width * ncols, row_height, sharex=True)
    flat = list(grid.flat)
    for ax in flat[n:]:
        ax.remove()
    return fig, flat[:n], ncols


def _bottom_labels(axes, ncols, label):
    """Tick labels and the x label on each axis with none below it."""
    for k, ax in enumerate(axes):
        if k + ncols >= len(axes):
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel(label)


def _figure_legend(fig, axes):
    """One legend at the foot of fig with every labelled artist of axes, each
    label once."""
    seen = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    fig.legend(list(seen.values()), list(seen), loc="outside lower center",
               ncols=len(seen) if len(seen) < 4 else 2, frameon=False)


def _legend_above(ax, side, **kw):
    """ax's legend just above it, on the left or right, off the data."""
    ax.legend(loc=f"lower {side}", bbox_to_anchor=(0.0 if side == "left" else 1.0, 1.0),
              frameon=False, borderaxespad=0.1, borderpad=0.0, handlelength=1.6, **kw)


#: Decades a logarithmic axis spans at least (so that it has labelled powers of ten).
LOG_DECADES = 2


def _decades(ax, n):
    """ax's log y axis widened about its geometric middle to span n decades
    when it spans fewer; minor ticks unlabelled."""
    from matplotlib.ticker import NullFormatter
    lo, hi = ax.get_ylim()
    if hi < lo * 10 ** n:
        mid = np.sqrt(lo * hi)
        ax.set_ylim(mid / 10 ** (n / 2), mid * 10 ** (n / 2))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _time_axis(axes, recs):
    axes[-1].set_xlabel("t [s]")
    for ax in axes:
        recs.mark_joins(ax)
        ax.margins(x=0.0)
    axes[0].figure.align_ylabels(axes)


# -- records and fits ---------------------------------------------------------

@_styled
def time_histories(data, path=None):
    """Inputs and outputs of a record against time, each in its declared unit.

    Parameters
    ----------
    data : FlightData or list of FlightData
        A record, or several manoeuvres (drawn one after the other, no line
        across a join).
    path : str or Path, optional
        Also write the figure there (format from the suffix).

    Returns
    -------
    matplotlib.figure.Figure
        One axis per channel, inputs first, sharing the time axis.

    Raises
    ------
    InputError
        If data is not a FlightData or a list of them.
    """
    recs = _Records(data)
    rows = [("u", i) for i in drawn_inputs(recs.records)] + \
           [("y", i) for i in range(recs.first.y.shape[1])]
    fig, axes = _figure(len(rows), 1, 7.5, 1.35, sharex=True)
    for ax, (which, i) in zip(axes[:, 0], rows):
        x, _ = recs.shown(which, i)
        ax.plot(recs.time, x, color=COLORS["input" if which == "u" else "measured"], lw=1.0)
        ax.set_ylabel(recs.label(which, i))
    _time_axis(axes[:, 0], recs)
    title = getattr(recs.first, "source", "") or "record"
    fig.suptitle(f"time histories: {Path(title).name}", fontsize=10)
    return _finish(fig, path)


def drawn_inputs(data):
    """The inputs a figure draws: those that vary, in any of the records
    when data is a list (a constant input, the 'one' of a bias or trim
    term, gets no flat panel of its own)."""
    records = data if isinstance(data, (list, tuple)) else [data]
    u = np.concatenate([np.asarray(r.u) for r in records])
    return [i for i in range(u.shape[1]) if u.shape[0] and np.ptp(u[:, i]) > 0]


def _draw_outputs(fig, axes, result, recs):
    inputs = drawn_inputs(result.data)
    nu = len(inputs)
    for ax, i in zip(axes, inputs):
        x, _ = recs.shown("u", i)
        ax.plot(recs.time, x, color=COLORS["input"], lw=1.0)
        ax.set_ylabel(recs.label("u", i))
    for i in range(result.data.y.shape[1]):
        ax = axes[nu + i]
        x, _ = recs.shown("y", i)
        ax.plot(recs.time, x, ".", ms=2.2, color=COLORS["measured"], label="measured")
        ax.plot(recs.time, recs.convert("y", i, result.yhat[:, i]), color=COLORS["model"],
                label=model_label(result))
        ax.set_ylabel(recs.label("y", i))
    _legend_above(axes[nu], "right", ncols=2)
    _time_axis(axes, recs)


def _draw_residuals(axes, result, recs):
    sigma = np.sqrt(np.clip(np.diag(result.rhat), 0, None))
    res = result.residuals
    for i, ax in enumerate(axes):
        _, scale, _ = _display(recs.first, "y", i)
        band = 2 * sigma[i] / abs(scale)
        ax.axhspan(-band, band, color=COLORS["band"], alpha=0.12, lw=0,
                   label=f"±2σ ({noise_symbol(result)})")
        ax.plot(recs.time, recs.convert("y", i, res[:, i], difference=True),
                color=COLORS["residual"], lw=0.8)
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_ylabel(axis_label(f"Δ{recs.names('y')[i]}",
                                 _display(recs.first, "y", i)[0]))
        outside = np.mean(np.abs(res[:, i]) > 2 * sigma[i]) if sigma[i] > 0 else np.nan
        ax.set_title(f"{100 * outside:.1f}% outside ±2σ", loc="right", fontsize=7.5,
                     color="0.35", pad=2)
    _legend_above(axes[0], "left")
    _time_axis(axes, recs)


@_styled
def outputs(result, path=None):
    """Measured and model outputs, under the inputs, against time.

    Parameters
    ----------
    result : FitResult
        A fit (one manoeuvre or several; joins are not bridged).
    path : str or Path, optional
        Also write the figure there.

    Returns
    -------
    matplotlib.figure.Figure
        nu + ny axes sharing the time axis: the inputs, then each output.
    """
    recs = _Records.of_result(result)
    n = len(drawn_inputs(result.data)) + result.data.y.shape[1]
    fig, axes = _figure(n, 1, 7.5, 1.35, sharex=True)
    _draw_outputs(fig, axes[:, 0], result, recs)
    fig.suptitle(outputs_title(result), fontsize=10)
    return _finish(fig, path)


@_styled
def residuals(result, path=None):
    """Residuals (measured minus model) per output with the ±2σ band, σ the
    square root of the diagonal of R̂ (of B̂, the innovation covariance, for
    filter error: ``noise_symbol``).

    Parameters
    ----------
    result : FitResult
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        ny axes sharing the time axis.
    """
    recs = _Records.of_result(result)
    fig, axes = _figure(result.data.y.shape[1], 1, 7.5, 1.25, sharex=True)
    _draw_residuals(axes[:, 0], result, recs)
    fig.suptitle("residuals with ±2σ bands", fontsize=10)
    return _finish(fig, path)


@_styled
def frequency_overview(result, path=None):
    """A frequency-domain fit: for each output the magnitude of the measured
    transform (or equation error's left-hand side) and the model's against
    frequency, and of their difference: the figure ``plot_fit`` writes for it.

    Returns
    -------
    matplotlib.figure.Figure
        One axis per output.
    """
    ny = result.z.shape[1]
    fig, axes = _figure(ny, 1, 6.5, 1.6, sharex=True)
    f = np.asarray(result.frequencies)
    # one block of frequencies per manoeuvre, each drawn on its own (no line
    # zigzags between two manoeuvres' transforms)
    blocks = np.split(np.arange(len(f)), np.flatnonzero(np.diff(f) <= 0) + 1)
    names, units = _transform_names(result, ny)
    for i, ax in enumerate(axes[:, 0]):
        for k, b in enumerate(blocks):
            which = f" (manoeuvre {k + 1})" if len(blocks) > 1 else ""
            style = ("-", "--", ":", "-.")[k % 4]
            ax.semilogy(f[b], np.abs(result.z[b, i]), ".", ms=3, color=COLORS["measured"],
                        label="measured" if k == 0 else None)
            ax.semilogy(f[b], np.abs(result.zhat[b, i]), style, color=COLORS["model"], lw=1,
                        label=f"model{which}")
            ax.semilogy(f[b], np.abs(result.residuals[b, i]), style, color=COLORS["residual"],
                        lw=0.8, label=f"residual{which}")
        ax.set_ylabel(axis_label(f"|{names[i]}|", units[i]))
    axes[-1, 0].set_xlabel("frequency [Hz]")
    _figure_legend(fig, axes[0, :1])
    equation = result.options["method"] == "frequency_equation_error"
    fig.suptitle(f"{result.options['method'].replace('_', ' ')}: finite Fourier transforms"
                 + ("\nleft-hand sides Z: jωY of an output that measures a state, else Y"
                    if equation else " of the outputs, core units"), fontsize=10)
    return _finish(fig, path)


def _transform_names(result, n):
    """Names and units of the n transforms of a frequency-domain fit, one
    per output: Y, in the output's core unit times s (output error); the
    left-hand side, jω Y or Y, unit not stated (equation error)."""
    names = list(result.data.output_names)
    names = names if len(names) == n else [f"y{k + 1}" for k in range(n)]
    if result.options["method"] == "frequency_equation_error":
        return [f"Z {name}" for name in names], [""] * n
    units = list(result.data.output_units or [""] * n)
    units = units if len(units) == n else [""] * n
    return [f"Y {name}" for name in names], [f"{_grouped(u)}·s" if u else "" for u in units]


def fit_overview(result, path=None, title=None):
    """Outputs (with the inputs) on the left, residuals on the right, rows
    aligned per output, the estimates with their sigma beside the inputs,
    under a title naming the case (``title``) or the record: the figure
    ``plot_fit`` writes (``frequency_overview`` for a frequency-domain fit).

    Returns
    -------
    matplotlib.figure.Figure
        nu + ny axes on the left; on the right the estimates (when there
        are inputs) and ny residual axes.
    """
    import matplotlib.pyplot as plt
    if getattr(result, "frequencies", None) is not None:
        return frequency_overview(result, path)
    recs = _Records.of_result(result)
    nu, ny = len(drawn_inputs(result.data)), result.data.y.shape[1]
    fig = plt.figure(figsize=(12, 1.3 * (nu + ny) + 1.0), layout="constrained")
    fig.suptitle(title or getattr(result.data, "source", "") or "fit", fontsize=11)
    left, right = fig.subfigures(1, 2, width_ratios=[1.15, 1])
    la = left.subplots(nu + ny, 1, sharex=True, squeeze=False)[:, 0]
    ra = right.subplots(nu + ny, 1, sharex=True, squeeze=False)[:, 0]
    _draw_outputs(left, la, result, recs)
    for ax in ra[1:nu]:
        ax.remove()
    if nu:
        _estimates_text(ra[0], result, lines=max(3, int(nu * 1.3 * 72 / 11)))
    _draw_residuals(ra[nu:], result, recs)
    left.suptitle(outputs_title(result), fontsize=10)
    right.suptitle(f"residuals with ±2σ bands (σ from {noise_symbol(result)})",
                   fontsize=10)
    return _finish(fig, path)


def _estimates_text(ax, result, lines):
    """The estimates with their Cramér-Rao sigma and unit, as many as the
    axis has lines for (the rest counted), in the place the inputs leave."""
    ax.axis("off")
    units = getattr(result, "param_units", None) or [""] * len(result.names)
    rows = [f"{n[:16]:<16} {e: .4g} ± {s:.2g} {u}" for n, e, s, u in
            zip(result.names, result.estimate, result.sigma, units)]
    if len(rows) > lines - 1:
        rows = rows[:lines - 2] + [f"... {len(rows) - (lines - 2)} more (the results table)"]
    ax.text(0.0, 1.0, "\n".join(["estimate ± 1σ (Cramér-Rao)"] + rows), va="top",
            ha="left", family="monospace", fontsize=8, transform=ax.transAxes)


def _write_into(draw, obj, folder, name):
    """Draw obj into FOLDER/NAME (whole or not at all), release the figure,
    return the path."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    close(draw(obj, folder / name))
    return folder / name


def plot_fit(result, folder, stem, title=None):
    """Write FOLDER/STEM_fit.png (``fit_overview``, under title) and return
    its path."""
    path = Path(folder) / f"{stem}_fit.png"
    Path(folder).mkdir(parents=True, exist_ok=True)
    close(fit_overview(result, path, title=title))
    return path


def _under(title, draw):
    """draw(result, path) with title (naming the case) above its own title."""
    def drawn(result, path):
        fig = draw(result)
        if title:
            own = fig.get_suptitle()
            fig.suptitle(f"{title}\n{own}" if own else title, fontsize=10)
        return _finish(fig, path)
    return drawn


def plot_residual_input(result, folder, stem, title=None):
    """Write FOLDER/STEM_residual_input.png (``residual_input``, under
    title) and return its path."""
    return _write_into(_under(title, residual_input), result, folder,
                       f"{stem}_residual_input.png")


def plot_measured_vs_model(result, folder, stem, title=None):
    """Write FOLDER/STEM_measured_vs_model.png (``measured_vs_model``, under
    title) and return its path."""
    return _write_into(_under(title, measured_vs_model), result, folder,
                       f"{stem}_measured_vs_model.png")


def plot_bode(result, folder, stem, title=None):
    """Write FOLDER/STEM_bode.png (``bode``, under title) and return its path."""
    return _write_into(_under(title, bode), result, folder, f"{stem}_bode.png")


def time_domain(result):
    """Whether result is a time-domain fit (its residuals are time series)."""
    return getattr(result, "frequencies", None) is None


def inputs_move(result):
    """A time-domain fit with an input that varies (one to correlate with)."""
    return time_domain(result) and bool(drawn_inputs(result.data))


def linear_model(result):
    """Whether the fitted model is linear (it has modes and a Bode plot)."""
    return getattr(result.model, "kind", None) == 1


def fit_writers(result):
    """The figures a fit's plots are, as functions (result, folder, stem,
    title) writing each and returning its path: the overview
    (``plot_fit``); for a time-domain fit the measured-vs-model cross-plots
    and, when an input varies, the residual-input correlation; for a linear
    model the Bode plot.  ``mlid run --plots`` writes them all."""
    writers = [plot_fit]
    if time_domain(result):
        writers.append(plot_measured_vs_model)
    if inputs_move(result):
        writers.append(plot_residual_input)
    if linear_model(result):
        writers.append(plot_bode)
    return writers


def plot_fit_figures(result, folder, stem, title=None):
    """Write every figure of ``fit_writers`` into FOLDER as STEM_*.png and
    return their paths."""
    return [write(result, folder, stem, title) for write in fit_writers(result)]


def plot_online_history(estimate, folder, stem):
    """Write FOLDER/STEM_online.png (``online_history``) and return its path."""
    return _write_into(lambda e, path: online_history(e, path=path), estimate, folder,
                       f"{stem}_online.png")


def plot_validation(v, folder, stem):
    """Write FOLDER/STEM_validation.png (``validation``) and return its path."""
    return _write_into(validation, v, folder, f"{stem}_validation.png")


# -- residual statistics ------------------------------------------------------

def _max_lag(lags, n):
    """The largest lag in samples: lags, else N/10 between 10 and 50; below N."""
    return int(min(lags or max(10, min(50, n // 10)), n - 1))


def residual_autocorrelation(result, lags=None):
    """Autocorrelation of each output's residuals at lags 0..lags, summed
    within each manoeuvre (no product spans a join), normalised by lag 0.

    Returns
    -------
    (lag times (lags+1,) in s, rho (lags+1, ny), band 1.96/sqrt(N))
    """
    recs = _Records.of_result(result)
    e = result.residuals - result.residuals.mean(axis=0)
    n = len(e)
    lags = _max_lag(lags, n)
    num = np.zeros((lags + 1, e.shape[1]))
    for seg in recs.segments():
        s = e[seg]
        for k in range(min(lags + 1, len(s))):
            num[k] += np.sum(s[k:] * s[:len(s) - k], axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = num / num[0]
    return np.arange(lags + 1) * recs.dt, rho, 1.96 / np.sqrt(n)


@_styled
def autocorrelation(result, lags=None, path=None):
    """Residual autocorrelation per output against lag [s], with the
    ±1.96/sqrt(N) band white residuals stay inside 95% of the time.

    Parameters
    ----------
    result : FitResult
    lags : int, optional
        Largest lag in samples (default N/10, between 10 and 50).
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axis per output.
    """
    tau, rho, band = residual_autocorrelation(result, lags)
    fig, axes, ncols = _panels(rho.shape[1])
    for i, ax in enumerate(axes):
        ax.axhspan(-band, band, color=COLORS["band"], alpha=BAND_ALPHA, lw=0,
                   label="±1.96/√N (95%)")
        ax.vlines(tau, 0, rho[:, i], color=COLORS["residual"], lw=1.4)
        ax.plot(tau, rho[:, i], "o", ms=2.5, color=COLORS["residual"], label="ρ(τ)")
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_title(result.data.output_names[i])
        ax.set_ylabel("autocorrelation [-]")
        ax.set_ylim(min(-2.5 * band, np.nanmin(rho[:, i]) - 0.05), 1.05)
    _bottom_labels(axes, ncols, "lag [s]")
    _figure_legend(fig, axes[:1])
    fig.suptitle(f"residual autocorrelation, ±1.96/√N band (N = {len(result.residuals)})",
                 fontsize=10)
    return _finish(fig, path)


def cross_correlation(e, u, lags, segments=None):
    """Normalised cross-correlation of each column of e with each of u at
    lags -lags..lags (samples):

        r(τ) = Σ e(t + τ) u(t) / √(Σ e² Σ u²),

    each signal less its mean within each segment, every sum within each
    segment (no product spans a join; scipy.signal.correlate).  τ > 0: e
    after u.  Independent e and u, one of them white, keep r within
    ±1.96/√N at about 95% of the lags.

    Parameters
    ----------
    e : array (N, ne)
    u : array (N, nu)
    lags : int
    segments : list of slice, optional
        The manoeuvres (default: one).

    Returns
    -------
    r : ndarray (2 lags + 1, ne, nu)
    """
    from scipy.signal import correlate, correlation_lags

    e, u = np.asarray(e, dtype=float), np.asarray(u, dtype=float)
    num = np.zeros((2 * lags + 1, e.shape[1], u.shape[1]))
    see, suu = np.zeros(e.shape[1]), np.zeros(u.shape[1])
    for seg in segments or [slice(0, len(e))]:
        es, us = e[seg] - e[seg].mean(axis=0), u[seg] - u[seg].mean(axis=0)
        lag = correlation_lags(len(es), len(us))
        keep = np.abs(lag) <= lags
        for i in range(es.shape[1]):
            for c in range(us.shape[1]):
                num[lag[keep] + lags, i, c] += correlate(es[:, i], us[:, c])[keep]
        see += np.sum(es ** 2, axis=0)
        suu += np.sum(us ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / np.sqrt(see[None, :, None] * suu[None, None, :])


def residual_input_correlation(result, lags=None):
    """``cross_correlation`` of each output's residuals with each input
    that varies (``drawn_inputs``), within each manoeuvre.  τ > 0: the
    residual after the input (what the model misses of the input's
    effect); τ < 0: before it (feedback from the output to the input).

    Parameters
    ----------
    result : FitResult
        A time-domain fit.
    lags : int, optional
        The largest lag in samples (default N/10, between 10 and 50).

    Returns
    -------
    (lag times (2L+1,) in s, r (2L+1, ny, nd), input indices (nd,), band 1.96/√N)

    Raises
    ------
    InputError
        If the fit is of the frequency domain.
    """
    if getattr(result, "frequencies", None) is not None:
        raise InputError("the residual-input correlation needs a time-domain fit")
    recs = _Records.of_result(result)
    inputs = drawn_inputs(recs.records)
    n = len(result.residuals)
    big = _max_lag(lags, n)
    r = cross_correlation(result.residuals, np.asarray(result.data.u)[:, inputs], big,
                          recs.segments())
    return np.arange(-big, big + 1) * recs.dt, r, inputs, 1.96 / np.sqrt(n)


@_styled
def residual_input(result, lags=None, path=None):
    """The residual-input cross-correlation (MATLAB ``resid``'s second
    panel): for each output's residual and each input that varies, r(τ) of
    ``residual_input_correlation`` against lag [s], with the ±1.96/√N band
    (95%) that independent residuals and inputs stay within.

    Parameters
    ----------
    result : FitResult
        A time-domain fit with at least one input that varies.
    lags : int, optional
        Largest lag in samples (default N/10, between 10 and 50).
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axis per output (rows) and input (columns).

    Raises
    ------
    InputError
        A frequency-domain fit, or no input that varies.
    """
    tau, r, inputs, band = residual_input_correlation(result, lags)
    if not inputs:
        raise InputError("the residual-input correlation needs an input that varies")
    recs = _Records.of_result(result)
    ny, nd = r.shape[1:]
    fig, axes = _figure(ny, nd, max(6.0, 3.6 * nd), 1.55, sharex=True, sharey=True)
    for i in range(ny):
        for c, j in enumerate(inputs):
            ax = axes[i, c]
            ax.axhspan(-band, band, color=COLORS["band"], alpha=BAND_ALPHA, lw=0,
                       label="±1.96/√N (95%)")
            ax.vlines(tau, 0, r[:, i, c], color=COLORS["residual"], lw=1.2)
            ax.plot(tau, r[:, i, c], "o", ms=2.2, color=COLORS["residual"], label="r(τ)")
            ax.axhline(0, color="0.5", lw=0.6)
            ax.axvline(0, color="0.5", lw=0.6)
            outside = np.mean(np.abs(r[:, i, c]) > band)
            ax.set_title(f"Δ{recs.names('y')[i]} × {recs.names('u')[j]}", loc="left")
            ax.set_title(f"{100 * outside:.0f}% outside", loc="right", fontsize=7.5,
                         color="0.35")
        axes[i, 0].set_ylabel("r [-]")
    for c in range(nd):
        axes[-1, c].set_xlabel("lag τ [s]  (τ > 0: residual after input)")
    lim = max(2.5 * band, 1.1 * np.nanmax(np.abs(r)))
    axes[0, 0].set_ylim(-lim, lim)
    _figure_legend(fig, axes.flat)
    fig.suptitle("residual-input cross-correlation, band ±1.96/√N (95%), "
                 f"N = {len(result.residuals)}\nr(τ) = Σ e(t+τ) u(t) / √(Σe² Σu²), "
                 "each manoeuvre less its means", fontsize=10)
    return _finish(fig, path)


def fit_statistics(result):
    """R² and MATLAB's fit percentage of each output of a time-domain fit:
    R² = 1 - Σ(y - ŷ)² / Σ(y - ȳ)², fit = 100 (1 - ‖y - ŷ‖ / ‖y - ȳ‖);
    y measured, ŷ the model's (the filter's for filter error), ȳ the
    mean over the record (all manoeuvres).

    Returns
    -------
    (R² (ny,), fit [%] (ny,))
    """
    require_estimates(result, "plot")
    y, yhat = np.asarray(result.data.y), np.asarray(result.yhat)
    ss_res = np.sum((y - yhat) ** 2, axis=0)
    ss_tot = np.sum((y - y.mean(axis=0)) ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return 1 - ss_res / ss_tot, 100 * (1 - np.sqrt(ss_res / ss_tot))


@_styled
def measured_vs_model(result, path=None):
    """Measured against model output, one square panel per output in its
    declared unit, with the 1:1 line and R² and fit % (``fit_statistics``)
    in the panel's title.

    Parameters
    ----------
    result : FitResult
        A time-domain fit.
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axis per output.
    """
    if getattr(result, "frequencies", None) is not None:
        raise InputError("measured-vs-model cross-plots need a time-domain fit")
    recs = _Records.of_result(result)
    r2, fit = fit_statistics(result)
    ny = result.data.y.shape[1]
    ncols = ny if ny <= 3 else int(np.ceil(np.sqrt(ny)))
    nrows = (ny + ncols - 1) // ncols
    fig, grid = _figure(nrows, ncols, 3.3 * ncols, 3.1)
    for ax in list(grid.flat)[ny:]:
        ax.remove()
    who = model_label(result)
    for i, ax in enumerate(list(grid.flat)[:ny]):
        x, unit = recs.shown("y", i)
        y = recs.convert("y", i, result.yhat[:, i])
        ok = np.isfinite(x) & np.isfinite(y)
        ax.plot(x[ok], y[ok], ".", ms=2.0, alpha=0.6, color=COLORS["model"],
                label=f"samples (N = {int(ok.sum())})")
        lo, hi = min(x[ok].min(), y[ok].min()), max(x[ok].max(), y[ok].max())
        pad = 0.05 * (hi - lo or 1.0)
        ends = [lo - pad, hi + pad]
        ax.plot(ends, ends, "--", color=COLORS["truth"], lw=0.9, label="1:1")
        ax.set_xlim(ends)
        ax.set_ylim(ends)
        ax.set_aspect("equal")
        name = recs.names("y")[i]
        ax.set_xlabel(axis_label(f"measured {name}", unit))
        ax.set_ylabel(axis_label(f"{who} {name}", unit))
        ax.set_title(f"{name}: R² = {r2[i]:.3f}, fit {fit[i]:.1f}%", loc="left")
    _figure_legend(fig, grid.flat[:1])
    fig.suptitle(f"measured against {who} output\nR² = 1 - Σ(y - ŷ)² / Σ(y - ȳ)², "
                 "fit = 100 (1 - ‖y - ŷ‖ / ‖y - ȳ‖) %", fontsize=10)
    return _finish(fig, path)


def residual_spectra(result, segment=None):
    """Power spectral density of each output's residuals in its declared unit
    (Welch: Hann windows of ``segment`` samples, half overlapping, within
    each manoeuvre; one-sided).

    Returns
    -------
    (frequencies (nf,) in Hz, psd (nf, ny) in unit^2/Hz)
    """
    recs = _Records.of_result(result)
    e = result.residuals
    shortest = min(s.stop - s.start for s in recs.segments())
    m = int(segment or min(256, max(32, shortest // 4)))
    m = max(8, min(m, shortest))
    from scipy.signal import welch

    acc, count = np.zeros((m // 2 + 1, e.shape[1])), 0
    for seg in recs.segments():     # each manoeuvre's windows, averaged over all of them
        s = e[seg] - e[seg].mean(axis=0)
        windows = (len(s) - m) // (m // 2) + 1
        _, p = welch(s, fs=1.0 / recs.dt, window=np.hanning(m), noverlap=m - m // 2,  # hop m//2
                     detrend=False,
                     axis=0)
        acc += windows * p
        count += windows
    psd = acc / count
    scales = np.array([_display(recs.first, "y", i)[1] for i in range(e.shape[1])])
    return np.fft.rfftfreq(m, recs.dt), psd / scales ** 2


@_styled
def spectra(result, segment=None, path=None):
    """Residual power spectra per output against frequency [Hz], with the
    level of white noise of the same variance (R̂, B̂ for filter error) dashed.

    Parameters
    ----------
    result : FitResult
    segment : int, optional
        Samples per Welch window (default up to 256).
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axis per output.
    """
    recs = _Records.of_result(result)
    f, psd = residual_spectra(result, segment)
    fig, axes, ncols = _panels(psd.shape[1])
    for i, ax in enumerate(axes):
        unit, scale, _ = _display(recs.first, "y", i)
        white = 2 * result.rhat[i, i] * recs.dt / scale ** 2
        ax.semilogy(f[1:], psd[1:, i], color=COLORS["residual"], lw=1.0)
        ax.axhline(white, color=COLORS["band"], ls="--", lw=0.9, label="white, same variance")
        ax.set_title(recs.names("y")[i], loc="left")
        ax.set_ylabel(axis_label("PSD", psd_unit(unit)))
        ax.set_xlim(0, f[-1])
        _decades(ax, LOG_DECADES)
    _legend_above(axes[0], "right")
    _bottom_labels(axes, ncols, "frequency [Hz]")
    fig.suptitle("residual power spectra (Welch, Hann)", fontsize=10)
    return _finish(fig, path)


# -- estimates -----------------------------------------------------------------

@_styled
def correlation(result, path=None):
    """The correlation matrix of the estimates (Cramér-Rao) as a heat map,
    values written in the cells when there are 16 parameters or fewer.

    Returns
    -------
    matplotlib.figure.Figure
        The map and its colour bar.
    """
    require_estimates(result, "plot")
    c = result.correlation
    names = list(result.names)
    n = len(names)
    size = min(9.0, 2.2 + 0.42 * n)
    fig, axes = _figure(1, 1, size + 1.0, size - 0.7)
    ax = axes[0, 0]
    im = ax.imshow(c, cmap="RdBu_r", vmin=-1, vmax=1)
    ax.set_xticks(range(n), names, rotation=50, ha="right", rotation_mode="anchor")
    ax.set_yticks(range(n), names)
    ax.grid(False)
    ax.spines[:].set_visible(False)
    if n <= 16:
        for i in range(n):
            for j in range(n):
                ax.text(j, i, f"{c[i, j]:.2f}", ha="center", va="center",
                        fontsize=7 if n > 8 else 8,
                        color="white" if abs(c[i, j]) > 0.6 else "black")
    fig.colorbar(im, ax=ax, shrink=0.85, label="correlation [-]")
    ax.set_title("correlation of the estimates (Cramér-Rao)")
    return _finish(fig, path)


# -- linear models: modes and frequency response -------------------------------

def state_space(model):
    """A, B, C, D of a linear model (the LinearModel with its state feedback
    K closed: A = F + G K, B = G, C = H + D K, D).

    Raises
    ------
    InputError
        If the model is not linear.
    """
    if getattr(model, "kind", None) != 1:
        raise InputError(f"modes and frequency responses need a linear model, got "
                         f"{type(model).__name__}")
    F, G, H, D, K = model.F, model.G, model.H, model.D, model.K
    return F + G @ K, G, H + D @ K, D


def modes(model):
    """Eigenvalues of A with natural frequency and damping ratio.

    Returns
    -------
    list of dict
        Per eigenvalue (one of each complex pair, positive imaginary part):
        ``eigenvalue``, ``omega_n`` [rad/s], ``f_n`` [Hz], ``zeta`` [-] and
        ``time_constant`` [s] (1/|re| for a real eigenvalue, else None).
    """
    lam = np.linalg.eigvals(state_space(model)[0])
    rows = []
    for z in sorted(lam[lam.imag >= 0], key=lambda z: (abs(z), z.imag)):
        wn = abs(z)
        real = abs(z.imag) <= 1e-12 * max(wn, 1.0)
        rows.append({"eigenvalue": complex(z), "omega_n": float(wn),
                     "f_n": float(wn / (2 * np.pi)),
                     "zeta": float(-z.real / wn) if wn > 0 else float("nan"),
                     "time_constant": float(1 / abs(z.real)) if real and z.real != 0 else None})
    return rows


def _free_positions(result, model):
    """Positions in model.theta of the result's free parameters that the model
    shares (a manoeuvre's own x0 and bias are left out), with their index in
    result.estimate."""
    labels = [model.names.get(e, e) for e in model.element_names()]
    pos, idx = [], []
    for k, name in enumerate(result.names):
        if name in labels:
            pos.append(labels.index(name))
            idx.append(k)
    return np.array(pos, dtype=int), np.array(idx, dtype=int)


def sampled_models(result, samples=BAND_SAMPLES, seed=BAND_SEED):
    """Models with the free parameters drawn from N(estimate, Cramér-Rao
    covariance), seeded; tied parameters follow their ties (affine ones too)."""
    require_estimates(result, "plot")
    model = result.model
    pos, idx = _free_positions(result, model)
    cov = np.asarray(result.covariance)[np.ix_(idx, idx)]
    draws = np.random.default_rng(seed).multivariate_normal(
        np.asarray(result.estimate)[idx], cov, size=samples, method="eigh")
    terms = model.tie_terms()
    out = []
    for d in draws:
        theta = model.theta
        theta[pos] = d
        out.append(model.with_theta(model.tied(theta, terms)))
    return out


def _frequencies(model, hz, dt, measured=None):
    """A decade below the slowest mode to a decade above the fastest, at
    most the Nyquist frequency of the record, widened to the measured
    frequencies given (rad/s): (rad/s, axis values)."""
    wn = [r["omega_n"] for r in modes(model) if r["omega_n"] > 0] or [1.0]
    lo, hi = min(wn) / 10, min(max(wn) * 10, np.pi / dt)
    if measured is not None:
        lo, hi = min(lo, measured[0]), max(hi, measured[-1])
    omega = np.logspace(np.log10(lo), np.log10(max(hi, 10 * lo)), 300)
    return omega, (omega / (2 * np.pi) if hz else omega)


def _on_branch(phase, f, f_ref, phase_ref):
    """phase [deg] at f moved by whole turns onto the branch of phase_ref at
    f_ref (the same complex response, drawn beside the model's curve)."""
    return phase - 360 * np.round((phase - np.interp(f, f_ref, phase_ref)) / 360)


def _record_responses(recs, inputs, ny):
    """The record's response of every output to each input given (None
    where the record has none: too short, or not uniformly sampled), and
    the reason when there is none."""
    try:
        return [[record_response(recs.records, j, i) for j in inputs] for i in range(ny)], None
    except InputError as exc:
        return None, str(exc)


def bode_data(result, hz=True, measured=True):
    """Gain [dB] and phase [deg] of the identified model per input-output
    pair in the declared units of the channels, with their Cramér-Rao σ
    (``mlid.model_response``: the delta method on the core's analytic
    derivatives, the channels' delays included), and the record's response
    (``mlid.record_response``) with its random-error σ (Bendat & Piersol).
    Constant inputs are left out (``drawn_inputs``).  The record's response
    of a pair is the single-input one, G_uy / G_uu: where several inputs
    move together it carries the others' effect too (the model's does not).

    Parameters
    ----------
    result : FitResult
        A fit of a LinearModel.
    hz : bool
        Frequencies in Hz (default) or rad/s.
    measured : bool
        Also the record's response.

    Returns
    -------
    dict
        ``freq`` (nω,) and ``unit`` ('Hz' or 'rad/s'); ``inputs`` (the
        model's input indices drawn, nd); ``mag``, ``phase``, ``mag_sigma``,
        ``phase_sigma`` (nω, ny, nd); ``mag_band``, ``phase_band`` (2, nω,
        ny, nd): value ∓ BAND_SIGMAS σ; ``measured``: None, or a dict of
        ``freq`` (nf,), ``mag``, ``phase`` (on the model's branch),
        ``mag_sigma``, ``phase_sigma``, ``coherence`` (nf, ny, nd),
        ``averages`` and ``segment``; ``measured_error``: why there is no
        record response, or None.

    Raises
    ------
    InputError
        If the model is not linear or the fit failed.
    """
    state_space(result.model)
    recs = _Records.of_result(result)
    inputs = drawn_inputs(recs.records)
    ny = result.model.ny
    rec, why = _record_responses(recs, inputs, ny) if measured else (None, None)
    omega, freq = _frequencies(result.model, hz, recs.dt,
                               2 * np.pi * rec[0][0].frequency if rec else None)
    fhz = omega / (2 * np.pi)
    shape = (len(omega), ny, len(inputs))
    out = {k: np.zeros(shape) for k in ("mag", "phase", "mag_sigma", "phase_sigma")}
    m = None
    if rec:
        nf = len(rec[0][0].frequency)
        m = {k: np.zeros((nf, ny, len(inputs))) for k in
             ("mag", "phase", "mag_sigma", "phase_sigma", "coherence")}
        m.update(freq=rec[0][0].frequency * (1 if hz else 2 * np.pi),
                 averages=rec[0][0].averages, segment=rec[0][0].segment)
    for i in range(ny):
        for c, j in enumerate(inputs):
            shift = _declared_db(recs.first, j, i)[0]
            r = model_response(result, fhz, j, i)
            out["mag"][:, i, c], out["phase"][:, i, c] = r.gain + shift, r.phase
            out["mag_sigma"][:, i, c], out["phase_sigma"][:, i, c] = r.sigma_gain, r.sigma_phase
            if m is not None:
                g = rec[i][c]
                m["mag"][:, i, c] = g.gain + shift
                m["phase"][:, i, c] = _on_branch(g.phase, g.frequency, fhz, r.phase)
                m["mag_sigma"][:, i, c], m["phase_sigma"][:, i, c] = g.sigma_gain, g.sigma_phase
                m["coherence"][:, i, c] = g.coherence
    for key in ("mag", "phase"):
        k_sigma = BAND_SIGMAS * out[f"{key}_sigma"]
        out[f"{key}_band"] = np.stack([out[key] - k_sigma, out[key] + k_sigma])
    return {"freq": freq, "unit": "Hz" if hz else "rad/s", "inputs": inputs, **out,
            "measured": m, "measured_error": why}


def _draw_band(ax, f, y, sigma, unit):
    """The model's curve and its ±BAND_SIGMAS σ Cramér-Rao band (y and sigma
    in unit): filled, edged in the curve's colour, its widest half stated
    above the axis."""
    k = BAND_SIGMAS * np.asarray(sigma)
    ax.plot(f, y, color=COLORS["model"], label="identified model")
    ax.fill_between(f, y - k, y + k, facecolor=COLORS["band"], alpha=BAND_ALPHA,
                    edgecolor=COLORS["model"], lw=0.7, label=band_label("model", "Cramér-Rao"))
    # a band can be too narrow to see: its widest half, stated
    ax.set_title(f"±{BAND_SIGMAS}σ ≤ {np.nanmax(k):.2g} {unit}", loc="right", fontsize=7.5,
                 color="0.35", pad=2)


def _draw_measured(ax, f, y, sigma, coherence):
    """The record's response: where the coherence is at least
    COHERENCE_SHOWN, filled points with ±BAND_SIGMAS σ error bars (the
    random error); below it, hollow grey points without (Bendat & Piersol's
    error holds for small errors only, and bars of tens of dB would hide
    the rest)."""
    good = np.asarray(coherence) >= COHERENCE_SHOWN
    if good.any():
        ax.errorbar(f[good], y[good], yerr=BAND_SIGMAS * np.asarray(sigma)[good], fmt="o",
                    ms=2.8, color=COLORS["measured"], elinewidth=0.7, capsize=1.8,
                    label=band_label("measured", "random error"))
    if not good.all():
        ax.plot(f[~good], y[~good], "o", ms=2.8, mfc="none", mew=0.6, color="0.6",
                label=f"measured, γ² < {COHERENCE_SHOWN} (no bar)")


def _limits(ax, band, y=None, sigma=None, coherence=None):
    """y limits that hold the model's band (2, n), every measured point y
    and the error bars drawn (``_draw_measured``): 5% margin."""
    values = [np.ravel(band)]
    if y is not None:
        good = np.asarray(coherence) >= COHERENCE_SHOWN
        k = BAND_SIGMAS * np.asarray(sigma)
        values += [y, y[good] - k[good], y[good] + k[good]]
    v = np.concatenate(values)
    v = v[np.isfinite(v)]
    lo, hi = v.min(), v.max()
    pad = 0.05 * (hi - lo or 1.0)
    ax.set_ylim(lo - pad, hi + pad)


@_styled
def bode(result, hz=True, measured=True, path=None):
    """Bode plot of a linear identified model per input-output pair
    (constant inputs left out): gain [dB] and phase [deg] against frequency
    with the model's ±2σ Cramér-Rao band, and the record's response with
    ±2σ random-error bars (``bode_data``; BAND_SIGMAS σ, stated in the
    legend).

    Parameters
    ----------
    result : FitResult
        A fit of a LinearModel.
    hz : bool
        Frequency axis in Hz (default) or rad/s.
    measured : bool
        Also draw the record's response.
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        2 ny rows (gain, phase) by one column per drawn input.

    Raises
    ------
    InputError
        If the model is not linear.
    """
    b = bode_data(result, hz, measured)
    recs = _Records.of_result(result)
    ny, nd = b["mag"].shape[1:]
    m = b["measured"]
    fig, axes = _figure(2 * ny, nd, max(6.8, 4.8 * nd + 0.6), 1.35, sharex=True)
    for c, j in enumerate(b["inputs"]):
        for i in range(ny):
            am, ap = axes[2 * i, c], axes[2 * i + 1, c]
            ratio = unit_ratio(_display(recs.first, "y", i)[0], _display(recs.first, "u", j)[0])
            for ax, key in ((am, "mag"), (ap, "phase")):
                _draw_band(ax, b["freq"], b[key][:, i, c], b[f"{key}_sigma"][:, i, c],
                           "dB" if key == "mag" else "deg")
                shown = () if m is None else (m[key][:, i, c], m[f"{key}_sigma"][:, i, c],
                                              m["coherence"][:, i, c])
                if shown:
                    _draw_measured(ax, m["freq"], *shown)
                _limits(ax, b[f"{key}_band"][:, :, i, c], *shown)
                ax.set_xscale("log")
            am.set_ylabel("gain [dB]")
            ap.set_ylabel("phase [deg]")
            am.set_title(f"{recs.names('u')[j]} → {recs.names('y')[i]}"
                         + (f"  [{ratio}]" if ratio else ""), loc="left")
        axes[-1, c].set_xlabel(f"frequency [{b['unit']}]")
    _figure_legend(fig, axes.flat)
    said = (f"; record: {m['averages']} averages of {m['segment']} samples (Welch)"
            if m is not None else (f"; no record response: {b['measured_error']}"
                                   if b["measured_error"] else ""))
    fig.suptitle(f"frequency response of the identified model{said}", fontsize=9.5)
    return _finish(fig, path)


@_styled
def s_plane(result, samples=BAND_SAMPLES, seed=BAND_SEED, path=None):
    """Eigenvalues of A on the s-plane, with those of models drawn from the
    Cramér-Rao covariance as a cloud, and lines of constant damping.

    Returns
    -------
    matplotlib.figure.Figure
        One axis, real and imaginary parts in rad/s.
    """
    lam = np.linalg.eigvals(state_space(result.model)[0])
    cloud = np.concatenate([np.linalg.eigvals(state_space(m)[0])
                            for m in sampled_models(result, samples, seed)])
    fig, axes = _figure(1, 1, 5.6, 4.2)
    ax = axes[0, 0]
    ax.plot(cloud.real, cloud.imag, ".", ms=1.5, color=COLORS["band"], alpha=0.25,
            label=f"{samples} draws (CR)")
    ax.plot(lam.real, lam.imag, "x", ms=8, mew=2, color=COLORS["residual"], label="estimate")
    r = 1.15 * max(np.max(np.abs(lam)), 1e-3)
    for zeta in (0.1, 0.3, 0.5, 0.7, 0.9):
        a = np.arccos(zeta)
        ax.plot([0, -r * np.cos(a)], [0, r * np.sin(a)], color="0.75", lw=0.6)
        ax.plot([0, -r * np.cos(a)], [0, -r * np.sin(a)], color="0.75", lw=0.6)
        ax.text(-r * np.cos(a), r * np.sin(a), f"ζ={zeta}", fontsize=7, color="0.45",
                ha="center", va="bottom")
    ax.axhline(0, color="0.5", lw=0.6)
    ax.axvline(0, color="0.5", lw=0.6)
    ax.set_xlabel("real part [rad/s]")
    ax.set_ylabel("imaginary part [rad/s]")
    ax.set_title("modes of the identified model (eigenvalues of A)")
    ax.legend(loc="lower left", frameon=False)
    return _finish(fig, path)


# -- Monte Carlo ----------------------------------------------------------------

@_styled
def monte_carlo_histograms(mc, cr_sigma=None, units=None, path=None):
    """Histograms of Monte Carlo estimates with the Cramér-Rao normal curve.

    Parameters
    ----------
    mc : dict
        What ``mlid.monte_carlo`` returns (estimates, information, status,
        names, truth); runs with status other than 0 are left out.
    cr_sigma : array, optional
        Cramér-Rao standard deviations (default: from the inverse of the
        runs' average information matrix).
    units : list of str, optional
        Unit of each parameter, for the axis labels.
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        One axis per parameter: density of the estimates, N(truth, σ_CR)
        overlaid, the truth and the sample mean marked.

    Raises
    ------
    InputError
        If no run succeeded.
    """
    ok = np.asarray(mc["status"]) == 0
    est = np.asarray(mc["estimates"])[ok]
    if len(est) == 0:
        raise InputError("no Monte Carlo run succeeded: nothing to plot")
    if cr_sigma is None:
        info = np.asarray(mc["information"])[ok].mean(axis=0)
        cr_sigma = np.sqrt(np.diag(np.linalg.pinv(info)))
    truth, names = np.asarray(mc["truth"]), list(mc["names"])
    n = len(names)
    ncols = min(3, n)
    fig, axes = _figure((n + ncols - 1) // ncols, ncols, 3.4 * ncols, 2.4)
    for k, ax in enumerate(axes.flat):
        if k >= n:
            ax.remove()
            continue
        x = est[:, k]
        ax.hist(x, bins="auto", density=True, color=COLORS["model"], alpha=0.45,
                edgecolor="white", lw=0.4, label=f"{len(x)} runs")
        s = cr_sigma[k]
        g = np.linspace(min(x.min(), truth[k] - 4 * s), max(x.max(), truth[k] + 4 * s), 200)
        ax.plot(g, np.exp(-0.5 * ((g - truth[k]) / s) ** 2) / (s * np.sqrt(2 * np.pi)),
                color=COLORS["residual"], label="N(truth, σ_CR)")
        ax.axvline(truth[k], color=COLORS["truth"], lw=1.0, label="truth")
        ax.axvline(x.mean(), color=COLORS["mean"], lw=1.0, ls="--", label="mean")
        ax.set_xlabel(axis_label(names[k], (units or [""] * n)[k]))
        ax.set_ylabel("density")
        ax.set_title(f"sample σ {x.std(ddof=1):.3g}, CR σ {s:.3g}", fontsize=8.5)
    axes.flat[0].legend(loc="upper left", frameon=False, fontsize=7)
    fig.suptitle("Monte Carlo estimates and the Cramér-Rao bound", fontsize=10)
    return _finish(fig, path)


# -- which input to fly -----------------------------------------------------------

@_styled
def input_ranking(ranking, path=None):
    """Which input to fly (``InputDesign.rank_inputs``): each candidate as
    scaled, one panel per input (left), and each unknown's Cramér-Rao σ
    under each candidate relative to the best-ranked one's (right, log
    scale: a bar above 1 is a worse σ).

    Parameters
    ----------
    ranking : InputRanking
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt
    nu = ranking.u.shape[2]
    fig = plt.figure(figsize=(10.0, max(3.4, 1.6 * nu + 0.7)), layout="constrained")
    grid = fig.add_gridspec(nu, 2, width_ratios=[1.0, 1.2])
    for j in range(nu):
        ax = fig.add_subplot(grid[j, 0])
        for k, name in enumerate(ranking.names):
            ax.stairs(ranking.u[k][:, j], ranking.t_edges, lw=1.0, label=f"{k + 1}. {name}")
        ax.set_ylabel(f"input {j + 1}")
        ax.set_xlim(ranking.t_edges[0], ranking.t_edges[-1])
    ax.set_xlabel("t [s]")
    ax.set_title(f"inputs at equal {ranking.compare} {ranking.level:.4g}", loc="left")
    ax.legend(fontsize=7, frameon=False, ncols=2)
    ax = fig.add_subplot(grid[:, 1])
    x = np.arange(len(ranking.unknowns))
    width = 0.8 / len(ranking)
    for k, name in enumerate(ranking.names):
        ax.bar(x + (k - (len(ranking) - 1) / 2) * width, ranking.sigma[k] / ranking.sigma[0],
               width, label=f"{k + 1}. {name}")
    ax.set_yscale("log")
    ax.axhline(1.0, color="0.4", lw=0.7)
    ax.set_xticks(x, ranking.unknowns)
    ax.set_ylabel(f"Cramér-Rao σ / σ of {ranking.names[0]}")
    by = "det M" if ranking.rank_by == "det" else "tr M"
    ax.set_title(f"σ of each unknown (ranked by {by})", loc="left")
    return _finish(fig, path)


# -- validation ---------------------------------------------------------------

@_styled
def validation(v, path=None):
    """Measured and predicted outputs of held-out manoeuvres (``mlid.validate``),
    under the inputs, with Theil's U and rms/σ of each output in its panel.

    Parameters
    ----------
    v : Validation
    path : str or Path, optional
        Also write the figure there.

    Returns
    -------
    matplotlib.figure.Figure
        nu + ny axes sharing the time axis; joins between held-out
        manoeuvres are not bridged.
    """
    result = v.prediction
    recs = _Records.of_result(result)
    nu = len(drawn_inputs(result.data))
    n = nu + result.data.y.shape[1]
    fig, axes = _figure(n, 1, 7.5, 1.35, sharex=True)
    _draw_outputs(fig, axes[:, 0], result, recs)
    for i, ax in enumerate(axes[nu:, 0]):
        ax.set_title(f"Theil U {v.theil[i]:.3f}   rms/σ {v.rms_over_sigma[i]:.2f}", loc="left",
                     fontsize=7.5, color="0.25", pad=2)
    axes[nu, 0].get_lines()[1].set_label("predicted")
    _legend_above(axes[nu, 0], "right", ncols=2)
    held = ", ".join(str(k) for k in v.holdout)
    fig.suptitle(f"validation: held-out manoeuvre{'s' * (len(v.holdout) > 1)} {held} "
                 "predicted by the identified model", fontsize=10)
    return _finish(fig, path)


def _declared_db(record, i, j):
    """dB to add to a gain of output j over input i in core units to have it
    in the declared units, and the ratio's unit ('(rad/s)/deg')."""
    uu, su, _ = _display(record, "u", i)
    uy, sy, _ = _display(record, "y", j)
    return 20 * np.log10(abs(su / sy)), unit_ratio(uy, uu)


@_styled
def bode_measured(result, input=0, output=0, measured=None, loes=None, frequencies=200,
                  path=None):
    """Bode plot of an identified linear model against the record's
    measured frequency response: gain and phase of the model with its ±2σ
    Cramér-Rao band (delta method, the core's analytic derivatives), the
    measured response as points with ±2σ random-error bars (Bendat &
    Piersol; hollow and grey where the coherence is below COHERENCE_SHOWN),
    its coherence in a third panel, and a
    fitted transfer function (LOES) when given.  Gains in dB of the
    declared units' ratio.

    Parameters
    ----------
    result : FitResult
        A fit of a LinearModel.
    input, output : str or int
        The pair, by channel name or index.
    measured : FrequencyResponse, optional
        The record's response (default: ``mlid.record_response`` of the
        fit's record, or of its manoeuvres together, for the pair).
    loes : TransferFunctionFit, optional
        Drawn over its frequency range.
    frequencies : int
        Points of the model's curve, log-spaced over the measured range.
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        Three axes sharing the frequency axis: gain, phase, coherence.
    """
    require_estimates(result, "plot")
    recs = _Records.of_result(result)
    if measured is None:
        measured = record_response(recs.records, input, output)
    i = recs.names("u").index(measured.input_name)
    j = recs.names("y").index(measured.output_name)
    f = measured.frequency
    fm = np.logspace(np.log10(f[0]), np.log10(f[-1]), int(frequencies))
    mod = model_response(result, fm, i, j)
    shift, ratio = _declared_db(recs.first, i, j)
    fig, axes = _figure(3, 1, 6.8, 1.6, sharex=True, height_ratios=[1.3, 1.3, 0.8])
    ag, ap, ac = axes[:, 0]
    mph = _on_branch(measured.phase, f, fm, mod.phase)
    for ax, y, ym, sm, s, unit in ((ag, measured.gain + shift, mod.gain + shift,
                                    mod.sigma_gain, measured.sigma_gain, "dB"),
                                   (ap, mph, mod.phase, mod.sigma_phase, measured.sigma_phase,
                                    "deg")):
        _draw_band(ax, fm, ym, sm, unit)
        _draw_measured(ax, f, y, s, measured.coherence)
        if loes is not None:
            fl = fm[(fm >= loes.frequency_range[0]) & (fm <= loes.frequency_range[1])]
            r = loes.response(fl)
            yl = r.gain + shift if ax is ag else _on_branch(r.phase, fl, fm, mod.phase)
            ax.plot(fl, yl, "--", color=COLORS["mean"], label=f"LOES ({loes.m}/{loes.n}"
                    + (", delay" if loes.has_delay else "") + ")")
        _limits(ax, [ym - BAND_SIGMAS * sm, ym + BAND_SIGMAS * sm], y, s, measured.coherence)
        ax.set_xscale("log")
    ac.plot(f, measured.coherence, "o", ms=2.5, color=COLORS["measured"])
    ac.axhline(COHERENCE_SHOWN, color="0.6", lw=0.7, ls=(0, (4, 3)))
    ac.set_ylim(0, 1.05)
    ag.set_ylabel("gain [dB]")
    ap.set_ylabel("phase [deg]")
    ac.set_ylabel("coherence γ²")
    ac.set_xlabel("frequency [Hz]")
    ag.set_title(f"{measured.input_name} → {measured.output_name}"
                 + (f"  [{ratio}]" if ratio else ""), loc="left")
    _figure_legend(fig, [ag, ap])
    fig.suptitle(f"frequency response: identified model and record ({measured.averages} "
                 f"averages of {measured.segment} samples)", fontsize=9.5)
    return _finish(fig, path)


@_styled
def online_history(estimate, batch=None, path=None, width=2.0):
    """An online estimator's history (``mlid.online``: rls, ftr, ekf,
    ukf): each parameter against time with its ±width σ band, the batch
    estimate beside it when given (a dashed line), and a dot where the
    estimate converged (from then on within width σ of its last value).

    Parameters
    ----------
    estimate : OnlineEstimate
    batch : dict or FitResult, optional
        The batch estimates by parameter name (a FitResult's estimate by
        name), drawn for comparison.
    path : str or Path, optional
    width : float
        The band's half-width in σ.

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = list(estimate.names)
    if batch is not None and hasattr(batch, "estimate") and hasattr(batch, "names"):
        batch = dict(zip(batch.names, np.asarray(batch.estimate).tolist()))
    converged = estimate.convergence_time(width)
    fig, axes, ncols = _panels(len(names))
    for ax, (j, name) in zip(axes, enumerate(names)):
        est, sig = estimate.estimates[:, j], estimate.sigma[:, j]
        ax.fill_between(estimate.t, est - width * sig, est + width * sig, alpha=0.25, lw=0)
        ax.plot(estimate.t, est, lw=1.0, label="online")
        if batch is not None and name in batch:
            ax.axhline(batch[name], color="k", ls="--", lw=0.8, label="batch")
        tc = converged[name]
        if np.isfinite(tc):
            k = int(np.searchsorted(estimate.t, tc))
            ax.plot([tc], [est[min(k, len(est) - 1)]], "o", ms=4, color="C3", label="converged")
        last, s = est[-1], sig[-1]
        if np.isfinite(last) and np.isfinite(s) and s > 0:
            ax.set_ylim(last - 10 * width * s, last + 10 * width * s)
        ax.set_title(name, loc="left", fontsize=9)
    _bottom_labels(axes, ncols, "t [s]")
    _figure_legend(fig, axes)
    return _finish(fig, path)
