"""A model's outputs at one point, h(x, u, t), computed by the core: the
first sample of a simulation that starts there, with no noise (the core
takes records of two samples or more; the second is not used)."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle
from ..checks import real_array
from ..errors import InputError, check_status, guarded
from .calls import _check_model, _set_simulation


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

    Raises
    ------
    InputError
        x or u of the wrong size, values that are not finite.
    """
    _check_model(model)
    x = real_array("x", x, finite=True).ravel()
    u = real_array("u", u, finite=True).ravel()
    t = real_array("t", t, finite=True).ravel()
    if x.size != model.nx or u.size != model.nu or t.size != 1:
        raise InputError(f"x, u and t have {x.size}, {u.size} and {t.size} values; the model "
                         f"has {model.nx} states and {model.nu} inputs, and t is one time")
    m = model.with_theta(model.theta)
    m.x0, m.r = x, np.zeros(model.ny)
    iopt, ropt = _api.mlid_default_options()
    h = _call_handle()
    _set_simulation(h, m, (np.array([t[0], t[0] + 1.0]), np.repeat(u.reshape(-1, 1), 2, axis=1)),
                    iopt, ropt, free=False)
    y, _, status, msg = _api.mlid_simulate(h.value, seed=0, timing=0, ny=m.ny, nx=m.nx, nt=2)
    check_status(status, msg)
    return y[:, 0].copy()
