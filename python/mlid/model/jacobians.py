"""A model's analytic Jacobians checked against central differences (the
core's mlid_check_jacobians)."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put
from ..checks import real_array
from ..errors import InputError, check_status, guarded
from .calls import _check_model, _set_model


@guarded
def check_jacobians(model, x, u, w=None):
    """Compare the model's analytic Jacobians with central differences, at
    one point and the model's parameters; write your own model's, then
    check them here.

    Parameters
    ----------
    model : Model
    x : array_like (nx,)
        State.
    u : array_like (nu,)
        Input.
    w : array_like (nw,), optional
        Process noise (default zero).

    Returns
    -------
    dict
        The largest relative difference for each of 'df/dx', 'df/dp',
        'dh/dx', 'dh/dp', 'df/dw' and 'dh/dw' ('dh/dw': how far dh/dw changes
        with w; the output noise must be linear in it).  Values near 1e-8 or
        below mean the Jacobians are right.  The Jacobians are those of the
        model's one evaluation of everything at the point (what the
        integration uses); asked for a part, it must give the same numbers,
        and a difference counts in the first four.

    Raises
    ------
    InputError
        x, u or w of the wrong size.
    """
    _check_model(model)
    w = np.zeros(model.nw) if w is None else np.asarray(w, dtype=float).reshape(model.nw)
    x, u = real_array("x", x).ravel(), real_array("u", u).ravel()
    if x.size != model.nx or u.size != model.nu:
        raise InputError(f"x and u have {x.size} and {u.size} values, the model has {model.nx} "
                         f"states and {model.nu} inputs")
    h = _call_handle()
    _set_model(h, model)
    _put(h, p=model.theta[:model.np], x=x, u=u, w=w)
    err, status, msg = _api.mlid_check_jacobians(h.value)
    check_status(status, msg)
    return dict(zip(("df/dx", "df/dp", "dh/dx", "dh/dp", "df/dw", "dh/dw"), err.tolist()))
