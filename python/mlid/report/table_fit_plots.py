"""The figure of tables over the flight condition: each table against its
first variable, the local estimates with their error bars on top and the
fitted table with its band, a breakpoint whose values nothing reaches
dashed (plots.py's style and band width).  The fit is a two-step one
(mlid.fit_tables, its own local estimates), or a global one: a fit whose
model has tables (a deck's or mlid.fit's result, its band from the fit's
Cramer-Rao covariance: ``FittedTables``) or any result offering tables,
table(q), curve(q, points), sigma and reached as TableFit does, with a
TableFit's local estimates on top when given.  A table over more variables
is drawn as one curve for each value the manoeuvres flew of the others (the
table's breakpoints where they flew more than six), each with its
manoeuvres in its colour; a manoeuvre that disagrees with the tables is
ringed."""

import numpy as np

from ..errors import InputError
from ..estimate.named import NamedArray
from ..estimate.table_fit import GlobalTableFit, TableFit
from ..export.source import Source
from ..model.tables import Table
from .plots import BAND_ALPHA, BAND_SIGMAS, COLORS, _figure, _finish, _styled, band_label


class FittedTables:
    """The tables of a fit whose model has tables, as a TableFit offers
    its own: each value with its sigma and where it acts, their covariance
    (the fit's Cramer-Rao block), the table and its sigma anywhere.

    Parameters
    ----------
    result : FitResult
        A fit (a deck case's or ``mlid.fit``'s) of a model written as
        equations with at least one table.

    Attributes
    ----------
    tables : dict
        {name: Table} (breakpoints; values: the estimates).
    names, cells : list of str
        Each value's name and where it acts (the core's text).
    values, sigma : NamedArray
        The estimates and their Cramer-Rao sigma (a value held: its value,
        sigma 0); NaN for a value no sample reaches (not identifiable).
    covariance : NamedArray (nv, nv)
        Their covariance (FitResult.covariance_of: tied values through
        their ties, 0 for a value held, NaN for one not reached).
    reached : ndarray of bool
        False for a value no sample reaches.
    fixed, tied : list of str
        The values neither free nor tied (known: sigma 0), and those tied
        (their sigma through the ties, FitResult.covariance_of).
    unreached : list of str
        The core's '... is reached by no sample: not identifiable' lines.

    Raises
    ------
    InputError
        A result that is no fit of a model with tables, or a failed fit.
    """

    def __init__(self, result):
        if not all(hasattr(result, a) for a in ("model", "names", "covariance")):
            raise InputError(f"a fit's result is needed, got {type(result).__name__}")
        if getattr(result, "failed", False):
            raise InputError("the fit failed: it has no tables to draw")
        src = Source(result)
        if not src.tables:
            raise InputError("the fit's model has no table")
        self.tables = {t.name: Table(t.variables, t.breakpoints, t.values) for t in src.tables}
        self.names = [n for q, t in self.tables.items() for n in t.value_names(q)]
        cells = result.model.table_cells
        self.cells = [cells.get(n, n) for n in self.names]
        self.unreached = list(result.model.unreached_cells(result))
        gone = set(result.model.unreached_names(result))
        free = set(result.names)
        tied_entries = result.model.tie_terms()
        labels = result.model.element_labels()
        self.reached = np.array([n not in gone for n in self.names])
        self.tied = [n for n in self.names if labels.index(n) in tied_entries]
        self.fixed = [n for n in self.names if n not in free and n not in self.tied]
        # the covariance of every value, free or tied (a held one's is zero:
        # known; one nothing reaches has no estimate)
        c = np.asarray(result.covariance_of(self.names), dtype=float)
        v = np.array([src.value(n) for n in self.names])
        v[~self.reached] = np.nan
        self.values = NamedArray(v, self.names)
        self.covariance = NamedArray(c, self.names)
        self.sigma = NamedArray(np.sqrt(np.clip(np.diag(c), 0, None)), self.names)

    def table(self, quantity):
        """A table's values in its breakpoints' shape (NaN where not reached)."""
        return TableFit.table(self, quantity)

    def curve(self, quantity, points):
        """The table and its sigma at points (npts, nvar): the core's
        interpolation weights w, w'v and sqrt(w' Cov w) (TableFit.curve)."""
        return TableFit.curve(self, quantity, points)


def tables_of(fit):
    """fit as something with tables, curve and sigma: a TableFit or a
    global fit's result as it is, a fit whose model has tables wrapped in
    FittedTables."""
    if hasattr(fit, "tables") and hasattr(fit, "curve"):
        return fit
    return FittedTables(fit)

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


def _local(fit, local):
    """Where the local estimates come from: the TableFit given, else the
    fit's own (a two-step fit, or a global fit tested against local fits);
    None for none."""
    if local is not None and not isinstance(local, TableFit):
        raise InputError(f"local must be a TableFit (mlid.fit_tables), got "
                         f"{type(local).__name__}")
    if local is not None:
        return local
    return fit if isinstance(fit, TableFit) and len(fit.entries) else None


def _flown(tab, q, loc):
    """The local estimates of q: their rows of loc, each manoeuvre's
    values of the table's variables (nloc, nvar)."""
    if loc is None or q not in loc.tables:
        return [], [], np.zeros((0, len(tab.variables)))
    rows = [k for k, (_, quantity) in enumerate(loc.entries) if quantity == q]
    man = [loc.labels.index(loc.entries[k][0]) for k in rows]
    var = [loc.variables.index(v) for v in tab.variables]
    return rows, man, loc.conditions[np.ix_(var, man)].T


