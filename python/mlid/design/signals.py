"""Standard input shapes (the core's mlid_input_signal)."""

from .._bridge import api as _api
from ..checks import whole
from ..errors import InputError, check_status, guarded


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
