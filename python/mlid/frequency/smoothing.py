"""Smoothing and the smoothed derivative of one channel: the global Fourier
smoother (the core's mlid_smooth, the decks' ``smooth(NAME)`` and
``deriv(NAME)``) or the local one (mlid_local_smooth, ``smooth_local(NAME)``
and ``deriv_local(NAME)``)."""

import numpy as np

from .._bridge import api as _api
from ..checks import real_array
from ..errors import InputError, check_status, guarded


#: method -> the core's switch (mlid_smooth_channel's local)
METHODS = {"fourier": 0, "local": 1}


def _smoothed(t, x, fc, method):
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(map(repr, METHODS))}, not {method!r}")
    t = real_array("t", t)
    x = real_array("x", x)
    if t.ndim != 1 or x.shape != t.shape:
        raise InputError(f"t and x must be 1-D arrays of one length (shapes {t.shape} and "
                         f"{x.shape})")
    if fc is None:
        fc = 0.0
    elif not (isinstance(fc, (int, float)) and np.isfinite(fc) and fc > 0):
        raise InputError(f"fc must be a frequency > 0 in Hz or None, not {fc!r}")
    xs, xd, fc, status, msg = _api.mlid_smooth_channel(t, x, float(fc), METHODS[method])
    check_status(status, msg)
    return xs, xd, float(fc)


@guarded
def smooth(t, x, fc=None, cutoff=False, method="fourier"):
    """x smoothed by the core's global Fourier smoother (or its local one).

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
        Also return the cut-off frequency [Hz] (0 for the local smoother).
    method : {'fourier', 'local'}
        'local': Spencer's 15-point moving average, shorter formulas toward
        the ends (fortran/numerics/mlid_local_smooth.f90, the textbook's
        preprocessing); no cut-off.

    Returns
    -------
    numpy.ndarray (n,), and the cut-off [Hz] when ``cutoff``

    Raises
    ------
    InputError
        Fewer than 16 samples (local: 5), non-uniform or non-finite times or
        samples, an unknown method, a cut-off for the local smoother.

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
    xs, _, fc = _smoothed(t, x, fc, method)
    return (xs, fc) if cutoff else xs


@guarded
def deriv(t, x, fc=None, method="fourier"):
    """The derivative of x smoothed as by :func:`smooth`: the filtered
    spectrum times i 2 pi f transformed back, plus the slope of the line
    through the end points; or (method 'local') the central difference of
    the local smoother's output, on 17 points inside and 5 toward the ends,
    the two end samples at each end held at the third's value.

    Parameters
    ----------
    t : array_like (n,)
        Uniformly spaced times [s], n >= 16.
    x : array_like (n,)
        The channel.
    fc : float, optional
        The cut-off [Hz]; None: the rule's.
    method : {'fourier', 'local'}
        As :func:`smooth`.

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
    return _smoothed(t, x, fc, method)[1]
