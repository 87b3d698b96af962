"""The two-step route from a campaign's local fits to tables over the flight
envelope (issue 46): each manoeuvre fitted on its own first (``mlid.fit``,
or the cases of ``mlid run --campaign``), then the tables' values fitted to
the local estimates with their full covariances, and each manoeuvre's
estimates tested against the tables.  The numbers are the core's
(fortran/estimation/fit/mlid_table_fit.f90); the interpolation is the
tables' own (mlid_tables), the one a model with tables flies.

The fit minimises sum_i (theta_i - A_i v)' C_i^-1 (theta_i - A_i v) over
the table values v: theta_i the estimates of manoeuvre i of the quantities
the tables model, C_i their covariance (the local fit's block), A_i the
interpolation weights at the manoeuvre's flight condition.  Each
manoeuvre's test is chi2_i = r_i' S_i^+ r_i, r_i = theta_i - A_i v the
residual and S_i = C_i - A_i Cov(v) A_i' its covariance, against the
chi-square of rank(S_i) degrees of freedom (docs/guide/estimator.md,
"Tables from local fits").
"""

import re

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, lines as _lines, \
    put as _put, run as _run
from ..checks import pandas_for, real_array
from ..data.flight_data import FlightData
from ..errors import InputError, guarded, guarded_class
from ..model.maneuvers import Params
from ..model.tables import Table
from .fit import fit
from .named import NamedArray

#: The default level of the consistency tests: the probability of naming a
#: manoeuvre that agrees with the tables.
LEVEL = 0.01


def _one_line(name, what):
    name = str(name)
    if not name or "\n" in name:
        raise InputError(f"{what} must be text of one line, got {name!r}")
    return name


def _tables_text(tables):
    """{quantity: Table} as the core's lines 'NAME(v1, v2) = b b; b b'."""
    if not isinstance(tables, dict) or not tables:
        raise InputError("tables must be a dict {quantity name: Table}, at least one, got "
                         f"{type(tables).__name__}")
    for name, tab in tables.items():
        if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_]\w*", name):
            raise InputError(f"tables: {name!r} is not a name a table can have: name the "
                             "parameter in the local model (names={'f(2,1)': 'M_alpha'})")
        if not isinstance(tab, Table):
            raise InputError(f"tables[{name!r}] must be a mlid.model.tables.Table, got "
                             f"{type(tab).__name__}")
    return "".join(tab.line(name)[2:] + "\n" for name, tab in tables.items())


def _condition_of(item, k):
    """A manoeuvre's condition: a mapping, or an object with ``condition``
    (a deck's Case)."""
    cond = getattr(item, "condition", item)
    if not hasattr(cond, "items"):
        raise InputError(f"conditions[{k}] must be a dict {{variable: value}} or a deck case, "
                         f"got {type(item).__name__}")
    return cond


def _conditions(conditions, n, variables, tables):
    """The (nvar, nman) array of the tables' variables at each manoeuvre
    (NaN where it has none) and the variables' names."""
    names = list(dict.fromkeys(v for tab in tables.values() for v in tab.variables))
    rename = dict(variables or {})
    if len(conditions) != n:
        raise InputError(f"conditions: one for each of the {n} results, got {len(conditions)}")
    out = np.full((len(names), n), np.nan)
    for k, item in enumerate(conditions):
        cond = _condition_of(item, k)
        for j, v in enumerate(names):
            x = cond.get(rename.get(v, v))
            if x is not None:
                out[j, k] = real_array(f"conditions[{k}][{rename.get(v, v)!r}]", x,
                                       finite=True).item()
    return names, out


