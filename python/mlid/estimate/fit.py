"""The maximum-likelihood fit of a model's free parameters (the core's
modified Newton-Raphson, report §4.6), and what its result makes when first
asked for."""

import functools
import numbers
import re
import time
import warnings

import numpy as np

from .._bridge import (api as _api, call_handle as _call_handle, counted, counter_id,
                       text as _text, values as _values)
from ..errors import InputError, MlidWarning, check_status, guarded
from ..model.calls import _check, _check_data, _check_model, _manoeuvres, _record, _set_problem
from .evaluate import FREQUENCY_METHODS, _frequency_call
from .options import _flat_options
from .outcome import fit_outcome
from .result import FitResult


def stop_reason(code):
    """Why an iteration stopped, in the report's words (from the core)."""
    return _stop_text(int(code))


@functools.lru_cache(maxsize=256)
def _stop_text(code):
    return _text(_api.mlid_stop_reason(code))


#: no bound
_HUGE = np.finfo(float).max


def _real_number(v):
    """A real number: a float, an int, a numpy scalar or 0-d array of one."""
    return (isinstance(v, numbers.Real) or
            (isinstance(v, np.ndarray) and v.ndim == 0 and np.isrealobj(v) and
             v.dtype.kind in "fiu"))


def _extras(params, prior, prior_weight, bounds):
    """A priori values/weight and bounds in the core's layout."""
    theta = params.theta
    pvec = theta.copy()
    for what, given in (("prior", prior), ("bounds", bounds)):
        if given is not None and not isinstance(given, dict):
            raise InputError(f"{what} must be a dict by parameter name, got "
                             f"{type(given).__name__}")
    for name, value in (prior or {}).items():
        pvec[params.index(name)] = value
    nf = params.free.size
    if prior_weight is None:
        weight = np.zeros((nf, nf))
    elif isinstance(prior_weight, dict):
        free = params.free.tolist()
        weight = np.zeros((nf, nf))
        for name, w in prior_weight.items():
            k = free.index(params.index(name))
            weight[k, k] = w
    else:
        weight = np.asarray(prior_weight, dtype=float)
        if weight.shape != (nf, nf):
            raise InputError(f"prior_weight must be {nf}x{nf} (free parameters), got "
                             f"{weight.shape}")
    lower = np.full(theta.size, -_HUGE)
    upper = np.full(theta.size, _HUGE)
    for name, pair in (bounds or {}).items():
        # NaN and infinite values go on: the core says what is wrong with them
        if not isinstance(pair, (tuple, list)) or len(pair) != 2 or \
                any(v is not None and not _real_number(v) for v in pair):
            raise InputError(f"bounds[{name!r}] must be a pair (lower, upper) of numbers or None, "
                             f"got {pair!r}")
        lo, hi = pair
        k = params.index(name)
        lower[k] = -_HUGE if lo is None else float(lo)
        upper[k] = _HUGE if hi is None else float(hi)
    return {"use_prior": int(prior_weight is not None), "prior": pvec,
            "pweight": np.asfortranarray(weight), "use_bounds": int(bool(bounds)),
            "lower": lower, "upper": upper}


