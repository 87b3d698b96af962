"""Fourier-transform regression in real time (the core's mlid_ftr): the
state equations' F and G from growing Fourier transforms, solved every few
samples."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..checks import real_array
from ..errors import InputError, check_status, guarded
from .rls import OnlineEstimate


def _whole(name, value, low):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InputError(f"{name} must be a whole number >= {low}, not {value!r}")
    return int(value)


@guarded
def ftr(t, x, u, frequencies, every=25, trim=10, first=1, forgetting=1.0):
    """Fourier-transform regression (Morelli's real-time method,
    fortran/estimation/online/mlid_ftr.f90): the transforms X(w), U(w) of
    the measured states and inputs gain each sample; every ``every``
    samples each state equation i w X_i = F(i,:) X + G(i,:) U is solved by
    least squares on the real parts over the band.

    Parameters
    ----------
    t : array_like (n,)
        Sample times [s].
    x : array_like (n, nx)
        The measured states (every state measured).
    u : array_like (n, nu)
        The inputs.
    frequencies : array_like (nw,)
        The band's frequencies [Hz], more than nx + nu.
    every : int
        Samples between solves (25 at 25 Hz: one a second).
    trim : int
        The trim removed from x and u first: the mean of the first ``trim``
        samples (0: none).
    first : int
        The first sample taken into the transforms (1-based; the textbook's
        ftr_mod starts at 2).
    forgetting : float
        lambda in (0, 1]: the transforms fade by lambda a sample, to track
        a change (memory about dt/(1 - lambda) s); 1: none.

    Returns
    -------
    OnlineEstimate
        At each solve's time: the estimates f(i,j) and g(i,l), equation by
        equation (F's row i, then G's), and their sigma (from each
        equation's residual variance over the band); NaN at a solve before
        the band is excited enough to determine them.

    Examples
    --------
    >>> import numpy as np, mlid
    >>> from mlid.design.signals import multistep
    >>> t = 0.02 * np.arange(1000)
    >>> de = multistep("3211", 1.0, 1.0, 0.5, 0.02, 1000)
    >>> m = mlid.LinearModel(F=[[-1.0, 1.0], [-4.0, -1.5]], G=[[0.1], [-6.0]], H=np.eye(2))
    >>> data, _ = mlid.simulate(m, t, de[:, None])
    >>> est = mlid.online.ftr(t, data.y, de, np.arange(0.1, 1.5, 0.05), every=50)
    >>> round(est.final["f(2,1)"], 2), round(est.final["g(2,1)"], 2)
    (-4.0, -6.0)
    """
    t = real_array("t", t)
    x = real_array("x", x)
    u = real_array("u", u)
    if x.ndim == 1:
        x = x[:, None]
    if u.ndim == 1:
        u = u[:, None]
    if t.ndim != 1 or x.shape[0] != t.size or u.shape[0] != t.size:
        raise InputError(f"t (n,), x (n, nx) and u (n, nu) need one row per sample (shapes "
                         f"{t.shape}, {x.shape}, {u.shape})")
    nx, nu = x.shape[1], u.shape[1]
    h = _call_handle()
    _put(h, frequencies=real_array("frequencies", frequencies), every=_whole("every", every, 1),
         trim=_whole("trim", trim, 0), first=_whole("first", first, 1),
         forgetting=float(real_array("forgetting", forgetting)))
    # (n, k) C-ordered is the core's (k, n) Fortran-ordered: no copy
    check_status(*_api.mlid_set_record(h.value, t=t, u=np.ascontiguousarray(u).T,
                                       y=np.ascontiguousarray(x).T, segstart=[1]))
    out = _run(h, _api.mlid_ftr)
    ts, est, sig = out["t_solve"], out["estimates"], out["sigma"]
    names = [n for i in range(1, nx + 1)
             for n in [f"f({i},{j})" for j in range(1, nx + 1)]
             + [f"g({i},{k})" for k in range(1, nu + 1)]]
    return OnlineEstimate(ts, names, est.T.copy(), sig.T.copy())
