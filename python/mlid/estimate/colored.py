"""The Cramer-Rao covariance corrected for coloured residuals (the core's
mlid_colored), from what ``evaluate`` gives."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..errors import InputError, guarded


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
    h = _call_handle()
    given = dict(segstart=seg, a=a, cov=mats[0], info=mats[1], msens=mats[2])
    if rvv is not None:
        r = np.asarray(rvv, dtype=float)
        if r.ndim != 3 or r.shape[1:] != (ny, ny):
            raise InputError(f"rvv must be (nlag + 1, {ny}, {ny})")
        _put(h, **given, rvv=r.transpose(1, 2, 0))
    else:
        v = np.asarray(residuals, dtype=float)
        if v.shape != (nt, ny):
            raise InputError(f"residuals must be ({nt}, {ny}) like the sensitivities")
        _put(h, **given, v=v.T, lag=-1 if lag is None else int(lag))
    out = _run(h, _api.mlid_colored_cov)
    return out["covariance_corrected"], out["lag"]