@guarded
def fit(model, data, prior=None, prior_weight=None, bounds=None, initial_states=None,
        biases=None, x0_from=None, x0_samples=None, progress=None, **options):
    """Maximum-likelihood fit of the model's free parameters.

    Modified Newton-Raphson (report §4.6) on the negative log-likelihood,
    from the model's current parameter values.

    Parameters
    ----------
    model : Model
        A LinearModel, LongitudinalModel, X22Model or UserModel; its free
        parameters are estimated, the others held.
    data : FlightData or list of FlightData
        One record, or several manoeuvres fitted together: they share every
        parameter but the initial state and the output biases, which each
        has of its own (named like the model's with '#k', k the manoeuvre).
    prior : dict, optional
        A priori values {name: value} of §4.5.2 (default: the start values).
    prior_weight : dict or array_like, optional
        The a priori weights: {name: weight} (diagonal) or an nf x nf matrix
        over the free parameters; none, no a priori term.
    bounds : dict, optional
        {name: (lower, upper)}, either may be None (-inf, inf: the same);
        steps are limited to them as in §4.6 blocks 11-12.  NaN, a lower
        bound of inf or an upper of -inf raise InputError.
    initial_states, biases : list of array_like, optional
        Start values of each manoeuvre's x0 and output bias (several
        manoeuvres only; default the model's).
    x0_from : {'first', 'mean'}, optional
        Each manoeuvre's x0 of every state an output measures from its own
        record: that output's first sample, or the mean of its first
        ``x0_samples``, less its bias (a deck's &estimate x0_from; the
        core's rule, fortran/models/mlid_initial_states.f90).  An output
        measures state j when its row of H is the unit vector e_j and its
        row of D zero; a longitudinal or X-22 model's first four outputs; an
        equations, sixdof or flight-path output written as the state's
        name.  The other states keep their x0; free or held as ``free``
        says.  A user model cannot say which output is which state.
    x0_samples : int, optional
        The samples averaged by x0_from = 'mean' (>= 1, at most a
        manoeuvre's).
    **options
        Estimator options by name (defaults: ``default_options()``):

        method : 'output_error', 'filter_error', 'frequency_output_error' or \
'frequency_equation_error'
            Output error (§4.4): R estimated from the residuals.  Filter
            error (§4.1, §4.3): the Kalman filter with the model's process
            noise; q, r and S are parameters like any other.  A nonlinear
            model gets the extended Kalman filter, linearised over each
            sample interval.  The frequency-domain methods (linear models
            only, fortran/estimation/frequency_domain/mlid_frequency.f90) fit the record's finite
            Fourier transform over the band: output error the transfer
            function's outputs H (iwI - F)^-1 G U + D U, equation error the
            state equations iw X = F X + G U with the measured states; the
            noise spectrum S estimated from the residuals.  Each channel's
            mean is removed first, so biases and trim drop out; x0 and
            biases are not parameters there.  The result's ``frequencies``,
            ``z`` (measured) and ``zhat`` (model) are the transforms, and
            ``residuals`` their difference.
        f_min, f_max : float
            The frequency-domain methods' band, Hz (required by them).
        n_freq : int
            Frequencies evenly spaced over the band, both ends included.
        noise : 'diagonal' or 'full'
            Output error: the R estimated from the residuals.
        partials : bool
            Filter error: include the partials of the innovations and their
            covariance B through the filter's covariance and gain (eqs
            4.32-4.34) in the gradient and information matrix; needed for
            free noise parameters.  A linear model gets them analytically.
            A nonlinear model's extended Kalman filter depends on the
            parameters also through its linearisation (Phi, W and C taken
            along the estimated states), whose analytic partials need second
            derivatives of f and h: the core instead takes the innovations'
            and B's partials as forward differences of whole filter runs,
            one per free parameter (step 1e-6 of the parameter), so the
            gradient is that of the cost for every parameter, the
            coefficients of f and h as well as the noise statistics.  Without
            partials the gain and B are held fixed in the gradient and
            information: the innovations' sensitivities run through the
            states only, and the noise parameters get no gradient (a free
            one then makes the information singular).
        steady_state : bool
            Filter error: the steady-state gain (a nonlinear model's: that of
            the model linearised about x0 and the first input sample; its
            states still follow the nonlinear model).
        filter_params : 'noise' or 'gain'
            Filter error: what the filter's parameters are.  'noise': q, r
            and S (eqs 4.8-4.18).  'gain': the steady-state gain K (the
            model's block stab, its free entries 'stab(i,j)') and B
            estimated from the innovations (eqs 4.19-4.21; ``noise`` makes
            B diagonal or full); q, r and S are then not parameters.  The
            time-varying filter starts from the model's p0 (P(1|0)).
        process_noise : 'held', 'continuous' or 'continuous_sd'
            Filter error: what q are: variances held over each sample
            interval, spectral densities of continuous white noise, or their
            standard deviations (the textbook's F).
        noise_criterion : 'exact', 'innovations' or 'textbook'
            Filter error: how R is had.  'exact': r are parameters like any
            other; 'innovations': set after each step to what the
            innovations leave (R = S - C P C'); 'textbook': filter error as
            FVSysID's ml_fem2 computes it (gain from the continuous Riccati
            equation with R dt, R the innovations' mean square, the
            F-compensation, cost det R, diag(KC) <= 1; tol_cost is then the
            relative change of det R).  docs/guide/estimator.md compares them.
        startup : 'none' or 'equation_error'
            Start from an equation-error least-squares pass (all states
            measured).
        max_iter, halvings : int
            Iterations, and step halvings when the cost rises.
        tol_cost, tol_step, tol_grad : float
            Convergence tests: relative cost change, relative step, and the
            step in Cramer-Rao sigmas.
        rcond : float
            Eigenvalues of the normalised information below rcond times the
            largest are singular.
        rank_min, rank_max : int
            Rank-deficient search over these ranks (§4.6 blocks 7-10); 0,
            full rank.
        rank_rule : 'iteration' or 'staged'
            'iteration': the best rank each iteration, as the report;
            'staged': converge at rank_min, then free one more direction at
            a time while a likelihood-ratio test at 5% accepts it.
        prior_decay : float
            The a priori weights are multiplied by this each iteration.
    progress : None, bool or stream
        A bar of the Newton iterations (against max_iter) for a fit that
        runs over half a second, counted by the core: None shows it when
        stderr is a terminal, False never, a stream forces it there
        (``mlid.progress.bar`` says more).

    Returns
    -------
    FitResult
        Estimates, Cramer-Rao and coloured-residual sigmas, covariance,
        R-hat, outputs, cost history and how the iteration ended.  A run that
        ends without meeting a convergence test returns its last iterate with
        ``converged`` False; so does one that blew up, whatever test it met
        (reason 'diverged: R-hat or cost not sane': its cost or R-hat is not
        finite, or an R-hat(i,i) is above 1e6 times the mean square of output
        i as measured; the message names the output and the ratio).

    Raises
    ------
    InputError
        Bad model, data, names, options, prior, bounds or sizes; time that
        does not increase or has a gap; non-uniform sampling for filter
        error.
    SingularInformationError
        The information matrix, or R-hat or the filter's innovation
        covariance, is singular.
    DivergenceError
        The simulation diverged (a state not finite), or a nonlinear
        model's linearisation for the steady-state gain is not finite.
    NonConvergenceError
        The steady-state Kalman filter's Riccati iteration did not converge.
    InternalError
        A numerical library call failed.

        Each error but InputError carries the failed fit as ``.result``
        (``failed`` True): the start and the last values reached, no sigma.

    Warns
    -----
    MlidWarning
        When the core warns about the record (units that look wrong).

    Examples
    --------
    A first-order system, xdot = a x + b u, simulated with a pulse and noise
    of sigma 0.01, then fitted from start values half the truth:

    >>> import numpy as np
    >>> import mlid
    >>> truth = mlid.LinearModel([[-2.0]], [[4.0]], [[1.0]], r=[1e-4])
    >>> t = np.arange(0.0, 5.0, 0.02)
    >>> u = np.where((t > 1.0) & (t < 2.0), 1.0, 0.0).reshape(-1, 1)
    >>> data, states = mlid.simulate(truth, t, u, seed=1)
    >>> start = mlid.LinearModel([[-1.0]], [[2.0]], [[1.0]], free=["f(1,1)", "g(1,1)"],
    ...                          names={"f(1,1)": "a", "g(1,1)": "b"})
    >>> res = mlid.fit(start, data)
    >>> res.converged
    True
    >>> res.params["estimate"].round(2).to_dict()
    {'a': -2.0, 'b': 3.99}
    >>> bool(np.all(abs(res.estimate - [-2.0, 4.0]) < 3 * res.sigma))
    True
    """
    _check_model(model)
    _check_data(data)
    setup = _setup(model, data, prior, prior_weight, bounds, initial_states, biases, options,
                   (x0_from, x0_samples))
    params, starts, (t, u, y), iopt, ropt = (setup[k] for k in ("params", "starts", "tuy",
                                                                 "iopt", "ropt"))
    h = _call_handle()
    _set_problem(h, model, params, setup["tuy"], starts, iopt, ropt)
    if prior is not None or prior_weight is not None or bounds:   # else none (the core's)
        _check(_api.mlid_set_extras(h.value, **_extras(params, prior, prior_weight, bounds)))
    counter, bar = counted(progress)
    start = time.perf_counter()
    with bar:
        status, msg = _api.mlid_fit(h.value, counter_id(counter))
    wall_time = time.perf_counter() - start      # the core call alone
    out = _values(h, 0, "call")
    if "status" not in out:             # refused before it ran: nothing to read
        check_status(status, msg)
    out["wall_time"] = wall_time
    out["message"] = _text(out["message"])
    return _result(model, data, setup, out, stacklevel=3)


