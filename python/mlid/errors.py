"""Exceptions raised by mlid, one per status code of the Fortran core, and
the guard that lets no other exception leave the public API."""

import functools
import inspect
import os


class MlidError(Exception):
    """Base class of every error mlid raises.  ``result``: the fit that
    failed, when a fit did (``result.failed``: its start and the last values
    it reached, no sigma, correlations or cost); else None."""

    result = None


class InputError(MlidError):
    """Bad input: deck, data file, dimensions, values or options."""


class SingularInformationError(MlidError):
    """The information matrix (or a residual covariance) is singular.

    Parameters
    ----------
    message : str
        What is singular and, where the core can tell, which parameters.
    result : FitResult, optional
        The failed fit, when there is one (``.result``).
    """

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


class DivergenceError(MlidError):
    """The simulation diverged: a state became NaN or infinite."""


class NonConvergenceError(MlidError):
    """An iteration that must converge to give a result did not (an input
    design's, the steady-state Kalman filter's).  A fit that runs out of
    iterations is not an error: its result says ``converged=False``.

    Parameters
    ----------
    message : str
        Which iteration, and how it ended.
    result : FitResult, optional
        The failed fit, when there is one (``.result``).
    """

    def __init__(self, message, result=None):
        super().__init__(message)
        self.result = result


class MlidWarning(UserWarning):
    """Something in the input looks wrong but the computation went on (units)."""


class ConvergenceWarning(MlidWarning):
    """Some runs of a batch (Monte Carlo) did not converge or failed; the
    others' results stand."""


class InternalError(MlidError):
    """A numerical library call failed unexpectedly."""


class OutOfMemoryError(MlidError, MemoryError):
    """The core could not allocate what a call needs (a record too long for
    this machine's memory): the message names what and its size.  Also a
    MemoryError."""


#: The core's status of a call that Ctrl-C interrupted: KeyboardInterrupt.
INTERRUPTED = 6

_BY_STATUS = {
    1: InputError,
    2: SingularInformationError,
    3: DivergenceError,
    4: NonConvergenceError,
    5: InternalError,
    7: OutOfMemoryError,
}


def status_of(error):
    """The core's status code of an mlid error (1, bad input, for any other)."""
    for status, cls in _BY_STATUS.items():
        if type(error) is cls:
            return status
    return 1


#: A core status code in a few words (a Monte Carlo run's status, say).
STATUS_TEXT = {0: "succeeded", 1: "bad input", 2: "singular information", 3: "diverged",
               4: "not converged", 5: "internal error", INTERRUPTED: "interrupted",
               7: "out of memory"}


def status_text(status):
    """A core status code in a few words (STATUS_TEXT)."""
    return STATUS_TEXT.get(int(status), f"status {int(status)}")


def check_status(status, msg, context="", result=None):
    """Raise the exception for a non-zero core status, with its message and
    the failed fit, when there is one, as ``.result``; KeyboardInterrupt
    for a call Ctrl-C interrupted (when Python's own handler has not raised
    it already)."""
    if status == 0:
        return
    text = msg.decode(errors="replace") if isinstance(msg, bytes) else str(msg)
    text = text.strip()
    if status == INTERRUPTED:
        raise KeyboardInterrupt(text)
    if context:
        text = f"{context}: {text}"
    error = _BY_STATUS.get(int(status), MlidError)(text)
    error.result = result
    raise error


#: What a wrong type, shape or value passed in raises inside numpy, f2py or
#: Python itself; f2py's own argument checks raise '_core.error'.
_MISUSE = (TypeError, ValueError, KeyError, IndexError, OverflowError, AttributeError)


def guarded(fn):
    """Only MlidError subclasses leave fn: misuse the explicit checks did not
    catch becomes InputError naming the function, anything else
    InternalError.  MLID_DEBUG=1 lets the original exception through."""
    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except MlidError:
            raise
        except MemoryError:
            raise OutOfMemoryError(f"{fn.__qualname__}: not enough memory for these sizes") \
                from None
        except Exception as exc:
            if os.environ.get("MLID_DEBUG"):
                raise
            misuse = isinstance(exc, _MISUSE) or type(exc).__name__ == "error"
            raise (InputError if misuse else InternalError)(
                f"{fn.__qualname__}: {type(exc).__name__}: {exc}") from None
    return call


def guarded_class(cls):
    """guarded() on the constructor and every public method of cls."""
    for name, member in list(vars(cls).items()):
        if inspect.isfunction(member) and (name == "__init__" or not name.startswith("_")):
            setattr(cls, name, guarded(member))
    return cls
