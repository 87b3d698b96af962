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
#: Draws and seed of the Cramér-Rao band of the Bode plot.
BAND_SAMPLES, BAND_SEED = 300, 0


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
    order = np.argsort(result.frequencies, kind="stable")
    f = result.frequencies[order]
    for i, ax in enumerate(axes[:, 0]):
        ax.semilogy(f, np.abs(result.z[order, i]), ".", ms=3, color=COLORS["measured"],
                    label="measured")
        ax.semilogy(f, np.abs(result.zhat[order, i]), color=COLORS["model"], lw=1,
                    label="model")
        ax.semilogy(f, np.abs(result.residuals[order, i]), color=COLORS["residual"], lw=0.8,
                    label="residual")
        ax.set_ylabel(f"|Z_{i + 1}|")
    axes[-1, 0].set_xlabel("frequency (Hz)")
    axes[0, 0].legend(fontsize=7, ncol=3, loc="upper right")
    fig.suptitle(f"{result.options['method'].replace('_', ' ')}: transforms", fontsize=10)
    return _finish(fig, path)


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


def plot_validation(v, folder, stem):
    """Write FOLDER/STEM_validation.png (``validation``) and return its path."""
    return _write_into(validation, v, folder, f"{stem}_validation.png")


# -- residual statistics ------------------------------------------------------

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
    lags = int(min(lags or max(10, min(50, n // 10)), n - 1))
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
        ax.axhspan(-band, band, color=COLORS["band"], alpha=0.12, lw=0)
        ax.vlines(tau, 0, rho[:, i], color=COLORS["residual"], lw=1.4)
        ax.plot(tau, rho[:, i], "o", ms=2.5, color=COLORS["residual"])
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_title(result.data.output_names[i])
        ax.set_ylabel("autocorrelation [-]")
        ax.set_ylim(min(-2.5 * band, np.nanmin(rho[:, i]) - 0.05), 1.05)
    _bottom_labels(axes, ncols, "lag [s]")
    fig.suptitle(f"residual autocorrelation, ±1.96/√N band (N = {len(result.residuals)})",
                 fontsize=10)
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


def frequency_response(model, omega):
    """G(jω) = C (jωI - A)^-1 B + D at omega [rad/s]: (nω, ny, nu) complex."""
    A, B, C, D = state_space(model)
    n = A.shape[0]
    s = 1j * np.asarray(omega, dtype=float)[:, None, None] * np.eye(n) - A
    return C @ np.linalg.solve(s, np.broadcast_to(B, (len(omega), *B.shape))) + D


def _frequencies(model, hz, dt):
    """A decade below the slowest mode to a decade above the fastest, at most
    the Nyquist frequency of the record."""
    wn = [r["omega_n"] for r in modes(model) if r["omega_n"] > 0] or [1.0]
    lo, hi = min(wn) / 10, min(max(wn) * 10, np.pi / dt)
    omega = np.logspace(np.log10(lo), np.log10(max(hi, 10 * lo)), 300)
    return omega, (omega / (2 * np.pi) if hz else omega)


def bode_data(result, hz=True, samples=BAND_SAMPLES, seed=BAND_SEED):
    """Magnitude [dB] and phase [deg] of the identified model, in the
    declared units of the channels, with a Cramér-Rao band.

    The band is sampled: ``samples`` parameter vectors drawn from
    N(estimate, covariance) with a fixed seed; at each frequency the 2.5 and
    97.5 percentiles (the ±2σ band of a normal spread).

    Returns
    -------
    dict
        ``freq`` (axis values), ``unit`` ('Hz' or 'rad/s'), ``mag``, ``phase``
        (nω, ny, nu) and ``mag_band``, ``phase_band`` (2, nω, ny, nu).
    """
    recs = _Records.of_result(result)
    omega, freq = _frequencies(result.model, hz, recs.dt)
    su = np.array([_display(recs.first, "u", j)[1] for j in range(result.model.nu)])
    sy = np.array([_display(recs.first, "y", i)[1] for i in range(result.model.ny)])
    gain = su[None, :] / sy[:, None]          # core ratio to declared-unit ratio

    def db_phase(model):
        g = frequency_response(model, omega) * gain
        with np.errstate(divide="ignore"):
            return 20 * np.log10(np.abs(g)), np.degrees(np.unwrap(np.angle(g), axis=0))

    mag, phase = db_phase(result.model)
    mags, phases = [], []
    for m in sampled_models(result, samples, seed):
        a, p = db_phase(m)
        # the branch nearest the estimate's phase at each frequency: a draw
        # whose pole crosses the axis turns the other way, by 360 deg, which
        # is the same complex response
        p -= 360 * np.round((p - phase) / 360)
        mags.append(a)
        phases.append(p)
    q = (2.5, 97.5)
    return {"freq": freq, "unit": "Hz" if hz else "rad/s", "mag": mag, "phase": phase,
            "mag_band": np.percentile(mags, q, axis=0),
            "phase_band": np.percentile(phases, q, axis=0), "samples": samples, "seed": seed}


@_styled
def bode(result, hz=True, samples=BAND_SAMPLES, seed=BAND_SEED, path=None):
    """Bode plot of a linear identified model per input-output pair:
    magnitude [dB] and phase [deg] against frequency, with the sampled
    Cramér-Rao 95% (±2σ) band of ``bode_data``.

    Parameters
    ----------
    result : FitResult
        A fit of a LinearModel.
    hz : bool
        Frequency axis in Hz (default) or rad/s.
    samples, seed : int
        Draws of the parameter vector for the band, and their seed.
    path : str or Path, optional

    Returns
    -------
    matplotlib.figure.Figure
        2 ny rows (magnitude, phase) by nu columns.

    Raises
    ------
    InputError
        If the model is not linear.
    """
    state_space(result.model)
    b = bode_data(result, hz, samples, seed)
    recs = _Records.of_result(result)
    ny, nu = b["mag"].shape[1:]
    fig, axes = _figure(2 * ny, nu, max(6.8, 4.8 * nu + 0.6), 1.35, sharex=True)
    for j in range(nu):
        for i in range(ny):
            am, ap = axes[2 * i, j], axes[2 * i + 1, j]
            uy, uu = _display(recs.first, "y", i)[0], _display(recs.first, "u", j)[0]
            ratio = unit_ratio(uy, uu)
            for ax, key, lab in ((am, "mag", "dB"), (ap, "phase", "deg")):
                ax.fill_between(b["freq"], b[f"{key}_band"][0, :, i, j],
                                b[f"{key}_band"][1, :, i, j], color=COLORS["band"], alpha=0.2,
                                lw=0, label="95% band (CR)")
                ax.plot(b["freq"], b[key][:, i, j], color=COLORS["model"], label="estimate")
                ax.set_xscale("log")
            am.set_ylabel("|G| [dB]")
            ap.set_ylabel("phase [deg]")
            am.set_title(f"{recs.names('u')[j]} → {recs.names('y')[i]}"
                         + (f"  [{ratio}]" if ratio else ""), loc="left")
        axes[-1, j].set_xlabel(f"frequency [{b['unit']}]")
    _legend_above(axes[0, 0], "right", ncols=2)
    fig.suptitle(f"frequency response of the identified model\nband: 2.5-97.5 percentiles of "
                 f"{samples} draws from N(θ̂, Cramér-Rao covariance), seed {seed}", fontsize=9.5)
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


#: Coherence below which the Bode plot draws a measured point hollow (less trusted).
COHERENCE_SHOWN = 0.6


@_styled
def bode_measured(result, input=0, output=0, measured=None, loes=None, frequencies=200,
                  path=None):
    """Bode plot of an identified linear model against the record's
    measured frequency response: gain and phase of the model with its ±2σ
    Cramér-Rao band (delta method, the core's analytic derivatives), the
    measured response as points (hollow where the coherence is below
    COHERENCE_SHOWN), its coherence in a third panel, and a
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
    # the measured phase on the model's branch (the same complex response)
    mph = measured.phase - 360 * np.round((measured.phase - np.interp(f, fm, mod.phase)) / 360)
    for ax, y, ym, s in ((ag, measured.gain + shift, mod.gain + shift, mod.sigma_gain),
                         (ap, mph, mod.phase, mod.sigma_phase)):
        ax.fill_between(fm, ym - 2 * s, ym + 2 * s, color=COLORS["band"], alpha=0.2, lw=0,
                        label="model ±2σ (Cramér-Rao)")
        ax.plot(fm, ym, color=COLORS["model"], label="identified model")
        good = measured.coherence >= COHERENCE_SHOWN
        ax.plot(f[good], y[good], "o", ms=2.5, color=COLORS["measured"],
                label="measured (record)")
        ax.plot(f[~good], y[~good], "o", ms=2.5, mfc="none", mew=0.6, color="0.6",
                label=f"measured, γ² < {COHERENCE_SHOWN}")
        if loes is not None:
            fl = fm[(fm >= loes.frequency_range[0]) & (fm <= loes.frequency_range[1])]
            r = loes.response(fl)
            yl = r.gain + shift if ax is ag else r.phase - 360 * np.round(
                (r.phase - np.interp(fl, fm, mod.phase)) / 360)
            ax.plot(fl, yl, "--", color=COLORS["mean"], label=f"LOES ({loes.m}/{loes.n}"
                    + (", delay" if loes.has_delay else "") + ")")
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
    _legend_above(ag, "right", ncols=3)
    fig.suptitle(f"frequency response: identified model and record ({measured.averages} "
                 f"averages of {measured.segment} samples)", fontsize=9.5)
    return _finish(fig, path)
