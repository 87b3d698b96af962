"""What a fit has to show, as the core decides from its status and stop
reason: estimates, or only the last values reached (a failed fit), or
nothing (not run); and the refusal of a failed fit where estimates are
needed."""

import functools

from .._bridge import api as _api
from ..errors import InputError

#: The core's fit outcomes (mlid_kinds FIT_*), by code.
OUTCOMES = ("estimates", "failed", "not run")


def fit_outcome(status, reason):
    """What a fit that ended with a core status and stop reason has to show.

    Parameters
    ----------
    status, reason : int
        The core's status code and stop reason (mlid_kinds).

    Returns
    -------
    str
        'estimates' (converged or not), 'failed' (an error ended it: only the
        last values reached) or 'not run' (bad input), as the core decides.
    """
    return OUTCOMES[_outcome_code(int(status), int(reason))]


@functools.lru_cache(maxsize=256)
def _outcome_code(status, reason):
    """The core's answer, kept: a fit asks it three times."""
    return int(_api.mlid_fit_outcome(status, reason))


def require_estimates(result, what):
    """Refuse a failed fit where estimates are needed.

    Parameters
    ----------
    result : FitResult
    what : str
        What needs them ('plot', 'results table').

    Raises
    ------
    InputError
        If the fit failed: it has only the last values it reached.
    """
    if getattr(result, "failed", False):
        raise InputError(f"no {what} of a failed fit (it has last values, not estimates): "
                         f"{result.message}")
