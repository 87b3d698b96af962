"""Exceptions raised by mlid, one per status code of the Fortran core."""


class MlidError(Exception):
    """Base class of every error mlid raises."""


class InputError(MlidError):
    """Bad input: deck, data file, dimensions, values or options."""


class SingularInformationError(MlidError):
    """The information matrix (or a residual covariance) is singular.

    ``result`` holds the fit as far as it got, when there is one.
    """

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


class DivergenceError(MlidError):
    """The simulation diverged: a state became NaN or infinite."""


class NonConvergenceError(MlidError):
    """The iteration ended without meeting a convergence test."""

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


class MlidWarning(UserWarning):
    """Something in the input looks wrong but the computation went on (units)."""


class InternalError(MlidError):
    """A numerical library call failed unexpectedly."""


_BY_STATUS = {
    1: InputError,
    2: SingularInformationError,
    3: DivergenceError,
    4: NonConvergenceError,
    5: InternalError,
}


def status_of(error):
    """The core's status code of an mlid error (1, bad input, for any other)."""
    for status, cls in _BY_STATUS.items():
        if type(error) is cls:
            return status
    return 1


def check_status(status, msg, context=""):
    """Raise the exception for a non-zero core status, with its message."""
    if status == 0:
        return
    text = msg.decode(errors="replace") if isinstance(msg, bytes) else str(msg)
    text = text.strip()
    if context:
        text = f"{context}: {text}"
    raise _BY_STATUS.get(int(status), MlidError)(text)
