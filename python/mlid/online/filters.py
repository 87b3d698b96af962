"""Augmented-state Kalman filters for parameter estimation, sample by sample
(the core's mlid_online_ekf and mlid_online_ukf), for any mlid model."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run_call
from ..checks import real_array
from ..data.flight_data import FlightData
from ..errors import InputError, guarded
from ..estimate.options import _flat_options
from ..model.calls import _check, _check_model, _record, _set_simulation
from .rls import OnlineEstimate

_METHODS = {"ekf": 1, "ukf": 2, "ukf_augmented": 3, "efrls": 4}


def _per_entry(name, value, n, what):
    """A scalar or n values, as n floats."""
    a = real_array(name, value).ravel()
    if a.size == 1:
        a = np.full(n, a[0])
    if a.size != n:
        raise InputError(f"{name} needs {n} values ({what}) or one for all, got {a.size}")
    return a


def _run(method, model, data, free, p0, q, r, ut, delta, r_fading=0.0, forget=0.0):
    _check_model(model)
    if not isinstance(data, FlightData):
        raise InputError("data must be one FlightData (the filters run on one record; join "
                         f"the manoeuvres into one), got {type(data).__name__}")
    if model.ties:
        raise InputError("the online filters do not follow ties: give the model without them")
    free = list(model.free if free is None else [model.canonical_name(n) for n in free])
    if not free:
        raise InputError("no free parameters to estimate")
    labels = [model.names.get(n, n) for n in free]
    names = model._layout.names
    np_model = model._layout.slice("x0").start
    idx = [names.index(n) for n in free]
    outside = [lab for lab, k in zip(labels, idx) if k >= np_model]
    if outside:
        raise InputError(f"the online filters estimate model parameters only, not {outside[0]!r}")
    n = model.nx + len(free)
    what = f"{model.nx} states, then {len(free)} parameters"
    p0 = _per_entry("p0", p0, n, what)
    q = _per_entry("q", q, n, what)
    r = _per_entry("r", model.r if r is None else r, model.ny, "one per output")
    t, u, y = _record(model, data)
    iopt, ropt, _ = _flat_options(model, {})
    h = _call_handle()
    _set_simulation(h, model, (t, u), iopt, ropt, free=False)
    _check(_api.mlid_set_record(h.value, t=t, u=u, y=y, segstart=np.ones(1, dtype=np.int32)))
    alpha, beta, kappa = ut
    _put(h, method=_METHODS[method], ifree=np.array(idx, dtype=np.int32) + 1, p0=p0, q=q, r=r,
         ut=np.array([alpha, beta, 0.0 if kappa is None else kappa], dtype=float),
         kappa_given=int(kappa is not None), delta=float(delta), r_fade=float(r_fading),
         forget=float(forget))
    out = _run_call(h, _api.mlid_online_filter)
    est, sig = out["est"], out["sig"]
    nx = model.nx
    noise = out["rhist"].T.copy() if r_fading else None
    return OnlineEstimate(t, labels, est[nx:].T.copy(), sig[nx:].T.copy(),
                          states=est[:nx].T.copy(), states_sigma=sig[:nx].T.copy(),
                          noise=noise)


_PARAMS = """
    Parameters
    ----------
    model : Model
        Any mlid model: its x0 starts the states, its values of the free
        parameters start their estimates, its output biases stay fixed;
        its input_hold and substeps set the integration.
    data : FlightData
        One record, run straight through.
    free : list of str, optional
        The model parameters to estimate (default: the model's free ones).
    p0 : float or array_like (nx + nf,)
        The start variances of the states, then of the free parameters.
    q : float or array_like (nx + nf,)
        Process-noise variances added to the predicted covariance at each
        sample (discrete): on the states, and on the parameters a random
        walk that lets the estimates follow a change (0: constant).
    r : array_like (ny,), optional
        The measurement-noise variances (default: the model's r).
"""

_RETURNS = """
    Returns
    -------
    OnlineEstimate
        Estimates and sigma = sqrt(diag P) after each sample, and the
        states' (``states``, ``states_sigma``).
"""


def _doc(f):
    """Fill the shared parameters and returns into f's docstring (none under
    python -OO)."""
    if f.__doc__ is not None:
        f.__doc__ = f.__doc__.format(params=_PARAMS, returns=_RETURNS)
    return f


@guarded
@_doc
def ekf(model, data, free=None, p0=10.0, q=0.0, r=None, differences=0.0, r_fading=0.0):
    """Extended Kalman filter with the state augmented by the free parameters
    (fortran/estimation/online/mlid_online_ekf.f90): the model's integration
    from sample to sample, Phi = exp(A dt) with the model's exact Jacobians,
    P- = Phi P Phi' + diag(q), the update in Joseph form.  The first sample
    is an update alone (x0, p0 are the predicted values there).
    {params}    differences : float
        > 0: the Jacobians by central differences with this step instead
        (the textbook's choice, for comparison).
    r_fading : float
        In (0, 1): R adapted after each update from the residuals, with
        this fading memory b (R = (1 - d) R + d (e^2 + diag C P C'), d =
        (1 - b)/(1 - b^k), Sage and Husa; about 1/(1 - b) samples
        remembered), r its start; the history in ``noise``.  0: r given.
    {returns}
    Examples
    --------
    >>> import numpy as np, mlid
    >>> truth = mlid.LinearModel([[-1.0, 1.0], [-4.0, -2.0]], [[0.0], [-6.0]], np.eye(2),
    ...                          r=[1e-6, 1e-6])
    >>> t = np.arange(500) * 0.04
    >>> u = np.where((t % 4) < 2, 0.02, -0.02)[:, None]
    >>> data, _ = mlid.simulate(truth, t, u, seed=1)
    >>> start = mlid.LinearModel([[-1.0, 1.0], [-3.0, -2.0]], [[0.0], [-4.0]], np.eye(2),
    ...                          free=["f(2,1)", "g(2,1)"], names={{"g(2,1)": "M_de"}})
    >>> est = mlid.online.ekf(start, data, q=[1e-8, 1e-8, 0, 0], r=[1e-6, 1e-6])
    >>> round(est.final["M_de"], 1)
    -6.0
    """
    return _run("ekf", model, data, free, p0, q, r, (0.5, 2.0, None), differences, r_fading)


@guarded
@_doc
def efrls(model, data, free=None, forgetting=1.0, p0=10.0, q=0.0, r=None, differences=0.0):
    """Extended forgetting-factor recursive least squares (the textbook's
    EFRLS, sec. 7.4): the extended Kalman filter's recursion
    (fortran/estimation/online/mlid_online_ekf.f90) with the innovation
    weighted by lambda R and P divided by lambda after each update, so
    that a sample's weight decays as lambda^k; no update at the first
    sample (x0 and p0 are the estimate there).
    {params}    forgetting : float
        lambda in (0, 1]; 1 (the deck's default too): no forgetting, a memory
        of about 1/(1 - lambda) samples otherwise (the textbook's test case
        11: 0.998).
    differences : float
        > 0: the Jacobians by central differences with this step.

    The textbook weights every output by 1 (r = 1): its P is then not a
    covariance.  With r the measurement-noise variances, sigma is a
    standard deviation inflated by the forgetting.
    {returns}"""
    return _run("efrls", model, data, free, p0, q, r, (0.5, 2.0, None), differences,
                forget=forgetting)


@guarded
@_doc
def ukf(model, data, free=None, p0=10.0, q=0.0, r=None, augmented=False, alpha=0.5, beta=2.0,
        kappa=None, r_fading=0.0):
    """Unscented Kalman filter with the state augmented by the free
    parameters (fortran/estimation/online/mlid_online_ukf.f90): 2N + 1 sigma
    points from the symmetric square root of P, each carried by the model's
    integration.
    {params}    augmented : bool
        The augmented-noise form: the model's noise inputs w (variances:
        the model's q; it needs nw > 0, e.g. a linear model's Gamma) held
        over each interval and the measurement noise sampled with the
        state, N = nx + nf + nw + ny; q is still added to the predicted
        covariance (0 for the textbook's form).
    alpha, beta, kappa : float
        The unscented transform's spread, prior and scaling (kappa None:
        3 - N).
    r_fading : float
        In (0, 1): R adapted after each update as the EKF's (Sage and
        Husa's fading memory b, about 1/(1 - b) samples remembered), with
        diag C P C' from the transform's own moments, R - R Pyy^-1 R; r its
        start (in the augmented form, the sampled measurement noise's
        variances); the history in ``noise``.  0: r given.
    {returns}"""
    method = "ukf_augmented" if augmented else "ukf"
    return _run(method, model, data, free, p0, q, r, (alpha, beta, kappa), 0.0, r_fading)
