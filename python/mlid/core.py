"""Thin wrappers over the Fortran core (mlid._core): arrays in, arrays out."""

import functools
import numbers
import re
import time
import warnings

import numpy as np

from ._bridge import api as _api, text as _text
from .checks import real_array, whole
from .data import FlightData
from .errors import ConvergenceWarning, InputError, MlidWarning, check_status, guarded, status_text
from .maneuvers import Params, join
from .model import Model
from .progress import Silent, bar as progress_bar
from .outcome import fit_outcome
from .result import FitResult

#: Options that are the model's (Model.input_hold, Model.substeps), not fit()'s.
_MODEL_OPTIONS = ("input_hold", "substeps")


def _option_kinds():
    """The core's option table: {name: kind}, kind 'int', 'real', 'bool' or
    'choice'.  Names, positions and choices live in fortran/mlid_options.f90."""
    kinds, k = {}, 1
    while True:
        name, kind = (_text(v) for v in _api.mlid_option_info(k))
        if not name:
            return kinds
        kinds[name] = kind
        k += 1


_KINDS = _option_kinds()
_TYPES = {"int": int, "real": float, "bool": lambda s: s == "true", "choice": str}


def options_by_name(iopt, ropt):
    """Every option of the core's flat arrays, by name (the model's too)."""
    return {name: _TYPES[kind](_text(_api.mlid_option_get(iopt, ropt, name)))
            for name, kind in _KINDS.items()}


def _as_dict(iopt, ropt):
    opts = options_by_name(iopt, ropt)
    return {name: v for name, v in opts.items() if name not in _MODEL_OPTIONS}


def _as_text(value):
    if type(value) is str:          # a choice: as it is
        return value
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


@guarded
def default_options():
    """The core's default estimator options, by name.

    Returns
    -------
    dict
        {name: value} of every option ``fit`` takes (fortran/mlid_options.f90).
    """
    return _as_dict(*_api.mlid_default_options())


#: _flat_options' answers by the (name, text) pairs the core was given: the
#: core's options are a function of them, and asking it costs about 40 f2py
#: calls a fit (each option set, then every one read back).  Errors are
#: raised before anything is kept; cleared when full.
_OPTIONS_MADE = {}
_OPTIONS_KEPT = 256


def _flat_options(model, options):
    """The core's flat option arrays for fit() options and the model's own,
    set by name (the core checks names and values), and the options by name
    (copies: the caller may keep or change them)."""
    given = dict(options)
    unknown = [n for n in given if n not in _KINDS or n in _MODEL_OPTIONS]
    if unknown:
        raise InputError(f"unknown option {unknown[0]!r}; known: {', '.join(default_options())}")
    given.update(input_hold=model.input_hold, substeps=model.substeps)
    pairs = tuple((name, _as_text(value)) for name, value in given.items())
    made = _OPTIONS_MADE.get(pairs)
    if made is None:
        iopt, ropt = _api.mlid_default_options()
        for name, text in pairs:
            status, msg = _api.mlid_option_set(iopt, ropt, name, text)
            check_status(status, msg)
        check_status(*_api.mlid_options_check(iopt, ropt))
        made = iopt, ropt, _as_dict(iopt, ropt)
        if len(_OPTIONS_MADE) >= _OPTIONS_KEPT:
            _OPTIONS_MADE.clear()
        _OPTIONS_MADE[pairs] = made
    iopt, ropt, opts = made
    return iopt.copy(), ropt.copy(), dict(opts)


def stop_reason(code):
    """Why an iteration stopped, in the report's words (from the core)."""
    return _stop_text(int(code))


@functools.lru_cache(maxsize=256)
def _stop_text(code):
    return _text(_api.mlid_stop_reason(code))


def _check_model(model, name="model"):
    if not isinstance(model, Model):
        raise InputError(f"{name} must be a mlid model (LinearModel, LongitudinalModel, X22Model "
                         f"or UserModel), got {type(model).__name__}")


def _check_data(data):
    records = list(data) if isinstance(data, (list, tuple)) else [data]
    if not records or not all(isinstance(r, FlightData) for r in records):
        raise InputError("data must be a FlightData or a list of them (FlightData.load(path, "
                         f"...) reads a file), got {type(data).__name__}")