@guarded
def fit_tables(results, tables, conditions, labels=None, level=LEVEL, variables=None):
    """Tables fitted to local estimates with their covariances (the
    two-step route), and the chi-square test of each manoeuvre.

    Parameters
    ----------
    results : sequence of FitResult
        The local fits, one a manoeuvre; each must estimate (have free) at
        least one of the tabled quantities.  Their ``covariance`` blocks
        weight the estimates; manoeuvres are independent.
    tables : dict
        {quantity: Table}: the quantity, a free parameter's name in the
        results (a derivative such as ``'M_alpha'``), is the table over the
        flight-condition variables; its values are named ``'M_alpha[i]'``.
        The Table's values are not used (only its breakpoints).
    conditions : sequence
        Each manoeuvre's flight condition: a dict {variable: value}, or a
        deck case (its ``condition``, from &case mach, altitude, alpha_trim).
    labels : sequence of str, optional
        The manoeuvres' names (default 'manoeuvre 1', ...).
    level : float
        The tests' level: the probability of naming a manoeuvre that
        agrees (0.01).
    variables : dict, optional
        {table variable: condition name} where they differ, e.g.
        ``{'alpha': 'alpha_trim', 'Mach': 'mach'}``.

    Returns
    -------
    TableFit

    Raises
    ------
    InputError
        A result that is no fit or failed, or estimates none of the
        quantities; a condition missing; a table the core refuses.
    SingularInformationError
        Values reached only in a fixed combination (named), or a
        covariance that is not positive definite.
    """
    if isinstance(results, (str, bytes)) or not hasattr(results, "__len__") or not results:
        raise InputError("results must be a list of FitResults, at least one")
    results = list(results)
    labels = [f"manoeuvre {k + 1}" for k in range(len(results))] if labels is None \
        else [_one_line(x, "a manoeuvre's label") for x in labels]
    if len(labels) != len(results):
        raise InputError(f"labels: one for each of the {len(results)} results, got {len(labels)}")
    text = _tables_text(tables)
    level = real_array("level", level, finite=True).item()
    names, cond = _conditions(list(conditions), len(results), variables, tables)
    etab, eman, theta, cov, where = _local_entries(results, labels, list(tables))
    h = _call_handle()
    _put(h, tables=text, variables="".join(n + "\n" for n in names), conditions=cond,
         labels="".join(x + "\n" for x in labels), entry_table=np.array(etab, dtype=np.int32),
         entry_manoeuvre=np.array(eman, dtype=np.int32), theta=theta, covariance=cov,
         level=float(level))
    out = _run(h, _api.mlid_table_fit)
    return TableFit(dict(tables), names, cond, labels, where, theta, cov, level, out)


