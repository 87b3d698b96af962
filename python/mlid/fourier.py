"""The finite Fourier transform of records at chosen frequencies (the core's
mlid_fourier): what the frequency-domain methods of ``fit`` work on."""

import numpy as np

from . import _core
from .checks import real_array
from .errors import InputError, check_status, guarded

_api = _core.mlid_api


@guarded
def fourier_transform(t, x, freq):
    """X(f) = integral over the record of x(t) exp(-i 2 pi f t) dt.

    Exact (to rounding) for the straight lines between the samples: the sum
    over the samples times the interior weight W(w dt) plus end-point terms
    (fortran/mlid_fourier.f90), at any frequencies, not an FFT grid.

    Parameters
    ----------
    t : array_like (n,)
        Uniformly spaced sample times.
    x : array_like (n,) or (n, nch)
        The channels, one column each.
    freq : array_like (nf,)
        Frequencies in Hz.

    Returns
    -------
    ndarray, complex (nf,) or (nf, nch)
        The transform of each channel at each frequency.

    Raises
    ------
    InputError
        Fewer than two samples, sampling not uniform, values not finite.
    """
    t = real_array("t", t)
    xa = real_array("x", x)
    one = xa.ndim == 1
    xa = xa.reshape(len(xa), -1) if one else xa
    f = np.atleast_1d(real_array("freq", freq))
    if t.ndim != 1 or xa.ndim != 2 or len(t) != xa.shape[0]:
        raise InputError(f"x must have one row per sample of t ({len(t)}), got shape "
                         f"{np.shape(x)}")
    if len(t) < 2:
        raise InputError("a record to transform needs at least two samples")
    dt = (t[-1] - t[0]) / (len(t) - 1)
    if not np.allclose(np.diff(t), dt, rtol=1e-6, atol=0.0):
        raise InputError("the Fourier transform needs uniformly spaced samples")
    xre, xim, status, msg = _api.mlid_fourier_transform(
        np.asfortranarray(xa.T), dt, t[0], 2.0 * np.pi * f)
    check_status(status, msg)
    xf = (xre + 1j * xim).T
    return xf[:, 0] if one else xf