def _time_and_inputs(model, t, u):
    """t (nt,) and u (nt, nu) checked as a record's are (u given nu x nt is refused)."""
    rec = FlightData(t, u, np.zeros((np.size(t), 0)))
    if rec.u.shape[1] != model.nu:
        raise InputError(f"u has {rec.u.shape[1]} columns, the model has {model.nu} inputs")
    return rec.t, rec.u


def _model_args(model):
    """The model's part of every core call, by keyword."""
    return {"mkind": model.kind, "nx": model.nx, "nu": model.nu, "ny": model.ny,
            "nw": model.nw, "iconst": model.iconst, "rconst": model.rconst}


def _record(model, data):
    if data.u.shape[1] != model.nu:
        raise InputError(f"data has {data.u.shape[1]} input columns, the model has {model.nu} inputs")
    if data.y.shape[1] != model.ny:
        raise InputError(f"data has {data.y.shape[1]} output columns, the model has "
                         f"{model.ny} outputs")
    # (nt, n) C-ordered is the core's (n, nt) Fortran-ordered: no copy.
    u = np.ascontiguousarray(data.u, dtype=float).T
    y = np.ascontiguousarray(data.y, dtype=float).T
    return np.ascontiguousarray(data.t, dtype=float), u, y


#: fit()'s options that evaluate() does not take (they shape the iteration)
FIT_ONLY = ("prior", "prior_weight", "bounds")


def evaluate_options(options):
    """A fit's options as evaluate() takes them (FIT_ONLY left out)."""
    return {k: v for k, v in options.items() if k not in FIT_ONLY}


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
    nf = int(params.mask.sum())
    if prior_weight is None:
        weight = np.zeros((nf, nf))
    elif isinstance(prior_weight, dict):
        free = list(np.flatnonzero(params.mask))
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


def _manoeuvres(model, data, initial_states, biases):
    """The parameters and the record for one manoeuvre or several (a list)."""
    if isinstance(data, (list, tuple)):
        record, starts = join(list(data))
        return Params(model, len(data), initial_states, biases), record, starts
    if initial_states is not None or biases is not None:
        raise InputError("initial_states and biases are for several manoeuvres (a list of "
                         "records); one manoeuvre takes the model's x0 and bias")
    return Params(model), data, np.array([1], dtype=np.int32)


@guarded
def fit(model, data, prior=None, prior_weight=None, bounds=None, initial_states=None,
        biases=None, **options):
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
    **options
        Estimator options by name (defaults: ``default_options()``):

        method : 'output_error', 'filter_error', 'frequency_output_error' or \
