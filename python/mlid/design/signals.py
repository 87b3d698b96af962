"""Standard input shapes (the core's mlid_input_signal)."""

from .._bridge import api as _api
from ..checks import whole
from ..errors import InputError, check_status, guarded


@guarded
def input_signal(shape, amplitude, t_start, pulse_width, dt, nt):
    """A standard input shape on t = 0, dt, ..., (nt-1) dt.

    Parameters
    ----------
    shape : {'none', 'step', 'pulse', 'doublet', '3211'}
        The shape; a 3211's pulses are 3, 2, 1 and 1 times pulse_width.
    amplitude : float
        Its height (the doublet and 3211 alternate its sign).
    t_start, pulse_width : float
        When it starts and its unit pulse width [s]; edges fall on whole
        samples.
    dt : float
        Sample step [s].
    nt : int
        Samples.

    Returns
    -------
    ndarray (nt,)

    Raises
    ------
    InputError
        An unknown shape, dt not > 0, a pulse shorter than one sample, nt
        out of range.

    Examples
    --------
    >>> from mlid.design.signals import input_signal
    >>> input_signal("doublet", 1.0, 0.1, 0.2, 0.1, 8)
    array([ 0.,  1.,  1., -1., -1.,  0.,  0.,  0.])
    """
    nt = whole("nt", nt, 1, 10**7)
    if not isinstance(shape, str):
        raise InputError(f"shape must be a name ('none', 'step', 'pulse', 'doublet', '3211'), "
                         f"got {type(shape).__name__}")
    u, status, msg = _api.mlid_input_signal(shape, float(amplitude), float(t_start),
                                            float(pulse_width), float(dt), nt)
    check_status(status, msg)
    return u