def _setup(model, data, prior, prior_weight, bounds, initial_states, biases, options,
           x0=(None, None)):
    """What a fit's call and result are made of: the flat options and the
    options by name, the manoeuvres' parameter map (x0 = (x0_from,
    x0_samples): the measured states' x0 from the record), the record
    joined and its arrays, each manoeuvre's first sample."""
    iopt, ropt, opts = _flat_options(model, options)
    params, record, starts = _manoeuvres(model, data, initial_states, biases, *x0)
    return {"iopt": iopt, "ropt": ropt, "opts": opts, "params": params, "record": record,
            "starts": starts, "tuy": _record(model, record),
            "evaluate_args": (data, initial_states, biases)}


def fit_result(model, data, out, prior=None, prior_weight=None, bounds=None,
               initial_states=None, biases=None, x0_from=None, x0_samples=None, **options):
    """The FitResult of a fit the core has run already (a deck case run by
    the job runner, its numbers read by name: ``out`` has FIT_OUTPUTS), for
    ``fit``'s arguments, and its ``wall_time``; raises as ``fit`` does when
    it failed."""
    setup = _setup(model, data, prior, prior_weight, bounds, initial_states, biases, options,
                   (x0_from, x0_samples))
    return _result(model, data, setup, out, stacklevel=3)