'frequency_equation_error'
            Output error (§4.4): R estimated from the residuals.  Filter
            error (§4.1, §4.3): the Kalman filter with the model's process
            noise; q, r and S are parameters like any other.  A nonlinear
            model gets the extended Kalman filter, linearised over each
            sample interval.  The frequency-domain methods (linear models
            only, fortran/mlid_frequency.f90) fit the record's finite
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

    Returns
    -------
    FitResult
        Estimates, Cramer-Rao and coloured-residual sigmas, covariance,
        R-hat, outputs, cost history and how the iteration ended.  A run that
        ends without meeting a convergence test returns its last iterate with
        ``converged`` False.

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
    """
    _check_model(model)
    _check_data(data)
    iopt, ropt, opts = _flat_options(model, options)
    params, record, starts = _manoeuvres(model, data, initial_states, biases)
    t, u, y = _record(model, record)
    theta0, mask = params.theta, params.mask
    free_names = params.free_names()
    call = dict(**_model_args(model), theta0=theta0, isfree=mask, **params.ties, t=t, u=u, y=y,
                segstart=starts, iopt=iopt, ropt=ropt, nf=int(mask.sum()),
                nc=opts["max_iter"] + 1, **_extras(params, prior, prior_weight, bounds))
    start = time.perf_counter()
    (theta_start, theta, sigma, cov, info, grad, eigval, eigvec, rhat, yhat, cost_hist, cost,
     niter, reason, converged, rank, bad, sigma_c, cov_c, lag, rnoise, status,
     msg) = _api.mlid_fit(**call)
    wall = time.perf_counter() - start           # the core call alone
    text = msg.decode(errors="replace").strip()
    if status and bad:                # the core numbers the free parameter; name it
        text = re.sub(rf"free parameter {bad}(?!\d)", repr(free_names[bad - 1]), text)
    if fit_outcome(status, reason) == "not run":       # bad input: nothing fitted
        check_status(status, text)
    if status == 0 and text.startswith("warning:"):
        warnings.warn(text[len("warning:"):].strip(), MlidWarning, stacklevel=2)
    fields = dict(yhat=yhat.T.copy())
    fields.update(_frequency_fields(model, params, theta, t, u, y, starts, iopt, ropt, opts, status,
                                    reason))
    free = mask == 1
    result = FitResult(
        start_model=model, data=record, options=opts,
        evaluate_args=(data, initial_states, biases), names=free_names,
        later=_later_fields(model, record, params, theta),
        start=theta_start[free], estimate=theta[free],
        sigma=sigma[free], covariance=cov, information=info, gradient=grad,
        sigma_corrected=sigma_c[free], covariance_corrected=cov_c, colored_lag=int(lag),
        eigenvalues=eigval, eigenvectors=eigvec, rhat=rhat, cost=float(cost),
        r_innovations=rnoise.copy() if np.all(np.isfinite(rnoise)) else None,
        cost_history=cost_hist[:niter + 1].copy(), iterations=int(niter),
        converged=bool(converged), reason=stop_reason(reason), reason_code=int(reason),
        flat_options=iopt, flat_real_options=ropt, rank=int(rank),
        status=int(status), message=text, wall_time=wall, **fields)
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


#: The methods that fit the record's Fourier transform (fortran/mlid_frequency.f90).
FREQUENCY_METHODS = ("frequency_output_error", "frequency_equation_error")


def _frequency_fields(model, params, theta, t, u, y, starts, iopt, ropt, opts, status, reason):
    """A frequency-domain fit's data and fit at the estimate: ``frequencies``
    (Hz), ``z`` the measured left-hand sides and ``zhat`` (= ``yhat``) the
    model's, complex (nk, ny); {} for a time-domain fit or a failed one."""
    if opts["method"] not in FREQUENCY_METHODS or fit_outcome(status, reason) == "failed":
        return {}
    ev = _frequency_call(model, params, theta, t, u, y, starts, iopt, ropt, opts)
    return {"frequencies": ev["frequencies"], "z": ev["z"], "zhat": ev["zhat"],
            "yhat": ev["zhat"]}


def _frequency_call(model, params, theta, t, u, y, starts, iopt, ropt, opts):
    nk = opts["n_freq"] * len(starts)
    (freq, zre, zim, zhre, zhim, cost, grad, info, rhat, nterms, status,
     msg) = _api.mlid_freq_evaluate(
        **_model_args(model), theta=theta, isfree=params.mask, **params.ties, t=t, u=u, y=y,
        segstart=starts, iopt=iopt, ropt=ropt, nk=nk, nf=int(params.mask.sum()))
    check_status(status, msg)
    return {"frequencies": freq, "z": (zre + 1j * zim).T.copy(),
            "zhat": (zhre + 1j * zhim).T.copy(), "cost": float(cost), "gradient": grad,
            "information": info, "rhat": rhat, "transient_terms": int(nterms)}


@guarded
def frequency_evaluate(model, data, **options):
    """A frequency-domain method's cost, gradient and information at the
    model's values, without iterating (``evaluate``'s counterpart).

    Parameters
    ----------
    model : LinearModel
    data : FlightData or list of FlightData
    **options
        As for ``fit``; ``method`` one of 'frequency_output_error',
        'frequency_equation_error', and the band ``f_min``, ``f_max``,
        ``n_freq``.

    Returns
    -------
    dict
        ``frequencies`` (Hz), ``z`` and ``zhat`` (complex (nk, ny): the
        measured left-hand sides and the model's), ``cost``, ``gradient``
        and ``information`` over the free parameters, ``rhat`` (S-hat),
        ``transient_terms`` (how many of the initial and final states,
        constant forcing, output offsets and drift rates were estimated:
        those not linearly dependent on the others).

    Raises
    ------
    InputError
        As ``fit``; a time-domain method.
    """
    _check_model(model)
    _check_data(data)
    iopt, ropt, opts = _flat_options(model, options)
    if opts["method"] not in FREQUENCY_METHODS:
        raise InputError(f"frequency_evaluate takes method {' or '.join(FREQUENCY_METHODS)}, "
                         f"got {opts['method']!r}")
    params, record, starts = _manoeuvres(model, data, None, None)
    t, u, y = _record(model, record)
    return _frequency_call(model, params, params.theta, t, u, y, starts, iopt, ropt, opts)