@guarded_class
class TableFit:
    """Tables fitted to a campaign's local estimates, and each manoeuvre's
    consistency with them (made by :func:`mlid.fit_tables`).

    Parameters
    ----------
    tables : dict
        {quantity: Table}.
    variables : list of str
        The tables' variables, the rows of conditions.
    conditions : ndarray (nvar, nman)
        Each manoeuvre's values of them (NaN: none).
    labels : list of str
        The manoeuvres.
    entries : list of (str, str)
        Each local estimate's manoeuvre and quantity.
    theta : ndarray (K,)
        The local estimates.
    cov : ndarray (K, K)
        Their covariance (block-diagonal: manoeuvre by manoeuvre).
    level : float
        The tests' level.
    out : dict
        The core's results by name (mlid_table_fit).

    Attributes
    ----------
    tables : dict
        {quantity: Table} as given (their breakpoints).
    names, cells : list of str
        Each value's name ('M_alpha[3]') and where it is weighted
        ('M_alpha[3] (alpha = 0.1; weighted where 0.05 < alpha < 0.15)').
    values, sigma : NamedArray (nv,)
        The values and their standard deviations; NaN for a value no
        manoeuvre reaches.
    covariance : NamedArray (nv, nv)
        Cov(v) = (A' C^-1 A)^-1 over the reached values (NaN elsewhere).
    unreached : list of str
        Each value no manoeuvre reaches (all its weights zero), said as
        '... is reached by no manoeuvre: not identifiable'.
    labels : list of str
        The manoeuvres.
    entries : list of (str, str)
        Each local estimate's manoeuvre and quantity, in the order of
        ``theta``, ``local_sigma`` and ``residuals``.
    theta, local_sigma, residuals : ndarray (K,)
        The local estimates, their sigma, and theta - A v.
    chi2, p_value, limit : ndarray (nman,)
        Each manoeuvre's chi-square, its p-value and the limit at the level.
    dof : ndarray of int (nman,)
        Its degrees of freedom: its estimates less the directions it alone
        decides (a value only it reaches).
    disagree : list of str
        The manoeuvres whose chi-square passes the limit, the least likely
        first.  A grossly wrong manoeuvre pulls the tables toward itself and
        its neighbours' residuals with them: the first is the one to look
        at; fit again without it and test the rest.
    chi2_total, dof_total, p_total, limit_total
        The campaign's r' C^-1 r on K - (values reached) degrees of freedom.
    level : float
    """

    def __init__(self, tables, variables, conditions, labels, entries, theta, cov, level,
                 out):
        self.tables, self.variables = tables, list(variables)
        self.conditions = conditions
        self.labels, self.entries, self.level = list(labels), list(entries), float(level)
        self.theta, self.local_sigma = theta, np.sqrt(np.diag(cov))
        self.names = _lines(out["names"])
        self.cells = out["cells"].decode("utf-8", "surrogateescape").split("\n")[:len(self.names)]
        self.values = NamedArray(np.asarray(out["values"], dtype=float), self.names)
        self.sigma = NamedArray(np.asarray(out["sigma"], dtype=float), self.names)
        self.covariance = NamedArray(np.asarray(out["covariance"], dtype=float).reshape(
            len(self.names), len(self.names)), self.names)
        self.reached = np.asarray(out["reached"]).astype(bool)
        self.unreached = [f"{c} is reached by no manoeuvre: not identifiable"
                          for c, r in zip(self.cells, self.reached) if not r]
        self.weights = np.asarray(out["weights"], dtype=float).reshape(len(theta), -1)
        self.residuals = np.atleast_1d(np.asarray(out["residuals"], dtype=float))
        self.chi2 = np.atleast_1d(np.asarray(out["chi2"], dtype=float))
        self.dof = np.atleast_1d(np.asarray(out["dof"])).astype(int)
        self.p_value = np.atleast_1d(np.asarray(out["p_value"], dtype=float))
        self.limit = np.atleast_1d(np.asarray(out["limit"], dtype=float))
        order = np.lexsort((-self.chi2, self.p_value))          # the worst first
        flags = np.atleast_1d(out["disagree"])
        self.disagree = [self.labels[k] for k in order if flags[k]]
        self.chi2_total, self.dof_total = float(out["chi2_total"]), int(out["dof_total"])
        self.p_total, self.limit_total = float(out["p_total"]), float(out["limit_total"])

    def table(self, quantity):
        """A table's values in its breakpoints' shape.

        Parameters
        ----------
        quantity : str
            The table's name (its quantity).

        Returns
        -------
        ndarray
            values[i, j] at (b1[i], b2[j]), NaN where not reached.

        Raises
        ------
        InputError
            No table of that name.
        """
        if quantity not in self.tables:
            raise InputError(f"no table {quantity!r} (tables: {', '.join(self.tables)})")
        names = self.tables[quantity].value_names(quantity)
        return np.array([self.values[n] for n in names]).reshape(self.tables[quantity].shape,
                                                                  order="F")

    def curve(self, quantity, points):
        """The fitted table and its sigma anywhere.

        Parameters
        ----------
        quantity : str
            The table's name.
        points : array_like (npts, ndim)
            Points of its variables, in the Table's order.

        Returns
        -------
        value, sigma : ndarray (npts,)
            w'v and sqrt(w' Cov(v) w), w the interpolation weights there
            (the core's lookup); NaN where an unreached value has weight.

        Raises
        ------
        InputError
            No table of that name, or points that are not finite.
        """
        if quantity not in self.tables:
            raise InputError(f"no table {quantity!r} (tables: {', '.join(self.tables)})")
        tab = self.tables[quantity]
        pts = real_array("points", points, finite=True).reshape(-1, len(tab.variables))
        h = _call_handle()
        _put(h, tables=_tables_text({quantity: tab}),
             variables="".join(v + "\n" for v in tab.variables), conditions=pts.T.copy(),
             labels="".join(f"point {k + 1}\n" for k in range(len(pts))),
             entry_table=np.ones(len(pts), dtype=np.int32),
             entry_manoeuvre=np.arange(1, len(pts) + 1, dtype=np.int32))
        w = np.asarray(_run(h, _api.mlid_table_weights)["weights"]).reshape(len(pts), -1)
        idx = [self.names.index(n) for n in tab.value_names(quantity)]
        v, c = np.asarray(self.values)[idx], np.asarray(self.covariance)[np.ix_(idx, idx)]
        used = w != 0
        value = np.array([wk[u] @ v[u] if np.all(np.isfinite(v[u])) else np.nan
                          for wk, u in zip(w, used)])
        var = np.array([wk[u] @ c[np.ix_(u, u)] @ wk[u] if np.all(np.isfinite(v[u])) else np.nan
                        for wk, u in zip(w, used)])
        return value, np.sqrt(np.clip(var, 0, None))

    def consistency(self):
        """The consistency tests as a table.

        Returns
        -------
        pandas.DataFrame
            A row a manoeuvre: chi2, dof, limit, p_value, disagrees.
        """
        pd = pandas_for("TableFit.consistency")
        return pd.DataFrame({"chi2": self.chi2, "dof": self.dof, "limit": self.limit,
                             "p_value": self.p_value,
                             "disagrees": [lab in self.disagree for lab in self.labels]},
                            index=pd.Index(self.labels, name="manoeuvre"))

    def text(self):
        """The summary as text.

        Returns
        -------
        str
            Each value with its sigma and where it acts (or that no
            manoeuvre reaches it), each manoeuvre's test and the total.
        """
        n = len(self.names)
        out = [f"Two-step table fit: {len(self.labels)} manoeuvres, {len(self.theta)} local "
               f"estimates, {len(self.tables)} table(s), {n} values ({int(self.reached.sum())} "
               "reached)", "", "Table values (estimate +- sigma):"]
        width = max(len(c) for c in self.cells)
        for c, v, s, r in zip(self.cells, self.values, self.sigma, self.reached):
            out.append(f"  {c:<{width}}  " + (f"{v:12.5g} +- {s:.3g}" if r else
                                              "not identifiable: reached by no manoeuvre"))
        out += ["", f"Consistency of each manoeuvre with the tables (chi-square, level "
                f"{self.level:g}):"]
        lw = max(9, max(len(x) for x in self.labels))
        out.append(f"  {'manoeuvre':<{lw}} {'chi2':>10} {'dof':>4} {'limit':>8} {'p-value':>10}")
        for lab, c, d, lim, p in zip(self.labels, self.chi2, self.dof, self.limit,
                                     self.p_value):
            note = "  disagrees" if lab in self.disagree else (
                "  (decides its values alone: nothing to test)" if d == 0 else "")
            out.append(f"  {lab:<{lw}} {c:10.4g} {d:4d} {lim:8.4g} {p:10.3g}{note}")
        verdict = "consistent" if self.p_total >= self.level else "inconsistent"
        if self.dof_total == 0:
            verdict = "nothing to test (as many values as estimates)"
        out += ["", f"Total: chi2 = {self.chi2_total:.4g} on {self.dof_total} degrees of "
                f"freedom (limit {self.limit_total:.4g}, p = {self.p_total:.3g}): {verdict}",
                "Manoeuvres that disagree: " + (", ".join(self.disagree) or "none")]
        return "\n".join(out) + "\n"

    def __repr__(self):
        return (f"<TableFit: {len(self.tables)} table(s), {len(self.names)} values, "
                f"{len(self.labels)} manoeuvres, {len(self.disagree)} disagree>")