def _global_slices(tab, flown):
    """For a table over more variables with no local estimates: its
    breakpoints of the others, at most MAX_SLICES of them spread evenly
    over all, and the title's note of how many are drawn when not all."""
    if len(tab.variables) == 1 or len(flown):
        return None, ""
    values = np.array(np.meshgrid(*tab.breakpoints[1:], indexing="ij")).reshape(
        len(tab.variables) - 1, -1).T
    if len(values) <= MAX_SLICES:
        return [tuple(v) for v in values], ""
    pick = np.unique(np.round(np.linspace(0, len(values) - 1, MAX_SLICES)).astype(int))
    return [tuple(values[k]) for k in pick], f" ({len(pick)} of {len(values)} slices)"


@_styled
def table_fit_figure(fit, path=None, quantities=None, local=None):
    """Each table against its first variable: the local estimates ±2σ, the
    fitted table and its ±2σ band; the manoeuvres that disagree ringed.

    Parameters
    ----------
    fit : TableFit, FitResult or a global fit's result
        A two-step fit (its local estimates drawn), a fit whose model has
        tables (the band from its Cramér-Rao covariance; its values at the
        breakpoints drawn ±2σ), or a result offering tables, curve and
        sigma as TableFit does.
    path : str or Path, optional
        Where to write the figure (PNG, whole or not at all).
    quantities : list of str, optional
        The tables drawn (default all), a panel each.
    local : TableFit, optional
        Local estimates drawn on top of a global fit's band (those of a
        two-step fit of the same manoeuvres); a two-step fit draws its own.

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InputError
        fit has no tables (a failed fit, a model without tables), local
        is no TableFit, or a quantity no table of it.
    """
    import matplotlib.pyplot as plt
    loc = _local(fit, local)
    two_step = isinstance(fit, TableFit) and not isinstance(fit, GlobalTableFit)
    source = "two-step" if two_step else \
        "global fit, Cramér-Rao" if isinstance(fit, GlobalTableFit) else "Cramér-Rao"
    fit = tables_of(fit)
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
        rows, man, flown = _flown(tab, q, loc)
        slices, shown = _global_slices(tab, flown)
        if slices is None:
            slices, near = _slices(fit, tab, flown) if len(flown) else ([()], [])
        else:
            near = []
        x = np.linspace(tab.breakpoints[0][0], tab.breakpoints[0][-1], CURVE_POINTS)
        for s, rest in enumerate(slices):
            colour = colours(s % 10) if len(slices) > 1 else COLORS["model"]
            pts = np.column_stack([x] + [np.full_like(x, r) for r in rest])
            value, sd = fit.curve(q, pts)
            what = ", ".join(f"{v} = {r:g}" for v, r in zip(tab.variables[1:], rest))
            ax.plot(x, value, color=colour, label=f"table {what}".strip())
            ax.fill_between(x, value - BAND_SIGMAS * sd, value + BAND_SIGMAS * sd,
                            color=colour, alpha=BAND_ALPHA, linewidth=0)
            if not two_step:           # the fitted values at the breakpoints
                b = tab.breakpoints[0]
                bv, bs = fit.curve(q, np.column_stack([b] + [np.full_like(b, r) for r in rest]))
                ax.plot(b, bv, "s", ms=3, color=colour)
            if len(rows):
                mine = np.asarray(near) == s
                ax.errorbar(flown[mine, 0], loc.theta[rows][mine],
                            yerr=BAND_SIGMAS * loc.local_sigma[rows][mine], fmt="o", ms=3.5,
                            capsize=2, color=colour, linewidth=0.8)
        if len(rows):
            bad = np.array([loc.labels[m] in loc.disagree for m in man], dtype=bool)
            if bad.any():
                ax.plot(flown[bad, 0], loc.theta[rows][bad], "o", ms=10, mfc="none",
                        color=COLORS["residual"], label="disagrees (χ² test)")
            ax.plot([], [], "o", color="0.4", ms=3.5,
                    label=band_label("local estimates", "Cramér-Rao"))
        ax.fill_between([], [], [], color="0.4", alpha=BAND_ALPHA,
                        label=band_label("table", source))
        ax.set_xlabel(tab.variables[0])
        ax.set_ylabel(q)
        ax.set_title((f"{q}: {len(rows)} local estimates, {len(tab.flat_values)} values"
                      if len(rows) else f"{q}: {len(tab.flat_values)} values") + shown)
        reached = np.array([fit.reached[fit.names.index(n)] for n in tab.value_names(q)])
        reached = reached.reshape(tab.shape, order="F").reshape(tab.shape[0], -1).any(axis=1)
        for b, r in zip(tab.breakpoints[0], reached):
            ax.axvline(b, color=COLORS["grid"] if r else COLORS["residual"],
                       linestyle="-" if r else "--", linewidth=0.8, zorder=0,
                       label=None if r else f"{tab.variables[0]} = {b:g}: reached by no "
                                            f"{'manoeuvre' if two_step else 'sample'}")
        ax.legend(loc="best", fontsize=7)
    for ax in list(axes.flat)[len(quantities):]:
        ax.set_visible(False)
    return _finish(fig, path)