def _free_units(model, input_units, output_units, params):
    """The unit of each free parameter of a fit (mlid_param_units)."""
    units = model.param_units(input_units, output_units)
    return [units[i] for i, f in zip(params.map, params.mask) if f]


@guarded
def evaluate(model, data, initial_states=None, biases=None, **options):
    """The likelihood and its derivatives at the model's current parameters
    (no iteration).

    Parameters
    ----------
    model, data, initial_states, biases, **options
        As for ``fit``.

    Returns
    -------
    dict
        ``cost``; ``gradient`` (nf,) and ``information`` (nf, nf) over the
        free parameters; ``rhat`` (ny, ny); ``yhat`` (nt, ny); ``sensitivity``
        (ny, nf), the output sensitivity norms: how many residual sigmas each
        free parameter moves each output over the record;
        ``weighted_sensitivity`` (ny, nt, nf): W(j) d yhat/d theta at each
        sample (W the inverse of R-hat, or of the innovation covariance; the
        sign of the innovation sensitivities for filter error); and
        ``information_sensitivity`` (nf, nf), the part of the information
        they make: the inputs of the coloured-residual correction
        (``mlid.core.colored_covariance``).

    Raises
    ------
    InputError
        As for ``fit``.
    SingularInformationError
        A residual or innovation covariance that is singular.
    DivergenceError
        The simulation diverged.
    """
    _check_model(model)
    _check_data(data)
    iopt, ropt, _ = _flat_options(model, options)
    params, record, starts = _manoeuvres(model, data, initial_states, biases)
    t, u, y = _record(model, record)
    mask = params.mask
    cost, grad, info, rhat, yhat, sens, wsens, msens, status, msg = _api.mlid_evaluate(
        **_model_args(model), theta=params.theta, isfree=mask, **params.ties, t=t, u=u,
        y=y, segstart=starts, iopt=iopt, ropt=ropt, nf=int(mask.sum()))
    check_status(status, msg)
    return {"cost": float(cost), "gradient": grad, "information": info, "rhat": rhat,
            "yhat": yhat.T.copy(), "sensitivity": sens, "weighted_sensitivity": wsens,
            "information_sensitivity": msens}


@guarded
def colored_covariance(weighted_sensitivity, residuals, covariance, information,
                       information_sensitivity, segment_starts=None, lag=None, rvv=None):
    """The Cramer-Rao covariance corrected for coloured residuals (the core's
    mlid_colored): cov [M - Ms + sum_i sum_j a(i)' w(|i-j|) Rvv(i-j) a(j)] cov.

    Parameters
    ----------
    weighted_sensitivity : array (ny, nt, nf)
        a(i), as ``evaluate`` returns it.
    residuals : array (nt, ny)
        Residuals (innovations) v(i).
    covariance, information, information_sensitivity : arrays (nf, nf)
        M^-1, M and Ms.
    segment_starts : sequence of int, optional
        First sample (1-based) of each manoeuvre; default one manoeuvre.
    lag : int, optional
        Largest lag; default chosen from the residuals by the core.
    rvv : array (nlag + 1, ny, ny), optional
        The residual autocovariance Rvv(0..nlag) to use instead of the
        residuals' (residuals and lag are then ignored).

    Returns
    -------
    (cov_c, lag): the corrected covariance (nf, nf) and the lag used.

    Raises
    ------
    InputError
        Sizes that do not agree, or bad segment starts.
    """
    a = np.asfortranarray(weighted_sensitivity, dtype=float)
    if a.ndim != 3:
        raise InputError("weighted_sensitivity must be (ny, nt, nf)")
    ny, nt, nf = a.shape
    seg = np.asarray([1] if segment_starts is None else segment_starts, dtype=np.int32)
    mats = [np.asfortranarray(m, dtype=float) for m in (covariance, information,
                                                         information_sensitivity)]
    if any(m.shape != (nf, nf) for m in mats):
        raise InputError(f"covariance, information and information_sensitivity must be "
                         f"{nf} x {nf}")
    if rvv is not None:
        r = np.asarray(rvv, dtype=float)
        if r.ndim != 3 or r.shape[1:] != (ny, ny):
            raise InputError(f"rvv must be (nlag + 1, {ny}, {ny})")
        cov_c, status, msg = _api.mlid_colored_cov_rvv(
            segstart=seg, a=a, nlag=len(r) - 1, rvv=np.asfortranarray(r.transpose(1, 2, 0)),
            cov=mats[0], info=mats[1], msens=mats[2])
        check_status(status, msg)
        return cov_c, len(r) - 1
    v = np.asarray(residuals, dtype=float)
    if v.shape != (nt, ny):
        raise InputError(f"residuals must be ({nt}, {ny}) like the sensitivities")
    cov_c, used, status, msg = _api.mlid_colored_cov(
        segstart=seg, a=a, v=np.asfortranarray(v.T), cov=mats[0], info=mats[1], msens=mats[2],
        lag_in=-1 if lag is None else int(lag))
    check_status(status, msg)
    return cov_c, int(used)