# ---- the one-step route: one fit of every manoeuvre's record ------------------------------

#: The input that numbers the manoeuvres (1, 2, ...): a table over it alone
#: is each manoeuvre's own correction (a sensor's scale factor, say), not a
#: campaign table.
MANOEUVRE = "manoeuvre"


def _model_lines(model, kind):
    """The items of one kind ('u', 't') of an equations model's text."""
    return [line[2:].strip() for line in model.text.split("\n") if line.startswith(kind + " ")]


def _model_tables(model):
    """{name: Table} of the model's tables (their variables and breakpoints),
    those over the manoeuvre number alone left out."""
    out = {}
    for line in _model_lines(model, "t"):
        head, _, bps = line.partition(" = ")
        name, _, rest = head.partition("(")
        variables = [v.strip() for v in rest.rstrip(") ").split(",")]
        if variables != [MANOEUVRE]:
            out[name.strip()] = Table(variables, [[float(x) for x in b.split()]
                                                  for b in bps.split(";")])
    return out


def _records(model, data, conditions, rename):
    """Each manoeuvre's record with the model's inputs in order: a channel of
    the record by name, else its condition (or its number, for the input
    MANOEUVRE) as a constant channel.  Channels by position only when none
    of the record's is named as an input.  Refused with one line naming the
    manoeuvre and the input: an input in neither, in both with different
    values, or a table's variable whose channel varies over the manoeuvre."""
    inputs = _model_lines(model, "u")
    over = {v for t in _model_tables(model).values() for v in t.variables}
    out = []
    for k, d in enumerate(data):
        if not isinstance(d, FlightData):
            raise InputError(f"data[{k}] must be a FlightData, got {type(d).__name__}")
        cond = {} if conditions is None else _condition_of(conditions[k], k)
        given = {v: cond[rename.get(v, v)] for v in inputs if rename.get(v, v) in cond}
        if MANOEUVRE in inputs and MANOEUVRE not in given:
            given[MANOEUVRE] = k + 1
        given = {v: real_array(f"conditions[{k}][{rename.get(v, v)!r}]", x, finite=True).item()
                 for v, x in given.items()}
        by_name = any(v in d.input_names for v in inputs)
        if by_name:
            channel = {v: d.input_names.index(v) for v in inputs if v in d.input_names}
        else:
            rest = [v for v in inputs if v not in given]
            if d.u.shape[1] != len(rest):
                raise InputError(f"manoeuvre {k + 1}: its record's channels "
                                 f"({', '.join(d.input_names)}) are none of the model's inputs "
                                 f"by name and not one for each input its condition does not "
                                 f"give ({', '.join(rest)})")
            channel = {v: j for j, v in enumerate(rest)}
        cols, units = [], []
        for v in inputs:
            name = rename.get(v, v)
            if v not in channel and v not in given:
                raise InputError(f"manoeuvre {k + 1}: the model's input {v!r} is neither a "
                                 f"channel of its record ({', '.join(d.input_names)}) nor in its "
                                 "condition")
            if v in channel:
                u = d.u[:, channel[v]]
                if v in over and not np.all(u == u[0]):
                    raise InputError(f"manoeuvre {k + 1}: the input {v!r}, a table's variable, "
                                     f"varies over its record (channel {d.input_names[channel[v]]!r}"
                                     "): a manoeuvre's condition must be constant")
                if v in given and not np.all(u == given[v]):
                    raise InputError(f"manoeuvre {k + 1}: the input {v!r} is a channel of its "
                                     f"record and its condition's {name!r} ({given[v]:g}), "
                                     "different: give it once")
                cols.append(u)
                units.append(d.input_units[channel[v]])
            else:
                cols.append(np.full(d.nt, given[v]))
                units.append("")
        out.append(FlightData(d.t, np.column_stack(cols), d.y, list(inputs), d.output_names,
                              source=d.source, input_units=units, output_units=d.output_units,
                              output_display=d.output_display))
    return out


