"""Global Fourier smoothing and the smoothed derivative of one channel (the
core's mlid_smooth, the same the decks' ``smooth(NAME)`` and ``deriv(NAME)``
use)."""

import numpy as np

from .._bridge import api as _api
from ..checks import real_array
from ..errors import InputError, check_status, guarded


def _smoothed(t, x, fc):
    t = real_array("t", t)
    x = real_array("x", x)
    if t.ndim != 1 or x.shape != t.shape:
        raise InputError(f"t and x must be 1-D arrays of one length (shapes {t.shape} and "
                         f"{x.shape})")
    if fc is None:
        fc = 0.0
    elif not (isinstance(fc, (int, float)) and np.isfinite(fc) and fc > 0):
        raise InputError(f"fc must be a frequency > 0 in Hz or None, not {fc!r}")
    xs, xd, fc, status, msg = _api.mlid_smooth_channel(t, x, float(fc))
    check_status(status, msg)
    return xs, xd, float(fc)


@guarded
def smooth(t, x, fc=None, cutoff=False):
    """x smoothed by the core's global Fourier smoother.

    The line through the first and last samples is removed, the rest
    mirrored (odd) and transformed; the cut-off is the first bin k, up from
    the largest, whose mean power over the bins k - h .. k + h, h = max(4, k/2), is at or
    below 10 times the noise floor (the median power of the upper half of
    the bins over 0.4549); the spectrum is passed up to it and rolled off
    by a raised cosine over a quarter of it
    (fortran/numerics/mlid_smooth.f90); the line is added back.

    Parameters
    ----------
    t : array_like (n,)
        Uniformly spaced times [s], n >= 16.
    x : array_like (n,)
        The channel.
    fc : float, optional
        The cut-off [Hz]; None: the rule's.
    cutoff : bool
        Also return the cut-off frequency [Hz].

    Returns
    -------
    numpy.ndarray (n,), and the cut-off [Hz] when ``cutoff``

    Raises
    ------
    InputError
        Fewer than 16 samples, non-uniform or non-finite times or samples.

    Examples
    --------
    >>> import numpy as np, mlid
    >>> t = np.arange(0, 20, 0.02)
    >>> rng = np.random.default_rng(1)
    >>> x = np.sin(2*np.pi*0.5*t) + 0.05*rng.standard_normal(t.size)
    >>> xs, fc = mlid.smooth(t, x, cutoff=True)
    >>> bool(np.std(xs - np.sin(2*np.pi*0.5*t)) < 0.02), 0.5 < fc < 3
    (True, True)
    """
    xs, _, fc = _smoothed(t, x, fc)
    return (xs, fc) if cutoff else xs


@guarded
def deriv(t, x, fc=None):
    """The derivative of x smoothed as by :func:`smooth`: the filtered
    spectrum times i 2 pi f transformed back, plus the slope of the line
    through the end points.

    Parameters
    ----------
    t : array_like (n,)
        Uniformly spaced times [s], n >= 16.
    x : array_like (n,)
        The channel.
    fc : float, optional
        The cut-off [Hz]; None: the rule's.

    Returns
    -------
    numpy.ndarray (n,)
        dx/dt in x's unit per second.

    Raises
    ------
    InputError
        As :func:`smooth`.

    Examples
    --------
    >>> import numpy as np, mlid
    >>> t = np.arange(0, 20, 0.02)
    >>> rng = np.random.default_rng(1)
    >>> x = np.sin(2*np.pi*0.5*t) + 0.05*rng.standard_normal(t.size)
    >>> xd = mlid.deriv(t, x)
    >>> bool(np.std(xd - np.pi*np.cos(2*np.pi*0.5*t)) < 0.2)
    True
    """
    return _smoothed(t, x, fc)[1]