TIMINGS = ("forward", "backward")


@guarded
def simulate(model, t, u, noise_std=None, seed=0, output_names=None, input_names=None,
             timing="forward"):
    """Outputs of the model along t with inputs u, with the model's process
    and measurement noise (seeded).

    The process noise is held over each sample interval with variances q,
    correlated with the measurement noise through S; RK4 integrates each
    interval over its own length.

    Parameters
    ----------
    model : Model
        The model and its current parameters, q, r and S.
    t : array_like (nt,)
        Sample times, finite and increasing; uneven steps are taken as
        they are.
    u : array_like (nt, nu)
        Inputs, one row per sample.
    noise_std : array_like (ny,), optional
        Measurement-noise standard deviations replacing the model's
        (r = noise_std**2).
    seed : int
        Seed of the noise; the same seed gives the same record.
    output_names, input_names : list of str, optional
        Channel names of the record.
    timing : {'forward', 'backward'}
        Outputs that carry the process noise (accelerometers of the X-22
        model) get that of the interval after the sample ('forward', as the
        filter assumes) or before it ('backward'), report §5.1.5.

    Returns
    -------
    data : FlightData
        t, u and the noisy outputs.
    states : ndarray (nt, nx)
        The states along the record.

    Raises
    ------
    InputError
        Bad model, sizes, times, inputs, noise_std, seed or timing; noise
        covariances that are not positive semi-definite.
    DivergenceError
        The simulation diverged.
    """
    if timing not in TIMINGS:
        raise InputError(f"timing must be one of {TIMINGS}, got {timing!r}")
    _check_model(model)
    seed = whole("seed", seed)
    t, u = _time_and_inputs(model, t, u)
    if noise_std is not None:
        noise = real_array("noise_std", noise_std).ravel()
        if np.any(noise < 0):
            raise InputError(f"noise_std must be >= 0, got {noise.tolist()}")
        if noise.shape != (model.ny,):
            raise InputError(f"noise_std needs {model.ny} values (one per output), got "
                             f"{noise.size}")
        model = model.with_theta(model.theta)
        model.r = noise**2
    iopt, ropt, _ = _flat_options(model, {})
    y, x, status, msg = _api.mlid_simulate(**_model_args(model), theta=model.theta, t=t, u=u.T,
                                           seed=int(seed), timing=TIMINGS.index(timing),
                                           iopt=iopt, ropt=ropt)
    check_status(status, msg)
    return FlightData(t, u, y.T, input_names, output_names), x.T.copy()


