"""Checks of what a caller passes in, each one clear line (InputError)."""

import numpy as np

from .errors import InputError


def real_array(name, a, finite=True):
    """a as a float64 array of real numbers (not complex, text or objects),
    finite unless finite=False.  A masked array with samples masked is
    refused: what a masked sample should be (cut, filled, interpolated) is
    the caller's choice, and dropping the mask would fit what it hides."""
    if np.ma.isMaskedArray(a):
        masked = int(np.ma.count_masked(a))
        if masked:
            raise InputError(f"{name} is a masked array with {masked} masked value"
                             f"{'s' if masked > 1 else ''}: cut the samples or fill them "
                             "(np.ma.filled, or interpolate) before passing it")
        a = np.ma.getdata(a)
    a = np.asarray(a)
    if a.dtype.kind not in "biuf":
        raise InputError(f"{name} must hold real numbers, got {a.dtype}")
    if finite and not np.all(np.isfinite(a)):
        raise InputError(f"{name} has a value that is not finite")
    return a.astype(float)


def whole(name, value, low=0, high=2**31 - 1):
    """A whole number within [low, high] (the core's integers are 32-bit)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InputError(f"{name} must be a whole number, got {value!r}")
    if not low <= value <= high:
        raise InputError(f"{name} must lie in {low} to {high}, got {value}")
    return int(value)


def pandas_for(what):
    """The pandas module, or one line saying that what needs it."""
    try:
        import pandas
    except ImportError:
        raise InputError(f"{what} needs pandas: pip install pandas") from None
    return pandas
