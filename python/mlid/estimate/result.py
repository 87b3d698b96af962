"""The result of a fit, its printed report (report Table 5.3 style), its
HTML form for Jupyter, and the whiteness test of its residuals."""

import functools
import html
import json
import math
import re
import types

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..checks import pandas_for
from ..errors import InputError
from .diagnostics import Identifiability, Sensitivity, Whiteness
from .evaluate import evaluate
from .named import NamedArray
from .outcome import fit_outcome, require_estimates
from .table import HTML_DIGITS, results_table

#: What a failed fit does not have: every statistic of the fit (NaN in its
#: FitResult, null in its JSON).  Its ``estimate`` holds the last values reached.
NOT_IN_A_FAILED_FIT = ("sigma", "sigma_corrected", "covariance", "covariance_corrected",
                       "information", "gradient", "eigenvalues", "eigenvectors", "rhat", "yhat",
                       "cost", "cost_history")
#: The fields of a FitResult with one entry per free parameter, and those
#: with one row and column per free parameter: NamedArrays by ``names``.
BY_PARAMETER = ("start", "estimate", "sigma", "sigma_corrected", "gradient")
BY_PARAMETER_PAIR = ("covariance", "covariance_corrected", "information")


def _finite_or_none(value):
    """value with every float that is not finite, in its lists and dicts,
    replaced by None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, list):
        return [_finite_or_none(v) for v in value]
    if isinstance(value, dict):
        return {k: _finite_or_none(v) for k, v in value.items()}
    return value


def whiteness(residuals, lags=20, outputs=None):
    """Ljung-Box test of each column of residuals over lags 1..lags.

    Parameters
    ----------
    residuals : array_like (nt, ny) or (nt,)
        Residuals or innovations, a column per output; each column's mean is
        removed first.
    lags : int
        The largest lag.
    outputs : list of str, optional
        The columns' names (default y1, y2, ...).

    Returns
    -------
    Whiteness
        A list of dicts, per column: ``output``; ``Q``; ``critical``, the
        upper 5% point of chi-square(lags); ``white``, Q below it;
        ``outside``, the fraction of autocorrelations outside
        +-1.96/sqrt(N).  Also by output name, as arrays and as a DataFrame.

    Raises
    ------
    InputError
        If outputs does not name each column.
    """
    e = np.asarray(residuals, dtype=float)
    e = e.reshape(len(e), -1) - e.reshape(len(e), -1).mean(axis=0)
    n = len(e)
    from scipy.special import chdtri    # scipy.stats' chi2 without its import (~0.5 s)

    crit = chdtri(lags, 0.05)                 # the 95 % point of chi-square(lags)
    names = list(outputs) if outputs is not None else [f"y{i + 1}" for i in range(e.shape[1])]
    if len(names) != e.shape[1]:
        raise InputError(f"whiteness: {len(names)} output names for {e.shape[1]} columns")
    out = []
    for name, col in zip(names, e.T):
        c0 = col @ col
        rho = np.array([col[k:] @ col[:-k] for k in range(1, lags + 1)]) / c0
        q = n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1)))
        out.append({"output": name, "Q": float(q), "critical": float(crit),
                    "white": bool(q < crit),
                    "outside": float(np.mean(np.abs(rho) > 1.96 / np.sqrt(n)))})
    return Whiteness(out, lags)


class FitResult:
    """Estimates, Cramer-Rao standard deviations, correlations, noise
    covariance, residuals, cost history and how the iteration ended.
    ``sigma_corrected`` and ``covariance_corrected``: the Cramer-Rao ones
    corrected for coloured residuals (the core's mlid_colored, residual
    autocorrelation up to lag ``colored_lag``).

    Made by ``fit``; in Jupyter it shows as an HTML table.  A fit that
    failed (``failed``; the error raised carries it as ``.result``) has no
    estimates: ``estimate`` holds the last values reached, and every
    statistic (NOT_IN_A_FAILED_FIT) is NaN.

    Parameters
    ----------
    **fields
        The attributes, by name (``fit`` sets those below and more).

    Attributes
    ----------
    names : list of str
        The free parameters' labels.
    start, estimate, sigma, sigma_corrected : ndarray (nf,)
        Start values, estimates, Cramer-Rao and corrected sigmas.
    covariance, covariance_corrected, information : ndarray (nf, nf)
    rhat : ndarray (ny, ny)
        R-hat (output error) or the mean innovation covariance (filter error).
    r_innovations : ndarray (ny,) or None
        Filter error with ``noise_criterion='innovations'``: the diagonal of R
        the relaxation left (the model's r); None otherwise.
    yhat : ndarray (nt, ny)
        Model outputs (one-step predictions for filter error; for the
        frequency-domain methods ``zhat``).
    frequencies, z, zhat : ndarray or None
        Frequency-domain fits: the frequencies (Hz, each manoeuvre's in
        turn), the measured left-hand sides (output error: the outputs'
        transforms; equation error: i w Y for the outputs that measure a
        state) and the model's, complex (nk, ny).
    cost : float
    cost_history : ndarray (iterations + 1,)
    iterations : int
    converged : bool
        False for a failed fit.
    reason : str
        Why the iteration stopped, in the report's words.
    status : int
        The core's status code (0, or 4 when not converged; others: failed).
    message : str
        The core's message: a warning, why it did not converge or why it failed.
    model : Model
        The model at the estimate.
    data : FlightData
        The record fitted (several manoeuvres joined).
    options : dict
        The options used, by name.
    """

    r_innovations = None
    #: frequency-domain fits: the frequencies (Hz), measured and model transforms
    frequencies = z = zhat = None
    #: {name: what makes it}: fields made when first asked for (``fit``
    #: leaves ``model``, ``manoeuvres`` and ``param_units`` so: few fits are
    #: looked at that closely, and a fit is short enough for them to count)
    later = types.MappingProxyType({})

    def __init__(self, **fields):
        self.__dict__.update(fields)
        if self.failed:             # whatever the failure left there means nothing
            for name in NOT_IN_A_FAILED_FIT:
                if name in fields:
                    self.__dict__[name] = np.full(np.shape(fields[name]), np.nan)
            self.cost = float("nan")
            self.converged = False
        names = fields.get("names")
        if names is not None:       # reached by name as well as by position
            for field in BY_PARAMETER + BY_PARAMETER_PAIR:
                value = self.__dict__.get(field)
                if isinstance(value, np.ndarray) and value.ndim == (
                        1 if field in BY_PARAMETER else 2) and len(value) == len(names):
                    self.__dict__[field] = NamedArray(value, names)

    @property
    def failed(self):
        """True when an error ended the fit (``fit_outcome``): no estimates,
        only the last values reached.  Running out of iterations is not
        failing: that result has its sigma and ``converged`` False."""
        return fit_outcome(getattr(self, "status", 0), getattr(self, "reason_code", 0)) == \
            "failed"

    def _made(self, name):
        if name not in self.later:
            raise AttributeError(name)
        return self.later[name]()

    @functools.cached_property
    def model(self):
        """The model at the estimate (``later``)."""
        return self._made("model")

    @functools.cached_property
    def manoeuvres(self):
        """Each manoeuvre's model at the estimate: the shared parameters and
        its own x0 and bias (``later``)."""
        return self._made("manoeuvres")

    @functools.cached_property
    def param_units(self):
        """The unit of each free parameter, the core's mlid_param_units
        (``later``)."""
        return self._made("param_units")

    @property
    def residuals(self):
        """Measured minus model outputs, (nt, ny); for a frequency-domain fit
        the transforms' (complex, one row per frequency)."""
        if self.frequencies is not None:
            return self.z - self.zhat
        return self.data.y - self.yhat

    @property
    def correlation(self):
        """Correlation matrix of the estimates, from the Cramer-Rao covariance."""
        d = np.sqrt(np.clip(np.diag(self.covariance), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            c = self.covariance / np.outer(d, d)
        c = np.where(np.outer(d, d) > 0, c, 0.0)
        return NamedArray(c, self.names) if hasattr(self, "names") else c

    def whiteness(self, lags=20):
        """Ljung-Box whiteness test of the residuals (innovations), per output.

        Parameters
        ----------
        lags : int
            The largest lag.

        Returns
        -------
        Whiteness
            As ``mlid.whiteness``, the outputs named as the record names
            them: a list of dicts, one per output; ``to_frame()`` a row per
            output.

        Raises
        ------
        InputError
            If the fit failed.
        """
        require_estimates(self, "whiteness test")
        return whiteness(self.residuals, lags, self._output_names())

    def _output_names(self):
        names = list(getattr(self.data, "output_names", None) or [])
        return names or [f"y{i + 1}" for i in range(np.shape(self.rhat)[0])]

    @property
    def params(self):
        """The results table as a pandas DataFrame indexed by parameter name,
        in the order of ``names``: unit, estimate, Cramer-Rao sigma, corrected
        sigma, relative sigma (%) and the coloured-residuals flag
        (``res.params.loc["M_q", "estimate"]``).

        Raises
        ------
        InputError
            If the fit failed, or pandas is not installed.
        """
        return self.table().to_frame().set_index("name")

    def to_frame(self):
        """The estimates as a DataFrame indexed by name (``params``).

        Returns
        -------
        pandas.DataFrame
        """
        return self.params

    def _time_index(self, pd):
        """Time as the frames' index: t [s], under the manoeuvre's number
        when the fit took several."""
        t = np.asarray(self.data.t, dtype=float)
        data = getattr(self, "evaluate_args", (None,))[0]
        if not isinstance(data, (list, tuple)) or len(data) < 2:
            return pd.Index(t, name="t")
        number = np.repeat(np.arange(1, len(data) + 1), [d.nt for d in data])
        own = np.concatenate([d.t for d in data])     # each manoeuvre on its own time
        return pd.MultiIndex.from_arrays([number, own if own.size == t.size else t],
                                         names=["manoeuvre", "t"])

    def residuals_frame(self):
        """The residuals (innovations for filter error), a column per output
        named as the record names it, indexed by time; ``attrs["units"]``
        gives each column's unit (the record's, core units).

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        InputError
            If the fit failed, is a frequency-domain fit, or pandas is missing.
        """
        return self.outputs_frame()["residual"]

    def outputs_frame(self):
        """Measured and model outputs and their difference, indexed by time,
        columns (``measured``/``model``/``residual``, output name);
        ``attrs["units"]`` each output's unit.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        InputError
            If the fit failed, is a frequency-domain fit, or pandas is missing.
        """
        require_estimates(self, "outputs frame")
        if self.frequencies is not None:
            raise InputError("outputs_frame: a frequency-domain fit has transforms, not a time "
                             "history (see z and zhat)")
        pd = pandas_for("outputs_frame")
        names = self._output_names()
        blocks = {"measured": self.data.y, "model": self.yhat, "residual": self.residuals}
        frame = pd.concat({k: pd.DataFrame(v, columns=names, index=self._time_index(pd))
                           for k, v in blocks.items()}, axis=1)
        units = list(getattr(self.data, "output_units", None) or [""] * len(names))
        frame.attrs["units"] = dict(zip(names, units))
        return frame

    @property
    def cost_prime(self):
        """The report's J' (§5.1.6): (1/2N) sum nu'nu, the unweighted mean
        square of the one-step prediction errors (half the trace of R-hat,
        their mean square; the core's report prints it for filter error)."""
        return float(0.5 * np.trace(self.rhat))

    @property
    def det_r(self):
        """The determinant of R-hat (the report's det R, or det B); beyond
        the largest float it is infinite, as the report prints it."""
        with np.errstate(over="ignore", under="ignore"):
            return float(np.linalg.det(self.rhat))

    def as_dict(self):
        """Plain types for JSON.

        Returns
        -------
        dict
            Method and band (frequency domain; None for the time domain),
            parameters, start, estimate, sigmas, correlation, R, cost and its
            history, iterations, convergence, rank, reason, message, wall time;
            for a failed fit, as its JSON: ``failed`` True, ``last_values``,
            and None for the estimates and every statistic.  A number that
            is not finite (det R beyond the largest float) is None, as the
            core's JSON has it (null): JSON has no NaN or infinity.
        """
        return _finite_or_none(self._as_dict())

    def _as_dict(self):
        """as_dict, its numbers as they are."""
        core = json.loads(self._texts()[1])           # the estimator and band, as the core words them
        common = {"failed": self.failed, "method": core["method"], "band": core["band"],
                  "parameters": list(self.names),
                  "units": list(getattr(self, "param_units", None) or [""] * len(self.names)),
                  "start": self.start.tolist()}
        end = {"iterations": self.iterations, "converged": self.converged,
               "reason": self.reason, "message": self.message, "wall_time_s": self.wall_time}
        if self.failed:
            return {**common, "last_values": self.estimate.tolist(),
                    **dict.fromkeys(("estimate", "sigma", "sigma_corrected", "colored_lag",
                                     "correlation", "R", "det_R", "R_innovations", "cost",
                                     "cost_prime", "cost_history",
                                     "rank")), **end}
        return {**common, "estimate": self.estimate.tolist(), "sigma": self.sigma.tolist(),
                "sigma_corrected": self.sigma_corrected.tolist(),
                "colored_lag": self.colored_lag, "correlation": self.correlation.tolist(),
                "R": self.rhat.tolist(), "det_R": self.det_r,
                "R_innovations": None if self.r_innovations is None
                else self.r_innovations.tolist(), "cost": self.cost, "cost_prime": self.cost_prime,
                "cost_history": self.cost_history.tolist(), "rank": self.rank, **end}

    def _texts(self, title="", job="estimate"):
        """The core's report and JSON object of this fit (mlid-batch prints
        and writes the same text)."""
        h = _call_handle()
        data = self.data if not isinstance(self.data, (list, tuple)) else self.data[0]
        outputs = list(getattr(data, "output_names", None) or [])
        named = {}
        if len(outputs) == np.shape(self.rhat)[0]:      # named under R's diagonal
            named = dict(outputs="\n".join(outputs) + "\n", output_units="\n".join(
                getattr(data, "output_units", None) or [""] * len(outputs)) + "\n")
        _put(h, **named, labels="\n".join(self.names) + "\n",
             units="\n".join(getattr(self, "param_units", None) or [""] * len(self.names)) + "\n",
             iopt=self.flat_options, ropt=self.flat_real_options, start=self.start,
             est=self.estimate, sig=self.sigma, sigc=self.sigma_corrected, lag=self.colored_lag,
             cov=self.covariance, eigval=self.eigenvalues, eigvec=self.eigenvectors,
             rhat=self.rhat, hist=self.cost_history, cost=float(self.cost),
             niter=self.iterations, reason=self.reason_code, converged=int(self.converged),
             nrank=self.rank, title=title, job=job, fit_status=self.status, fit_msg=self.message,
             rnoise=np.full(self.rhat.shape[0], np.nan) if self.r_innovations is None
             else self.r_innovations)
        out = _run(h, _api.mlid_report_fit)
        return out["report"].decode(errors="replace"), out["json"].decode(errors="replace")

    def report(self):
        """The printed report (report Table 5.3 layout) with what the
        information says about identifiability (report §4.5, §5.3.5).

        Returns
        -------
        str
            The core's text, the one mlid-batch prints.
        """
        return self._texts()[0].rstrip("\n")

    def covariance_of(self, labels):
        """The Cramer-Rao covariance of any of the model's parameters, by
        label: a free one's from ``covariance``, a tied one's through its
        ties (J Cov J', J its scales on the free ones), one neither free
        nor tied zero (known); a free table value no sample reaches
        (``model.unreached_names``) NaN in its row and column.

        Parameters
        ----------
        labels : sequence of str
            The model's parameter labels ('C_Lalpha', 'CLt[2]').

        Returns
        -------
        NamedArray (n, n)

        Raises
        ------
        InputError
            A label that is no parameter of the model; a failed fit.
        """
        require_estimates(self, "covariance_of")
        labels = list(labels)
        model = self.model
        theta_labels = model.element_labels()
        entry = {lab: k for k, lab in enumerate(theta_labels)}
        unknown = [lab for lab in labels if lab not in entry]
        if unknown:
            raise InputError(f"covariance_of: {', '.join(unknown)} is no parameter of the model")
        free = {n: i for i, n in enumerate(self.names)}
        terms = model.tie_terms()
        J = np.zeros((len(labels), len(free)))
        for r, lab in enumerate(labels):
            if lab in free:
                J[r, free[lab]] = 1.0
            for j, scale in terms.get(entry[lab], (0.0, []))[1]:
                if theta_labels[j] in free:           # a fixed source adds no variance
                    J[r, free[theta_labels[j]]] += scale
        cov = J @ np.asarray(self.covariance, dtype=float) @ J.T
        unreached = set(model.unreached_names(self))
        gone = [r for r, lab in enumerate(labels) if lab in unreached]
        cov[gone, :] = cov[:, gone] = np.nan
        return NamedArray(cov, labels)

    def identifiability(self):
        """The report's lines on identifiability: eigenvalue spread of the
        normalised information, its weakest direction, correlations above 0.9.

        Returns
        -------
        Identifiability
            The report's lines (a list of str; empty for a failed fit), with
            their numbers: eigenvalues, spread, weakest direction and
            correlations by parameter name; ``to_frame()`` a row per
            parameter.
        """
        if self.failed:
            return Identifiability([], [], np.zeros(0), np.zeros((0, 0)), np.zeros((0, 0)))
        lines = self.report().split("\n")
        k = [i for i, ln in enumerate(lines) if ln.startswith((" R diagonal", " B diagonal",
                                                             " S diagonal", " output:",
                                                             " unit:"))]
        return Identifiability(lines[k[-1] + 1:], self.names, self.eigenvalues,
                               self.eigenvectors, self.correlation)

    def against_truth(self, truth):
        """The estimates against known true values: a simulated record's.

        Parameters
        ----------
        truth : Model
            A model of the fit's kind holding the true values (the model of
            the deck case that simulated the record), read at the fit's free
            elements.

        Returns
        -------
        values : ndarray
            The true value of each free parameter, in ``names``' order.
        deviations : ndarray
            (estimate - truth) / Cramer-Rao sigma of each.
        """
        values = truth.theta[self.start_model.free_indices()]     # as estimate
        return values, (self.estimate - values) / self.sigma

    def json(self, title="", job="estimate"):
        """The JSON object of this fit as a deck case (``mlid run --json``).

        Parameters
        ----------
        title, job : str
            The case's title and job, as a deck gives them.

        Returns
        -------
        str
            The core's JSON text, the one mlid-batch writes.
        """
        return self._texts(title, job)[1]

    def sensitivity_norms(self):
        """Output sensitivity norms at the estimate, (ny, nf): sqrt(sum over
        the record of (d yhat_i / d theta_k)^2 / R_ii), how many residual
        sigmas each parameter moves each output (innovations for filter
        error).  A parameter small in every output is one the data cannot see.

        Returns
        -------
        ndarray (ny, nf)

        Raises
        ------
        InputError
            If the fit failed.
        """
        require_estimates(self, "sensitivity norms")
        data, x0s, biases = getattr(self, "evaluate_args", (self.data, None, None))
        if isinstance(data, (list, tuple)):      # several manoeuvres: each one's own x0, bias
            x0s = [m.x0 for m in self.manoeuvres]
            biases = [m.bias for m in self.manoeuvres]
        return evaluate(self.model, data, initial_states=x0s, biases=biases,
                        **self.options)["sensitivity"]

    def sensitivity_frame(self):
        """The sensitivity norms as a DataFrame: a row per free parameter
        (``names``), a column per output (the record's names);
        ``sensitivity_table().to_frame()``.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        InputError
            If the fit failed, or pandas is not installed.
        """
        pandas_for("sensitivity_frame")        # before the model is run
        return self.sensitivity_table().to_frame()

    def sensitivity_table(self):
        """The sensitivity norms, a row per parameter.

        Returns
        -------
        Sensitivity
            The printed lines (a list of str), the norms (ny, nf), a
            parameter's norms by name, ``to_frame()``.

        Raises
        ------
        InputError
            If the fit failed.
        """
        return Sensitivity(self.sensitivity_norms(), self.names, self._output_names())

    def table(self):
        """The results table: name, unit, estimate, Cramer-Rao and corrected
        sigma, relative sigma, flag.

        Returns
        -------
        mlid.estimate.table.ResultsTable
            Exports CSV, LaTeX, JSON, HTML and DataFrames.

        Raises
        ------
        InputError
            If ``param_units`` does not have one entry per free parameter.
        """
        return results_table(self)

    def noise_diagonal(self):
        """The diagonal of R-hat by output, in the core report's words.

        Returns
        -------
        label : str
            'R diagonal' (output error: R estimated from the residuals) or
            'B diagonal (mean)' (filter error: the mean innovation covariance),
            as the printed report says it.
        rows : list of (str, float)
            Each output's name and its diagonal element (core units).

        Raises
        ------
        InputError
            If the fit failed.
        """
        require_estimates(self, "noise estimate")
        line = next(ln for ln in self.report().split("\n")
                    if ln.startswith((" R diagonal", " B diagonal")))
        label = re.match(r"\s*(\w diagonal(?: \(mean\))?)", line).group(1)
        outs = list(self.data.output_names) or [f"y{i + 1}" for i in range(len(self.rhat))]
        return label, [(name, float(v)) for name, v in zip(outs, np.diag(self.rhat))]

    def _repr_html_(self):
        """Jupyter's view: the report's first line (method, iterations,
        converged and why), the results table, the cost and R-hat's diagonal;
        for a failed fit the report's lines (what failed, the last values)."""
        e = html.escape
        if self.failed:
            return (f'<div class="mlid-fit mlid-failed"><p><b>FitResult</b></p>'
                    f"<pre>{e(self.report())}</pre></div>")
        head = self.report().split("\n")[0].strip()
        label, rows = self.noise_diagonal()
        noise = "".join(f"<tr><td>{e(name)}</td><td style=\"text-align:right\">"
                        f"{v:.{HTML_DIGITS}g}</td></tr>" for name, v in rows)
        return (f'<div class="mlid-fit"><p><b>FitResult</b>: {e(head)}</p>'
                f"{self.table().html_text()}"
                f'<p>cost J = <span class="cost">{self.cost:.{HTML_DIGITS}g}</span>, '
                f'<span class="iterations">{self.iterations}</span> iterations, '
                f'converged: <span class="converged">{"yes" if self.converged else "no"}'
                f'</span> (<span class="reason">{e(self.reason)}</span>)</p>'
                f'<table class="mlid-noise"><thead><tr><th>output</th><th>{e(label)}</th>'
                f"</tr></thead><tbody>{noise}</tbody></table></div>")

    def __repr__(self):
        if self.failed:
            return f"FitResult(failed after {self.iterations} iterations: {self.message})"
        return f"FitResult(cost={self.cost:.6g}, iterations={self.iterations}, " \
               f"converged={self.converged})"
