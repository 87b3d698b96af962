"""The likelihood and its derivatives at the model's current parameters,
without iterating: in the time domain (``evaluate``) and the frequency domain
(``frequency_evaluate``)."""

from .._bridge import api as _api, call_handle as _call_handle, run as _run
from ..errors import InputError, guarded
from ..model.calls import _check_data, _check_model, _manoeuvres, _record, _set_params, _set_problem
from .options import _flat_options


#: The methods that fit the record's Fourier transform (fortran/estimation/frequency_domain/mlid_frequency.f90).
FREQUENCY_METHODS = ("frequency_output_error", "frequency_equation_error")


def _frequency_call(model, params, theta, t, u, y, starts, iopt, ropt, opts):
    """The core's frequency-domain data and fit at theta (all of params'
    entries) on the record (t, u, y) of manoeuvres from samples starts:
    ``frequency_evaluate``'s dict.  (opts: the core counts the frequencies
    from the options itself.)"""
    h = _call_handle()
    _set_problem(h, model, params, (t, u, y), starts, iopt, ropt)
    _set_params(h, params, theta)
    out = _run(h, _api.mlid_freq_evaluate)
    return {"frequencies": out["frequencies"], "z": (out["z_re"] + 1j * out["z_im"]).T.copy(),
            "zhat": (out["zhat_re"] + 1j * out["zhat_im"]).T.copy(), "cost": out["cost"],
            "gradient": out["gradient"], "information": out["information"], "rhat": out["rhat"],
            "transient_terms": out["transient_terms"]}


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


@guarded
def evaluate(model, data, initial_states=None, biases=None, x0_from=None, x0_samples=None,
             **options):
    """The likelihood and its derivatives at the model's current parameters
    (no iteration).

    Parameters
    ----------
    model, data, initial_states, biases, x0_from, x0_samples, **options
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
        (``mlid.estimate.colored.colored_covariance``).

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
    params, record, starts = _manoeuvres(model, data, initial_states, biases, x0_from, x0_samples)
    h = _call_handle()
    _set_problem(h, model, params, _record(model, record), starts, iopt, ropt)
    out = _run(h, _api.mlid_evaluate)
    out["yhat"] = out["yhat"].T.copy()
    return out
