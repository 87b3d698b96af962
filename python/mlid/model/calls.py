"""A model's and a record's part of every core call, checked: the model's
sizes and constants by keyword, the record's arrays in the core's layout,
and the parameters and joined record of one manoeuvre or several."""

import numpy as np

from .._bridge import api, call_handle, put, run
from ..data.flight_data import FlightData
from ..errors import InputError, check_status
from .maneuvers import Params, join
from .models import Model


def _check_model(model, name="model"):
    if not isinstance(model, Model):
        raise InputError(f"{name} must be a mlid model (LinearModel, LongitudinalModel, X22Model "
                         f"or UserModel), got {type(model).__name__}")


def _check_data(data):
    records = list(data) if isinstance(data, (list, tuple)) else [data]
    if not records or not all(isinstance(r, FlightData) for r in records):
        raise InputError("data must be a FlightData or a list of them (FlightData.load(path, "
                         f"...) reads a file), got {type(data).__name__}")


def _time_and_inputs(model, t, u):
    """t (nt,) and u (nt, nu) checked as a record's are (u given nu x nt is refused)."""
    rec = FlightData(t, u, np.zeros((np.size(t), 0)))
    if rec.u.shape[1] != model.nu:
        raise InputError(f"u has {rec.u.shape[1]} columns, the model has {model.nu} inputs")
    return rec.t, rec.u


def _model_args(model):
    """The model's part of every core call, by keyword."""
    return {"mkind": model.kind, "nx": model.nx, "nu": model.nu, "ny": model.ny,
            "nw": model.nw, "iconst": model.iconst, "rconst": model.rconst}


def _check(status_msg):
    """Raise for a core call's (status, message) that is not OK."""
    if status_msg[0]:
        check_status(*status_msg)


def _set_problem(h, model, params, tuy, starts, iopt, ropt):
    """The parts of a call's problem into handle h (mlid_api_problem): the
    model, the parameters (params: a Params), the record (t, u, y) in the
    core's layout with each manoeuvre's first sample, and the options."""
    t, u, y = tuy
    hv = h.value
    _check(api.mlid_set_model(hv, **_model_args(model)))
    _check(api.mlid_set_params(hv, theta0=params.theta, isfree=params.mask, **params.ties))
    _check(api.mlid_set_record(hv, t=t, u=u, y=y, segstart=starts))
    _check(api.mlid_set_options(hv, iopt, ropt))


# The parts one at a time, for the calls that need only some of them.
def _set_model(h, model):
    """The model part of a call's problem into handle h (mlid_api_problem)."""
    _check(api.mlid_set_model(h.value, **_model_args(model)))


def _set_params(h, params, theta=None):
    """The parameters part into handle h: params (a Params) at theta (all
    its entries, e.g. a fit's estimate) when given, else at its own."""
    _check(api.mlid_set_params(h.value, theta0=params.theta if theta is None else theta,
                               isfree=params.mask, **params.ties))


def _set_record(h, tuy, starts):
    """The record (t, u, y) in the core's layout, with each manoeuvre's
    first sample, into handle h's problem (mlid_api_problem)."""
    t, u, y = tuy
    _check(api.mlid_set_record(h.value, t=t, u=u, y=y, segstart=starts))


def _set_simulation(h, model, tu, iopt, ropt, free=True):
    """The parts of a call that simulates a model (mlid_simulate, and
    mlid_monte_carlo's fits of what it simulates) into handle h
    (mlid_api_problem): the model; its parameters, with its free set and
    ties (a fit's start) or, free False, none; a record of times and inputs
    tu = (t, u) in the core's layout whose outputs are not made yet (zero);
    the options."""
    t, u = tu
    n = model.theta.size
    if free:
        params = {"isfree": model.free_places, **model.tie_args()}
    else:           # no tie is ntie = 0 over arrays of one (f2py wants an element)
        one = np.zeros(1, dtype=np.int32)
        params = {"isfree": np.zeros(n, dtype=np.int32), "ntie": 0, "tie_to": one,
                  "tie_from": one, "tie_scale": np.zeros(1), "tie_offset": np.zeros(n)}
    _check(api.mlid_set_model(h.value, **_model_args(model)))
    _check(api.mlid_set_params(h.value, theta0=model.theta, **params))
    _check(api.mlid_set_record(h.value, t=t, u=u, y=np.zeros((model.ny, t.size), order="F"),
                               segstart=np.ones(1, dtype=np.int32)))
    _check(api.mlid_set_options(h.value, iopt, ropt))


def _set_model_with_params(h, model):
    """The model part of a call's problem into handle h, with the model's
    parameters as it holds them (their free mask and ties too): for a call
    on the model alone, with no record or options (input design)."""
    _set_model(h, model)
    _check(api.mlid_set_params(h.value, theta0=model.theta, isfree=model.free_places,
                               **model.tie_args()))


def _record(model, data):
    if data.u.shape[1] != model.nu:
        raise InputError(f"data has {data.u.shape[1]} input columns, the model has {model.nu} inputs")
    if data.y.shape[1] != model.ny:
        raise InputError(f"data has {data.y.shape[1]} output columns, the model has "
                         f"{model.ny} outputs")
    # (nt, n) C-ordered is the core's (n, nt) Fortran-ordered: no copy.
    u = np.ascontiguousarray(data.u, dtype=float).T
    y = np.ascontiguousarray(data.y, dtype=float).T
    return np.ascontiguousarray(data.t, dtype=float), u, y


def _manoeuvres(model, data, initial_states, biases, x0_from=None, x0_samples=None):
    """The parameters and the record for one manoeuvre or several (a list),
    with x0_from: each manoeuvre's measured states' x0 from its record."""
    if isinstance(data, (list, tuple)):
        record, starts = join(list(data))
        params = Params(model, len(data), initial_states, biases)
    elif initial_states is not None or biases is not None:
        raise InputError("initial_states and biases are for several manoeuvres (a list of "
                         "records); one manoeuvre takes the model's x0 and bias")
    else:
        params, record, starts = Params(model), data, np.array([1], dtype=np.int32)
    if x0_from is not None or x0_samples is not None:
        params.theta = _x0_from(model, params, record, starts, x0_from, x0_samples)
    return params, record, starts


def _x0_from(model, params, record, starts, rule, samples):
    """params' theta with each manoeuvre's x0 of the states an output
    measures at that output's first sample ('first') or the mean of its
    first ``samples`` ('mean'), less its bias: the core's rule
    (fortran/models/mlid_initial_states.f90), as a deck's &estimate x0_from."""
    if rule is None:
        raise InputError("x0_samples is for x0_from = 'mean'")
    if not isinstance(rule, str):
        raise InputError(f"x0_from must be 'first' or 'mean', got {rule!r}")
    if samples is not None and (isinstance(samples, bool) or not isinstance(samples, (int, np.integer))):
        raise InputError(f"x0_samples must be a whole number, got {samples!r}")
    h = call_handle()
    _set_model(h, model)
    _set_params(h, params)
    _set_record(h, _record(model, record), starts)
    put(h, rule=rule, samples=0 if samples is None else int(samples))
    return run(h, api.mlid_x0_from)["theta"]
