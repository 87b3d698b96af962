"""A model at one point: its outputs h(x, u, t) (without output biases)
and state derivatives f(x, u, t), evaluated by the core (mlid_model_point;
nothing is integrated), the process noise zero."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..checks import real_array
from ..errors import InputError, guarded
from .calls import _check_model, _set_model


@guarded
def outputs_at(model, x, u, t=0.0):
    """The model's outputs where its states are x and its inputs u, at time t.

    Parameters
    ----------
    model : Model
    x : array_like (nx,)
    u : array_like (nu,)
    t : float

    Returns
    -------
    ndarray (ny,)
        h(x, u, t) at the model's parameters, without the output biases.

    Raises
    ------
    InputError
        x or u of the wrong size, values that are not finite.
    """
    return _point(model, x, u, t)["y"]


@guarded
def derivatives_at(model, x, u, t=0.0):
    """The model's state derivatives f(x, u, t) (as ``outputs_at``).

    Returns
    -------
    ndarray (nx,)
    """
    return _point(model, x, u, t)["xdot"]


def _point(model, x, u, t):
    _check_model(model)
    x = real_array("x", x, finite=True).ravel()
    u = real_array("u", u, finite=True).ravel()
    t = real_array("t", t, finite=True).ravel()
    if x.size != model.nx or u.size != model.nu or t.size != 1:
        raise InputError(f"x, u and t have {x.size}, {u.size} and {t.size} values; the model "
                         f"has {model.nx} states and {model.nu} inputs, and t is one time")
    h = _call_handle()
    _set_model(h, model)
    _put(h, p=model.theta[:model.np], x=x, u=u, t=t)
    out = _run(h, _api.mlid_model_point)
    return {k: np.asarray(out[k], dtype=float).ravel() for k in ("y", "xdot")}