def _flown(records, variables):
    """(nvar, nman): each manoeuvre's value of each table variable that is a
    channel constant over it (NaN otherwise: a state, or a channel that
    varies)."""
    out = np.full((len(variables), len(records)), np.nan)
    for k, r in enumerate(records):
        for j, v in enumerate(variables):
            if v in r.input_names:
                u = r.u[:, r.input_names.index(v)]
                if np.all(u == u[0]):
                    out[j, k] = u[0]
    return out


@guarded
def fit_global(model, data, conditions=None, local=None, labels=None, level=LEVEL,
               variables=None, smoothness=None, **fit_args):
    """The one-step route: one fit of every manoeuvre's record, sharing the
    tables, each manoeuvre with its own initial state and output biases.

    One ``mlid.fit(model, records)`` (output error, or filter error where
    the model has its filter: ``method='filter_error'``): the core runs the
    manoeuvres' simulations and their parts of the information matrix in
    parallel (OpenMP over manoeuvres, fortran/estimation/fit/mlid_likelihood.f90),
    and a channel constant over a manoeuvre (its condition) is folded into
    the model, so that each manoeuvre computes the sensitivities of only
    the table values it reaches.

    Parameters
    ----------
    model : EquationModel
        The model with its tables (``definitions``, mlid.model.tables.Table)
        over inputs that are each manoeuvre's condition (and over states if
        a table is nonlinear within a manoeuvre).  Its free parameters are
        estimated; x0 and bias entries are each manoeuvre's own.  A table
        over the input ``'manoeuvre'`` alone (breakpoints 1, 2, ..., n) is
        each manoeuvre's own correction (a sensor's scale factor, say): the
        input is the manoeuvre's number, its value k's weight 1 there and 0
        elsewhere.
    data : list of FlightData
        One record a manoeuvre.  Each input of the model is the record's
        channel of that name or, if it has none, the manoeuvre's condition
        of that name as a constant channel; given in both, the two must be
        equal; in neither, refused.  A channel of an input a table is over
        must be constant over the manoeuvre (its condition).  Only a record
        none of whose channels is named as a model's input gives its
        channels by position, in the order of the inputs its condition
        does not give.
    conditions : sequence, optional
        Each manoeuvre's flight condition: a dict {variable: value} or a
        deck case (its ``condition``), for the inputs its record lacks.
    local : sequence of FitResult, optional
        The same manoeuvres' local fits (as for :func:`fit_tables`): then
        each one's estimates are tested against the global tables (the
        chi-square test of fit_tables at the global values: the core's
        mlid_table_test).  The test holds without a prior only (refused
        with ``smoothness`` or ``prior_weight``).
    labels : sequence of str, optional
        The manoeuvres' names (default 'manoeuvre 1', ...).
    level : float
        The tests' level (0.01).
    variables : dict, optional
        {model input: condition name} where they differ, e.g.
        ``{'alpha_trim': 'alpha', 'Mach': 'mach'}``.
    smoothness : dict, optional
        {table name: lambda}: the tables' smoothness prior, the model's
        ``smoothness_weight(smoothness)`` over the global fit's free
        parameters (zero rows for each manoeuvre's own entries).
    **fit_args
        Passed to ``mlid.fit``: prior, prior_weight (over the global fit's
        free parameters: the shared ones, then each manoeuvre's own,
        'bias(1)#2'; not with ``smoothness``), bounds, initial_states,
        biases, x0_from and the estimator's options.

    Returns
    -------
    GlobalTableFit

    Raises
    ------
    InputError
        A model without tables, a record that is no FlightData, an input
        neither in the record nor in the condition; what ``mlid.fit`` and
        ``fit_tables`` raise.
    SingularInformationError
        Values no manoeuvre separates (the fit's information singular).
    """
    if not hasattr(model, "text") or not hasattr(model, "table_names"):
        raise InputError(f"fit_global needs a model written as equations with tables "
                         f"(EquationModel, SixDofModel), got {type(model).__name__}")
    tables = _model_tables(model)
    if not tables:
        raise InputError("fit_global: the model has no table over a flight condition")
    if isinstance(data, (str, bytes)) or not hasattr(data, "__len__") or not data:
        raise InputError("data must be a list of FlightData, a manoeuvre each, at least one")
    data = list(data)
    if conditions is not None:
        conditions = list(conditions)
        if len(conditions) != len(data):
            raise InputError(f"conditions: one for each of the {len(data)} records, got "
                             f"{len(conditions)}")
    labels = [f"manoeuvre {k + 1}" for k in range(len(data))] if labels is None \
        else [_one_line(x, "a manoeuvre's label") for x in labels]
    if len(labels) != len(data):
        raise InputError(f"labels: one for each of the {len(data)} records, got {len(labels)}")
    level = real_array("level", level, finite=True).item()
    if local is not None and (isinstance(local, (str, bytes)) or not hasattr(local, "__len__")
                              or len(local) != len(data)):
        raise InputError(f"local: one fit for each of the {len(data)} manoeuvres, got "
                         f"{len(local) if hasattr(local, '__len__') else type(local).__name__}")
    prior = smoothness is not None or fit_args.get("prior_weight") is not None
    if local is not None and prior:
        raise InputError("local: the test of local fits against the global tables holds for a "
                         "global fit without a prior only (a prior moves the tables off what "
                         "the records say): fit without smoothness and prior_weight to test")
    records = _records(model, data, conditions, dict(variables or {}))
    if smoothness is not None:
        if fit_args.get("prior_weight") is not None:
            raise InputError("fit_global: give smoothness or prior_weight, not both (add other "
                             "a priori weights to a prior_weight over the global free "
                             "parameters)")
        fit_args["prior_weight"] = _global_weight(model, len(records), smoothness, fit_args)
    result = fit(model, records, **fit_args)
    return GlobalTableFit(tables, records, labels, result, local, level)