def _result(model, data, setup, out, stacklevel):
    params, record, starts, opts = (setup[k] for k in ("params", "record", "starts", "opts"))
    theta, status, reason, niter = out["theta"], int(out["status"]), int(out["reason"]), \
        int(out["iterations"])
    text, bad = out["message"], int(out["bad_param"])
    free_names = params.free_names()
    if status and bad:                # the core numbers the free parameter; name it
        text = re.sub(rf"free parameter {bad}(?!\d)", repr(free_names[bad - 1]), text)
    if fit_outcome(status, reason) == "not run":       # bad input: nothing fitted
        check_status(status, text)
    if status == 0 and text.startswith("warning:"):
        warnings.warn(text[len("warning:"):].strip(), MlidWarning, stacklevel=stacklevel)
    fields = dict(yhat=out["yhat"].T.copy())
    fields.update(_frequency_fields(model, params, theta, *setup["tuy"], starts, setup["iopt"],
                                    setup["ropt"], opts, status, reason))
    free = params.free
    rnoise = out["r_innovations"]
    result = FitResult(
        start_model=model, data=record, options=opts,
        evaluate_args=setup["evaluate_args"], names=free_names,
        later=_later_fields(model, record, params, theta),
        start=out["theta_start"][free], estimate=theta[free],
        sigma=out["sigma"][free], covariance=out["covariance"], information=out["information"],
        gradient=out["gradient"], sigma_corrected=out["sigma_corrected"][free],
        covariance_corrected=out["covariance_corrected"], colored_lag=int(out["colored_lag"]),
        eigenvalues=out["eigenvalues"], eigenvectors=out["eigenvectors"], rhat=out["rhat"],
        cost=float(out["cost"]),
        r_innovations=rnoise.copy() if np.all(np.isfinite(rnoise)) else None,
        cost_history=out["cost_history"][:niter + 1].copy(), iterations=niter,
        converged=bool(out["converged"]), reason=stop_reason(reason), reason_code=reason,
        flat_options=setup["iopt"], flat_real_options=setup["ropt"], rank=int(out["rank"]),
        status=status, message=text, wall_time=out["wall_time"], **fields)
    if result.failed:                 # the error carries the last values
        check_status(status, text, result=result)
    return result


def _later_fields(model, record, params, theta):
    """What makes a fit's ``model``, ``manoeuvres`` and ``param_units`` when
    first asked for (FitResult.later): from a copy of the model and of the
    record's units as they are now, the fit's own theta and params (its map
    and mask), so that what they show does not depend on when they are made."""
    start = model.with_theta(model.theta)
    units = list(record.input_units), list(record.output_units)
    return {"model": functools.partial(params.model_of, theta, 0, start),
            "manoeuvres": functools.partial(_manoeuvre_models, params, theta, start),
            "param_units": functools.partial(_free_units, start, *units, params)}


def _manoeuvre_models(params, theta, base):
    return [params.model_of(theta, k, base) for k in range(params.n)]


def _frequency_fields(model, params, theta, t, u, y, starts, iopt, ropt, opts, status, reason):
    """A frequency-domain fit's data and fit at the estimate: ``frequencies``
    (Hz), ``z`` the measured left-hand sides and ``zhat`` (= ``yhat``) the
    model's, complex (nk, ny); {} for a time-domain fit or a failed one."""
    if opts["method"] not in FREQUENCY_METHODS or fit_outcome(status, reason) == "failed":
        return {}
    ev = _frequency_call(model, params, theta, t, u, y, starts, iopt, ropt, opts)
    return {"frequencies": ev["frequencies"], "z": ev["z"], "zhat": ev["zhat"],
            "yhat": ev["zhat"]}


def _free_units(model, input_units, output_units, params):
    """The unit of each free parameter of a fit (mlid_param_units)."""
    units = model.param_units(input_units, output_units)
    return [units[params.map[j]] for j in params.free]
