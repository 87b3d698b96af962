"""Model-structure determination for equation-error models of the
aerodynamic coefficients (Klein and Morelli 2006, sec. 5.4): stepwise
regression with the partial F-test and multivariate orthogonal functions
with the predicted square error, by the core (fortran/estimation/
regression); a small generator of polynomial and spline candidates."""

import re

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, lines as _lines, put as _put, \
    run as _run
from ..checks import pandas_for, real_array
from ..errors import InputError, guarded

#: The constant's name: the longitudinal model's regressor '1'.
CONSTANT = "1"


class ModelStructure:
    """A selected equation-error model y = X theta and how it was reached
    (made by :func:`mlid.stepwise`).

    Parameters
    ----------
    method : str
        The method that chose it.
    names : list of str
        The candidates' names.
    out : dict
        The core's results by name (mlid_model_structure).

    Attributes
    ----------
    method : str
        'forward', 'backward' or 'mof'.
    names : list of str
        The candidates, the constant ('1') first when it was added.
    selected : list of str
        The chosen terms, in the candidates' order.
    estimates, sigma : dict
        Least-squares estimate and its standard error of each chosen term.
    f : dict
        Each candidate's partial F against the final model: to remove where
        chosen, to enter where not.
    r2, s, pse : float
        R^2, the fit error sqrt(SSE/(N - p)) and the predicted square error
        SSE/N + sig2_max p/N of the final model.
    sig2_max : float
        The sig2_max of PSE.
    path : pandas.DataFrame
        The selection step by step (step 0 the start): the term that
        entered ('+name') or left ('-name'), its partial F, and R^2, PSE, s
        and the number of terms after the step.  For 'mof' the order in
        which the orthogonal functions were made, to the last candidate; the
        model is the step of least PSE.
    """

    def __init__(self, method, names, out):
        self.method, self.names = method, list(names)
        sel = np.asarray(out["selected"]).astype(bool)
        self.selected = [n for n, s in zip(self.names, sel) if s]
        theta, sigma = np.asarray(out["theta"]), np.asarray(out["sigma"])
        self.estimates = {n: float(theta[j]) for j, n in enumerate(self.names) if sel[j]}
        self.sigma = {n: float(sigma[j]) for j, n in enumerate(self.names) if sel[j]}
        self.f = dict(zip(self.names, np.asarray(out["f"]).tolist()))
        self.r2, self.s = float(out["r2"]), float(out["s"])
        self.pse, self.sig2_max = float(out["pse"]), float(out["sig2_max"])
        self._selected_mask = sel
        pd = pandas_for("ModelStructure")
        term = np.atleast_1d(out["term"]).astype(int)
        self.path = pd.DataFrame({
            "step": np.arange(term.size),
            "term": ["start" if k == 0 else ("+" if k > 0 else "-") + self.names[abs(k) - 1]
                     for k in term],
            "F": np.atleast_1d(out["path_f"]), "R2": np.atleast_1d(out["path_r2"]),
            "PSE": np.atleast_1d(out["path_pse"]), "s": np.atleast_1d(out["path_s"]),
            "terms": np.atleast_1d(out["np"]).astype(int)}).set_index("step")

    def to_frame(self):
        """A row per candidate: selected, estimate, sigma (NaN where not
        selected) and partial F.

        Returns
        -------
        pandas.DataFrame
            Indexed by the candidates' names.
        """
        pd = pandas_for("ModelStructure.to_frame")
        est = [self.estimates.get(n, np.nan) for n in self.names]
        sig = [self.sigma.get(n, np.nan) for n in self.names]
        return pd.DataFrame({"selected": self._selected_mask, "estimate": est, "sigma": sig,
                             "F": [self.f[n] for n in self.names]},
                            index=pd.Index(self.names, name="term"))

    def model_start(self, coefficient):
        """The chosen structure as a longitudinal model's start: the &model
        items ``<coefficient>_regressors`` and ``<coefficient>`` (e.g. 'cm':
        cm_regressors and cm), for a deck or for
        :class:`mlid.LongitudinalModel`.  The candidates' names must be that
        kind's regressors ('1', 'V/V0', 'alpha', 'alpha^2', 'qhat', 'de') for
        the model to read them; the estimates are of the candidates as
        given (scale them to the model's regressors first).

        Parameters
        ----------
        coefficient : str
            The coefficient's item name: 'cd', 'cl' or 'cm'.

        Returns
        -------
        dict
            ``{'<coefficient>_regressors': names, '<coefficient>': values}``.

        Raises
        ------
        InputError
            A coefficient that is no name.
        """
        if not isinstance(coefficient, str) or not coefficient.isidentifier():
            raise InputError(f"coefficient must be a name such as 'cm', got {coefficient!r}")
        return {f"{coefficient}_regressors": list(self.selected),
                coefficient: [self.estimates[n] for n in self.selected]}

    def deck_text(self, coefficient):
        """model_start(coefficient) as the lines of a deck's &model group:
        the core's text (fortran/case/mlid_stepwise_text.f90), the one the
        deck's job 'stepwise' prints and writes.

        Parameters
        ----------
        coefficient : str
            As for model_start.

        Returns
        -------
        str
            Two lines: ``<coefficient>_regressors = ...`` and
            ``<coefficient> = ...`` (the values as %.10g writes them).

        Raises
        ------
        InputError
            A coefficient that is no name, or a selected term's name over
            the 64 bytes a candidate's name may have.
        """
        start = self.model_start(coefficient)
        h = _call_handle()
        _put(h, coefficient=coefficient, names="".join(n + "\n" for n in self.selected),
             values=np.asarray(start[coefficient], dtype=float))
        return bytes(_run(h, _api.mlid_model_start_text)["text"]).decode("utf-8", "surrogateescape")

    def __repr__(self):
        rows = "\n".join(f"  {n:14s} {self.estimates[n]: .6g}  sigma {self.sigma[n]:.3g}  "
                         f"F {self.f[n]:.4g}" for n in self.selected)
        return (f"ModelStructure ({self.method}): {len(self.selected)} of {len(self.names)} "
                f"terms, R2 {self.r2:.6f}, s {self.s:.4g}, PSE {self.pse:.4g}\n{rows}")