def _global_weight(model, n, smoothness, fit_args):
    """The model's smoothness weight over the free parameters of its fit to
    n manoeuvres: the shared entries' rows and columns where the model's
    are, zero for each manoeuvre's own (x0, biases: no table values)."""
    w = model.smoothness_weight(smoothness)
    w = 0.5 * (w + w.T)          # exactly symmetric, as the core asks (its rounding is not)
    mine = list(model.free_names())
    names = Params(model, n, fit_args.get("initial_states"), fit_args.get("biases")).free_names()
    at = {name: k for k, name in enumerate(names)}
    idx = [at.get(name, -1) for name in mine]
    out = np.zeros((len(names), len(names)))
    rows = [i for i, k in enumerate(idx) if k >= 0]
    lost = [mine[i] for i, k in enumerate(idx) if k < 0 and np.any(w[i] != 0.0)]
    if lost:
        raise InputError(f"smoothness: {lost[0]} is each manoeuvre's own in the global fit, "
                         "not a table value")
    out[np.ix_([idx[i] for i in rows], [idx[i] for i in rows])] = w[np.ix_(rows, rows)]
    return out


@guarded_class
class GlobalTableFit(TableFit):
    """Tables from one fit of a campaign's records (made by
    :func:`mlid.fit_global`): the interface of :class:`TableFit` (values,
    sigma, covariance, table, curve, text), so that figures, exports and
    the comparison with the two-step route take either.

    Parameters
    ----------
    tables : dict
        {quantity: Table}: the model's tables (their breakpoints).
    records : list of FlightData
        The records as fitted (the conditions as channels).
    labels : list of str
        The manoeuvres.
    result : FitResult
        The global fit.
    local : sequence of FitResult or None
        The manoeuvres' local fits, to test against the tables.
    level : float
        The tests' level.

    Attributes
    ----------
    result : FitResult
        The fit itself: every free parameter (each manoeuvre's own x0 and
        biases named '#k'), the cost, the iterations, ``wall_time``.
    model : EquationModel
        The fitted model (manoeuvre 1's x0 and biases): what an export
        writes.
    names, cells, values, sigma, covariance, reached, unreached
        As TableFit's, over every value of every table, the covariance
        the result's ``covariance_of``: a tied value's through its ties, a
        held one's 0; a free value no sample reaches (no information) is NaN
        and named in unreached (the model's ``unreached_cells``).
    held : list of str
        The values neither free nor tied (shown '(held)').
    conditions : ndarray (nvar, nman)
        Each manoeuvre's value of each table variable (a channel constant
        over it; NaN otherwise).
    entries, theta, local_sigma, residuals, chi2, dof, p_value, limit,
    disagree, chi2_total, dof_total, p_total, limit_total
        With ``local``: the test of each manoeuvre's local estimates
        against the global tables, as TableFit's; without, empty (no test,
        none disagree).
    """

    def __init__(self, tables, records, labels, result, local, level):
        self.tables, self.result, self.model = dict(tables), result, result.model
        self.variables = list(dict.fromkeys(v for t in tables.values() for v in t.variables))
        self.conditions = _flown(records, self.variables)
        self.labels, self.level = list(labels), float(level)
        self.names = [n for q, t in tables.items() for n in t.value_names(q)]
        cells = result.start_model.table_cells
        self.cells = [cells.get(n, n) for n in self.names]
        # one place for each fact: the model says which free values no
        # sample reaches, the result gives any value's covariance (tied
        # ones through their ties, held ones 0, unreached ones NaN)
        gone = set(self.model.unreached_names(result))
        self.reached = np.array([n not in gone for n in self.names])
        self.unreached = list(self.model.unreached_cells(result))
        entry = {lab: k for k, lab in enumerate(self.model.element_labels())}
        tied, free = self.model.tie_terms(), set(result.names)
        self.held = [n for n in self.names if n not in free and entry[n] not in tied]
        values = np.array([self.model.value(n) for n in self.names], dtype=float)
        values[~self.reached] = np.nan
        cov = np.asarray(result.covariance_of(self.names), dtype=float)
        self.values = NamedArray(values, self.names)
        self.covariance = NamedArray(cov, self.names)
        self.sigma = NamedArray(np.sqrt(np.diag(cov)), self.names)
        self.local = None if local is None else list(local)
        self._test(self.local)

    def _test(self, local):
        """The local estimates' chi-square tests against these tables (the
        core's mlid_table_test), or no test."""
        n = len(self.labels)
        if local is None:
            self.entries, self.theta, self.local_sigma = [], np.zeros(0), np.zeros(0)
            self.weights = np.zeros((0, len(self.names)))
            self.residuals = np.zeros(0)
            self.chi2, self.p_value, self.limit = np.zeros(n), np.ones(n), np.zeros(n)
            self.dof, self.disagree = np.zeros(n, dtype=int), []
            self.chi2_total, self.dof_total, self.p_total, self.limit_total = 0.0, 0, 1.0, 0.0
            return
        held = [n for n, r in zip(self.names, self.reached) if r and n in self.held]
        if held:
            raise InputError(f"local: the tables' value {held[0]} is held in the global fit "
                             "(neither free nor tied): the test compares the local estimates "
                             "with fitted tables; free it to test")
        etab, eman, theta, cov, entries = _local_entries(local, self.labels, list(self.tables))
        h = _call_handle()
        _put(h, tables=_tables_text(self.tables),
             variables="".join(v + "\n" for v in self.variables), conditions=self.conditions,
             labels="".join(x + "\n" for x in self.labels),
             entry_table=np.array(etab, dtype=np.int32),
             entry_manoeuvre=np.array(eman, dtype=np.int32), theta=theta, covariance=cov,
             level=self.level, values=np.nan_to_num(np.asarray(self.values), nan=0.0))
        out = _run(h, _api.mlid_table_test)
        self.entries, self.theta = entries, theta
        self.local_sigma = np.sqrt(np.diag(cov))
        self.weights = np.asarray(out["weights"], dtype=float).reshape(len(theta), -1)
        self.residuals = np.atleast_1d(np.asarray(out["residuals"], dtype=float))
        self.chi2 = np.atleast_1d(np.asarray(out["chi2"], dtype=float))
        self.dof = np.atleast_1d(np.asarray(out["dof"])).astype(int)
        self.p_value = np.atleast_1d(np.asarray(out["p_value"], dtype=float))
        self.limit = np.atleast_1d(np.asarray(out["limit"], dtype=float))
        order = np.lexsort((-self.chi2, self.p_value))
        flags = np.atleast_1d(out["disagree"])
        self.disagree = [self.labels[k] for k in order if flags[k]]
        self.chi2_total, self.dof_total = float(out["chi2_total"]), int(out["dof_total"])
        self.p_total, self.limit_total = float(out["p_total"]), float(out["limit_total"])

    def text(self):
        """The summary as text.

        Returns
        -------
        str
            The fit (manoeuvres, cost, iterations), each table value with
            its sigma and where it acts, and with local fits each
            manoeuvre's test against the tables.
        """
        r = self.result
        out = [f"One-step global table fit: {len(self.labels)} manoeuvres, {len(r.names)} free "
               f"parameters, {len(self.tables)} table(s), {len(self.names)} values "
               f"({int(self.reached.sum())} reached); cost {r.cost:.6g} after {r.iterations} "
               f"iterations ({'converged' if r.converged else 'not converged'}: {r.reason})",
               "", "Table values (estimate +- sigma):"]
        width = max(len(c) for c in self.cells)
        for n, c, v, s, ok in zip(self.names, self.cells, self.values, self.sigma,
                                  self.reached):
            shown = f"{v:12.5g} (held)" if n in self.held else f"{v:12.5g} +- {s:.3g}"
            out.append(f"  {c:<{width}}  " + (shown if ok else
                                              "not identifiable: reached by no sample"))
        if self.local is None:
            return "\n".join(out) + "\n"
        rest = TableFit.text(self).split("\n")
        at = next(k for k, line in enumerate(rest) if line.startswith("Consistency"))
        rest[at] = rest[at].replace("with the tables", "with the global tables")
        return "\n".join(out + [""] + rest[at:])

    def __repr__(self):
        return (f"<GlobalTableFit: {len(self.tables)} table(s), {len(self.names)} values, "
                f"{len(self.labels)} manoeuvres, {len(self.disagree)} disagree>")