def _mc_setup(truth, start, t, u, noise_std, runs, seed, options):
    """Checked arguments of Monte Carlo runs: the core call's keywords but the
    seed and run count, and the names and true values of the free parameters."""
    _check_model(truth, "truth")
    _check_model(start, "start")
    runs = whole("runs", runs, 1, 10**7)
    seed = whole("seed", seed, 0, 2**31 - runs)     # seeds seed .. seed + runs - 1
    if truth.theta.size != start.theta.size or list(truth.free) != list(start.free):
        raise InputError("truth and start models must have the same structure and free set")
    if noise_std is not None:
        truth = truth.with_theta(truth.theta)
        truth.r = real_array("noise_std", noise_std).ravel() ** 2
    iopt, ropt, _ = _flat_options(start, options)
    t, u = _time_and_inputs(start, t, u)
    mask = start.free_mask
    call = dict(**_model_args(start), theta_true=truth.theta, theta_start=start.theta,
                isfree=mask, **start.tie_args(), t=t, u=u.T, iopt=iopt, ropt=ropt,
                nf=int(mask.sum()))
    return call, runs, seed, start.free_names(), truth.theta[mask == 1]


def _mc_runs(call, seed, runs):
    """Runs seed .. seed + runs - 1 (run k's noise is seed k's whichever
    call makes it: the results do not depend on how runs are split)."""
    est, sig, info, iters, run_status, status, msg = _api.mlid_monte_carlo(
        **call, seed0=int(seed), nrun=int(runs))
    check_status(status, msg)
    return {"estimates": est.T.copy(), "sigma": sig.T.copy(),
            "information": np.moveaxis(info, 2, 0).copy(), "iterations": iters,
            "status": run_status}


def _mc_chunks(runs, seed, chunk):
    """(seed, runs) of each call: runs in order, chunk at a time."""
    return [(seed + k, min(chunk, runs - k)) for k in range(0, runs, chunk)]


#: What the summary of a Monte Carlo holds, over the runs with status 0 (the
#: core's statistics, those of the deck job 'monte_carlo' too): their number,
#: the mean estimate, sample sigma and mean Cramer-Rao sigma of each free
#: parameter, trace and det of the sample covariance and of the mean
#: information.
SUMMARY = ("runs", "mean", "sample_sigma", "mean_cr_sigma", "sample_cov_trace", "sample_cov_det",
           "mean_info_trace", "mean_info_det")


def _mc_result(parts, names, truth, stacklevel=4):
    """The runs of parts joined in order, the summary over the runs that
    succeeded (the core's), and a ConvergenceWarning naming how many did not."""
    out = {key: np.concatenate([p[key] for p in parts])
           for key in ("estimates", "sigma", "information", "iterations", "status")}
    out["names"], out["truth"] = names, truth
    nok, mean, sample_sigma, cr_sigma, stats = _api.mlid_monte_carlo_summary(
        est=np.asfortranarray(out["estimates"].T), sig=np.asfortranarray(out["sigma"].T),
        info=np.asfortranarray(np.moveaxis(out["information"], 0, 2)),
        run_status=out["status"])
    out["summary"] = dict(zip(SUMMARY, (int(nok), mean, sample_sigma, cr_sigma,
                                        *(float(v) for v in stats))))
    ok = out["status"] == 0
    bad = out["status"][~ok]
    if bad.size:
        kinds = ", ".join(f"{int((bad == s).sum())} {status_text(s)}"
                          for s in np.unique(bad))
        warnings.warn(
            f"{bad.size} of {ok.size} Monte Carlo runs failed ({kinds}): result['summary'] "
            f"is over the {int(ok.sum())} that converged; the per-run arrays hold every run, "
            "failed ones marked by result['status'] != 0 (estimates of a run that ran out of "
            "iterations are its last iterate, of a run with no result zeros)",
            ConvergenceWarning, stacklevel=stacklevel)
    return out


