"""The figure of a two-step table fit (mlid.fit_tables): each table against
its first variable, the local estimates with their error bars on top and
the fitted table with its band, a breakpoint whose values no manoeuvre
reaches dashed (plots.py's style and band width).  A table
over more variables is drawn as one curve for each value the manoeuvres
flew of the others (the table's breakpoints where they flew more than six),
each with its manoeuvres in its colour; a manoeuvre that disagrees with the
tables is ringed."""

import numpy as np

from ..errors import InputError
from ..estimate.table_fit import TableFit
from .plots import BAND_ALPHA, BAND_SIGMAS, COLORS, _figure, _finish, _styled, band_label

#: The most curves a panel draws for the values flown of a table's other variables.
MAX_SLICES = 6
#: Points along the first variable where the band is drawn.
CURVE_POINTS = 121


def _slices(fit, tab, flown):
    """The values of the table's other variables a curve is drawn at, and
    each manoeuvre's curve."""
    if len(tab.variables) == 1:
        return [()], np.zeros(flown.shape[0], dtype=int)
    rest = flown[:, 1:]
    values = np.unique(rest, axis=0)
    if len(values) > MAX_SLICES:
        values = np.array(np.meshgrid(*tab.breakpoints[1:], indexing="ij")).reshape(
            len(tab.variables) - 1, -1).T
    near = np.argmin(((rest[:, None, :] - values[None]) ** 2).sum(axis=2), axis=1)
    return [tuple(v) for v in values], near


@_styled
def table_fit_figure(fit, path=None, quantities=None):
    """Each table against its first variable: the local estimates ±2σ, the
    fitted table and its ±2σ band; the manoeuvres that disagree ringed.

    Parameters
    ----------
    fit : TableFit
    path : str or Path, optional
        Where to write the figure (PNG, whole or not at all).
    quantities : list of str, optional
        The tables drawn (default all), a panel each.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InputError
        fit is no TableFit, or a quantity no table of it.
    """
    import matplotlib.pyplot as plt
    if not isinstance(fit, TableFit):
        raise InputError(f"fit must be a TableFit (mlid.fit_tables), got {type(fit).__name__}")
    quantities = list(fit.tables) if quantities is None else list(quantities)
    for q in quantities:
        if q not in fit.tables:
            raise InputError(f"no table {q!r} (tables: {', '.join(fit.tables)})")
    ncols = min(2, len(quantities))
    nrows = -(-len(quantities) // ncols)
    fig, axes = _figure(nrows, ncols, 4.6 * ncols, 3.0)
    colours = plt.get_cmap("tab10")
    for ax, q in zip(axes.flat, quantities):
        tab = fit.tables[q]
        rows = [k for k, (_, quantity) in enumerate(fit.entries) if quantity == q]
        man = [fit.labels.index(fit.entries[k][0]) for k in rows]
        var = [fit.variables.index(v) for v in tab.variables]
        flown = fit.conditions[np.ix_(var, man)].T
        slices, near = _slices(fit, tab, flown)
        x = np.linspace(tab.breakpoints[0][0], tab.breakpoints[0][-1], CURVE_POINTS)
        for s, rest in enumerate(slices):
            colour = colours(s % 10) if len(slices) > 1 else COLORS["model"]
            pts = np.column_stack([x] + [np.full_like(x, r) for r in rest])
            value, sd = fit.curve(q, pts)
            what = ", ".join(f"{v} = {r:g}" for v, r in zip(tab.variables[1:], rest))
            ax.plot(x, value, color=colour, label=f"table {what}".strip())
            ax.fill_between(x, value - BAND_SIGMAS * sd, value + BAND_SIGMAS * sd,
                            color=colour, alpha=BAND_ALPHA, linewidth=0)
            mine = near == s
            ax.errorbar(flown[mine, 0], fit.theta[rows][mine],
                        yerr=BAND_SIGMAS * fit.local_sigma[rows][mine], fmt="o", ms=3.5,
                        capsize=2, color=colour, linewidth=0.8)
        bad = np.array([fit.labels[m] in fit.disagree for m in man], dtype=bool)
        if bad.any():
            ax.plot(flown[bad, 0], fit.theta[rows][bad], "o", ms=10, mfc="none",
                    color=COLORS["residual"], label="disagrees (χ² test)")
        ax.plot([], [], "o", color="0.4", ms=3.5,
                label=band_label("local estimates", "Cramér-Rao"))
        ax.fill_between([], [], [], color="0.4", alpha=BAND_ALPHA,
                        label=band_label("table", "two-step"))
        ax.set_xlabel(tab.variables[0])
        ax.set_ylabel(q)
        ax.set_title(f"{q}: {len(rows)} local estimates, {len(tab.flat_values)} values")
        reached = np.array([fit.reached[fit.names.index(n)] for n in tab.value_names(q)])
        reached = reached.reshape(tab.shape, order="F").reshape(tab.shape[0], -1).any(axis=1)
        for b, r in zip(tab.breakpoints[0], reached):
            ax.axvline(b, color=COLORS["grid"] if r else COLORS["residual"],
                       linestyle="-" if r else "--", linewidth=0.8, zorder=0,
                       label=None if r else f"{tab.variables[0]} = {b:g}: reached by no "
                                            "manoeuvre")
        ax.legend(loc="best", fontsize=7)
    for ax in list(axes.flat)[len(quantities):]:
        ax.set_visible(False)
    return _finish(fig, path)