def _local_entries(results, labels, quantities):
    """The local estimates of the tabled quantities: each entry's table and
    manoeuvre (1-based), the estimates, their block-diagonal covariance and
    (manoeuvre, quantity) of each."""
    etab, eman, theta, blocks, where = [], [], [], [], []
    for k, (res, lab) in enumerate(zip(results, labels)):
        if not all(hasattr(res, a) for a in ("names", "estimate", "covariance")):
            raise InputError(f"results[{k}] must be a FitResult, got {type(res).__name__}")
        if getattr(res, "failed", False):
            raise InputError(f"manoeuvre {lab!r}: its fit failed; leave it out")
        idx = [(t, list(res.names).index(q)) for t, q in enumerate(quantities)
               if q in res.names]
        if not idx:
            raise InputError(f"manoeuvre {lab!r} estimates none of the tabled quantities "
                             f"({', '.join(quantities)})")
        j = [i for _, i in idx]
        etab += [t + 1 for t, _ in idx]
        eman += [k + 1] * len(idx)
        theta += list(np.asarray(res.estimate, dtype=float)[j])
        blocks.append(np.asarray(res.covariance, dtype=float)[np.ix_(j, j)])
        where += [(lab, quantities[t]) for t, _ in idx]
    cov = np.zeros((len(theta), len(theta)))
    at = 0
    for b in blocks:
        cov[at:at + len(b), at:at + len(b)] = b
        at += len(b)
    return etab, eman, np.array(theta), cov, where