@guarded
def stepwise(X, y, method="forward", f_in=None, f_out=None, intercept=True, forced=(),
             sig2_max=None, names=None):
    """The terms of an equation-error model y = X theta that the data
    support, from candidate regressors (fortran/estimation/regression).

    Methods (Klein and Morelli 2006, sec. 5.4):

    - 'forward': stepwise regression.  From the constant (and the forced
      terms), the candidate of the largest partial F enters while that F is
      at least f_in; after each entry a term whose partial F has fallen below
      f_out leaves.
    - 'backward': from all candidates, the term of the smallest partial F
      leaves while that F is below f_out.
    - 'mof': multivariate orthogonal functions.  The candidates are
      orthogonalised by Gram-Schmidt in the order of their contribution to
      the fit; the number of functions is the one of least predicted square
      error PSE = SSE/N + sig2_max p/N; the model goes back to the ordinary
      regressors by least squares on them.

    Partial F of a term: the drop in the residual sum of squares it brings,
    over the residual variance of the model with it.  The final estimates
    are least squares (QR) on the chosen terms.

    Parameters
    ----------
    X : pandas.DataFrame or array_like (N, m)
        The candidates, a column each (a DataFrame's columns name them).
    y : array_like (N,)
        The measured coefficient.
    method : str
        'forward', 'backward' or 'mof'.
    f_in, f_out : float, optional
        Partial-F thresholds to enter and to stay (f_out <= f_in); default
        4, about the 95 % point of F(1, N) for large N, Klein and Morelli's
        usual value (the textbook software's swr uses 20 for the coloured
        residuals of flight data).  f_in is forward's alone, f_out the
        stepwise methods' (not mof's): a threshold the method does not use
        is refused, not ignored.
    intercept : bool
        Add the constant '1' as the first term, always in the model.
    forced : sequence of str
        Candidates always in the model.
    sig2_max : float, optional
        sig2_max of PSE (default: (1/N) sum (y - mean y)^2, Morelli's bound).
    names : list of str, optional
        The candidates' names (default: the DataFrame's columns, else x1,
        x2, ...).

    Returns
    -------
    ModelStructure

    Raises
    ------
    InputError
        Shapes that disagree, values not finite, names repeated or unknown,
        thresholds with f_out > f_in, an unknown method, a candidate zero
        throughout, too few samples, or (backward) a candidate that is a
        combination of the others: one line naming it.

    Examples
    --------
    >>> import numpy as np, mlid
    >>> rng = np.random.default_rng(1)
    >>> X = rng.standard_normal((400, 4))
    >>> y = 1.0 + 2.0 * X[:, 0] - 0.5 * X[:, 2] + 0.1 * rng.standard_normal(400)
    >>> mlid.stepwise(X, y).selected
    ['1', 'x1', 'x3']
    """
    if names is None:
        names = [str(c) for c in X.columns] if hasattr(X, "columns") else None
    X = real_array("X", np.asarray(X, dtype=float) if not hasattr(X, "columns")
                   else X.to_numpy(dtype=float))
    y = real_array("y", y)
    if X.ndim != 2 or y.ndim != 1 or X.shape[0] != y.shape[0]:
        raise InputError(f"X must be (N, m) and y (N,) of one length N (shapes {X.shape} and "
                         f"{y.shape})")
    names = [f"x{j + 1}" for j in range(X.shape[1])] if names is None else list(names)
    if len(names) != X.shape[1]:
        raise InputError(f"{len(names)} names for {X.shape[1]} candidates")
    if len(set(names)) != len(names):
        raise InputError("the candidates' names must differ: "
                         f"{sorted({n for n in names if names.count(n) > 1})} repeat")
    if isinstance(forced, str):
        forced = [forced]
    unknown = [f for f in forced if f not in names]
    if unknown:
        raise InputError(f"forced terms {unknown} are not among the candidates")
    if intercept:
        if CONSTANT in names:
            raise InputError(f"a candidate is named '{CONSTANT}', the constant's name: pass "
                             "intercept=False to give the constant yourself")
        X = np.column_stack([np.ones(X.shape[0]), X])
        names = [CONSTANT] + names
    isforced = np.array([int(n in forced or (intercept and j == 0))
                         for j, n in enumerate(names)], dtype=np.int32)
    if sig2_max is None:
        sig2_max = 0.0
    elif not (isinstance(sig2_max, (int, float)) and sig2_max > 0 and np.isfinite(sig2_max)):
        raise InputError(f"sig2_max must be a positive number (or None), got {sig2_max!r}")
    thresholds = {k: v for k, v in (("f_in", f_in), ("f_out", f_out)) if v is not None}
    for label, v in thresholds.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
            raise InputError(f"{label} must be a number, got {v!r}")
    if not isinstance(method, str):
        raise InputError(f"method must be 'forward', 'backward' or 'mof', got {method!r}")
    h = _call_handle()
    _put(h, x=np.asfortranarray(X), y=y, forced=isforced, method=method,
         sig2_max=float(sig2_max), **{k: float(v) for k, v in thresholds.items()})
    try:
        out = _run(h, _api.mlid_model_structure)
    except InputError as e:
        # the core counts the candidates (the constant first): name them
        raise InputError(re.sub(r"(candidate|term) (\d+)",
                                lambda m: f"{m[1]} '{names[int(m[2]) - 1]}'", str(e))) from None
    return ModelStructure(method, names, out)