@guarded
def monte_carlo(truth, start, t, u, noise_std=None, runs=100, seed=1, progress=None,
                **options):
    """Seeded Monte Carlo of fits: simulate, fit, repeat.

    Run k (k = 0, 1, ...) simulates a record from ``truth`` with noise seed
    ``seed + k`` and fits it from ``start``; the results do not depend on how
    the runs are split (see ``monte_carlo_parallel``).

    Parameters
    ----------
    truth, start : Model
        The model the data come from (its process and measurement noise) and
        the one fitted, from its parameter values; same structure and free set.
    t : array_like, (nt,)
        Sample times.
    u : array_like, (nt, nu)
        Inputs.
    noise_std : array_like, (ny,), optional
        Measurement-noise standard deviations replacing the truth's.
    runs : int
        Number of runs, 1 to 10**7.
    seed : int
        Seed of the first run.
    progress : None, bool or stream
        A progress bar over the runs: None shows one when stderr is a
        terminal, True or False always or never, a stream writes it there.
    **options
        Fit options, as for ``fit``.

    Returns
    -------
    dict
        ``estimates`` and ``sigma`` (Cramer-Rao standard deviations), (runs,
        nf); ``information`` (runs, nf, nf); ``iterations`` and ``status``
        (runs,), status 0 for a converged run, else the core's status code
        (4 not converged, 2 singular information, 3 diverged); ``names`` and
        ``truth`` of the free parameters; ``summary``: over the runs with
        status 0, their number ``runs``, ``mean`` estimate, ``sample_sigma``,
        ``mean_cr_sigma``, and ``sample_cov_trace``, ``sample_cov_det``,
        ``mean_info_trace``, ``mean_info_det`` (the core's statistics, the
        same numbers as the deck job 'monte_carlo' reports).

    Raises
    ------
    InputError
        Models of different structure, bad times, inputs, options or sizes.

    Warns
    -----
    ConvergenceWarning
        When runs fail: how many of how many, and what ``summary`` leaves out.
    """
    call, runs, seed, names, truth_free = _mc_setup(truth, start, t, u, noise_std, runs, seed,
                                                    options)
    bar = progress_bar(progress, runs, "Monte Carlo", "run")
    chunk = runs if isinstance(bar, Silent) else max(1, runs // 100)
    parts = []
    with bar:
        for s, n in _mc_chunks(runs, seed, chunk):
            parts.append(_mc_runs(call, s, n))
            bar.update(n)
    return _mc_result(parts, names, truth_free)


@guarded
def input_signal(shape, amplitude, t_start, pulse_width, dt, nt):
    """A standard input shape on t = 0, dt, ..., (nt-1) dt: 'none', 'step',
    'pulse', 'doublet' or '3211' (pulse widths in multiples of pulse_width)."""
    nt = whole("nt", nt, 1, 10**7)
    if not isinstance(shape, str):
        raise InputError(f"shape must be a name ('none', 'step', 'pulse', 'doublet', '3211'), "
                         f"got {type(shape).__name__}")
    u, status, msg = _api.mlid_input_signal(shape, float(amplitude), float(t_start),
                                            float(pulse_width), float(dt), nt)
    check_status(status, msg)
    return u


@guarded
def check_jacobians(model, x, u, w=None):
    """Compare the model's analytic Jacobians with central differences, at
    one point and the model's parameters; write your own model's, then
    check them here.

    Parameters
    ----------
    model : Model
    x : array_like (nx,)
        State.
    u : array_like (nu,)
        Input.
    w : array_like (nw,), optional
        Process noise (default zero).

    Returns
    -------
    dict
        The largest relative difference for each of 'df/dx', 'df/dp',
        'dh/dx', 'dh/dp', 'df/dw' and 'dh/dw' ('dh/dw': how far dh/dw changes
        with w; the output noise must be linear in it).  Values near 1e-8 or
        below mean the Jacobians are right.  The Jacobians are those of the
        model's one evaluation of everything at the point (what the
        integration uses); asked for a part, it must give the same numbers,
        and a difference counts in the first four.

    Raises
    ------
    InputError
        x, u or w of the wrong size.
    """
    _check_model(model)
    w = np.zeros(model.nw) if w is None else np.asarray(w, dtype=float).reshape(model.nw)
    x, u = real_array("x", x).ravel(), real_array("u", u).ravel()
    if x.size != model.nx or u.size != model.nu:
        raise InputError(f"x and u have {x.size} and {u.size} values, the model has {model.nx} "
                         f"states and {model.nu} inputs")
    err, status, msg = _api.mlid_check_jacobians(
        **_model_args(model), np=model.np, p=model.theta[:model.np],
        x=x, u=u, w=w)
    check_status(status, msg)
    return dict(zip(("df/dx", "df/dp", "dh/dx", "dh/dp", "df/dw", "dh/dw"), err.tolist()))