def stepwise_candidates(data, variables, degree=2, knots=None, spline_degree=1):
    """Candidate regressors from named variables (the core's
    mlid_candidates): each variable, their products and powers up to a
    total degree, and spline terms.

    Parameters
    ----------
    data : pandas.DataFrame or dict of array_like
        The variables' samples by name.
    variables : sequence of str
        The variables to use (e.g. 'al', 'be', 'pn', 'qn', 'rn', 'de').
    degree : int
        The largest total degree of a product: 1 the variables alone, 2
        also 'al^2' and 'al*de', ...; by degree, each in the variables'
        order.
    knots : dict, optional
        Per variable the knots of its spline terms: (v - k)+^n, named
        '(v-k)+' or '(v-k)+^n' (k as %g writes it).
    spline_degree : int
        n of the spline terms.

    Returns
    -------
    pandas.DataFrame
        A column per candidate.

    Raises
    ------
    InputError
        data not a table, a variable not in the data, not real or not
        finite, variables of different lengths, knots for a
        variable not used, a degree below 1, more than 10,000 candidates,
        or a candidate's name over 64 bytes (the core's; not cut).
    """
    pd = pandas_for("stepwise_candidates")
    if isinstance(variables, str):
        variables = [variables]
    variables = list(variables)
    if not hasattr(data, "keys"):
        raise InputError("data must be a pandas DataFrame or a dict of the variables' samples "
                         f"by name, got {type(data).__name__}")
    missing = [v for v in variables if v not in data]
    if missing:
        raise InputError(f"variable {missing[0]!r} is not in the data")
    columns = [real_array(v, data[v]).ravel() for v in variables]
    if len({c.size for c in columns}) > 1:
        raise InputError("the variables need one sample count, got "
                         + ", ".join(f"{v} {c.size}" for v, c in zip(variables, columns)))
    V = np.column_stack(columns) if variables else None
    for label, v in (("degree", degree), ("spline_degree", spline_degree)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
            raise InputError(f"{label} must be a whole number >= 1, got {v!r}")
    knot_var, knot_at = [], []
    for v, ks in (knots or {}).items():
        if v not in variables:
            raise InputError(f"knots are given for {v!r}, which is not among the variables")
        for k in np.atleast_1d(real_array(f"knots of {v}", ks)):
            knot_var.append(variables.index(v) + 1)
            knot_at.append(float(k))
    if V is None:
        raise InputError("candidates: no variables or no samples")
    bad = [v for v in variables if not isinstance(v, str) or "\n" in v]
    if bad:
        raise InputError(f"a variable's name must be text of one line, got {bad[0]!r}")
    h = _call_handle()
    _put(h, v=np.asfortranarray(V), vnames="".join(v + "\n" for v in variables),
         degree=int(degree), knot_var=np.array(knot_var, np.int32),
         knots=np.array(knot_at, float), spline_degree=int(spline_degree))
    out = _run(h, _api.mlid_candidate_terms)
    x = np.asarray(out["x"]).reshape(V.shape[0], -1, order="F")
    # the names are the core's (fortran/case/mlid_stepwise_text.f90), as the deck's job prints
    return pd.DataFrame(x, columns=_lines(out["names"]), index=getattr(data, "index", None))
