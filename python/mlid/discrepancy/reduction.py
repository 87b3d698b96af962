"""The perfectly-measured-state reduction of report §5.3.2.

When a state is measured much more accurately than the process noise that
drives it (there: sideslip, with gusts entering like sideslip), the measured
value can replace the state wherever it appears.  The state leaves the model,
its column of F (and of H) becomes an input driven by the measurement, the
measurement leaves the outputs, and the order drops by one.  After a fit, the
removed state's own equation integrated along the fitted states gives its
inertial history; the measurement minus that history is the disturbance
(gust) plus measurement noise, to which a noise model can be fitted.
"""

import re

import numpy as np

from ..data.flight_data import FlightData
from ..design.simulate import simulate
from ..errors import InputError, guarded
from ..model.models import LinearModel


def _rename(name, keep, removed, nu, outs, output):
    """Element name of the full model -> element name in the reduced one."""
    key, i, j = re.match(r"(\w+)\((\d+)(?:,(\d+))?\)", name).groups()
    i, j = int(i) - 1, None if j is None else int(j) - 1
    if key == "f":
        if i == removed:
            return None
        return f"f({keep.index(i) + 1},{keep.index(j) + 1})" if j != removed \
            else f"g({keep.index(i) + 1},{nu + 1})"
    if key == "g":
        return None if i == removed else f"g({keep.index(i) + 1},{j + 1})"
    if key == "h":
        if i == output:
            return None
        return f"h({outs.index(i) + 1},{keep.index(j) + 1})" if j != removed \
            else f"d({outs.index(i) + 1},{nu + 1})"
    if key == "d":
        return None if i == output else f"d({outs.index(i) + 1},{j + 1})"
    if key in ("x0", "bx"):
        return None if i == removed else f"{key}({keep.index(i) + 1})"
    if key in ("bias", "r", "delay"):
        return None if i == output else f"{key}({outs.index(i) + 1})"
    if key == "udelay":                 # the inputs stay, the measurement comes last
        return name
    return None


@guarded
def reduce_measured_state(model, state, output):
    """The model with one state taken as perfectly measured by one output.

    Process noise is dropped (the reduced model is fitted by output error);
    free parameters and labels carry over.

    Parameters
    ----------
    model : LinearModel
        Without state feedback (K = 0).
    state : int
        The state, 1-based.
    output : int
        The output that measures it alone (its row of H a unit vector, D
        zero), 1-based.

    Returns
    -------
    LinearModel
        One state and one output fewer; its last input is the measurement.

    Raises
    ------
    InputError
        No such state or output, an output that does not measure the state
        alone, state feedback, or a free parameter that leaves with the state.
    """
    k, o = state - 1, output - 1
    if not (0 <= k < model.nx and 0 <= o < model.ny):
        raise InputError(f"state {state} or output {output} does not exist")
    if model.H[o, k] != 1.0 or np.any(np.delete(model.H[o], k) != 0) or np.any(model.D[o] != 0):
        raise InputError(f"output {output} must measure state {state} alone (H row = unit vector)")
    if np.any(model.K != 0):
        raise InputError("the reduction takes a model without state feedback (K = 0)")
    if model.delay[o] != 0:
        raise InputError(f"output {output} has a time delay: it cannot stand in for the state")
    if np.any(np.delete(model.stab[:, o], k) != 0):
        raise InputError(f"the stabilizing gain feeds output {output} back: it cannot leave")
    keep = [i for i in range(model.nx) if i != k]
    outs = [i for i in range(model.ny) if i != o]
    F = model.F[np.ix_(keep, keep)]
    G = np.column_stack([model.G[keep], model.F[keep, k]])
    H = model.H[np.ix_(outs, keep)]
    D = np.column_stack([model.D[outs], model.H[outs, k]])
    free, names = [], {}
    for n in model.free:
        new = _rename(n, keep, k, model.nu, outs, o)
        if new is None:
            raise InputError(f"free parameter {n!r} does not survive the reduction")
        free.append(new)
        if n in model.names:
            names[new] = model.names[n]
    return LinearModel(F, G, H, D, model.x0[keep], model.bias[outs], free=free, names=names,
                       r=model.r[outs], input_hold=model.input_hold, substeps=model.substeps,
                       bx=model.bx[keep], delay=model.delay[outs],
                       udelay=np.r_[model.udelay, 0.0], stab=model.stab[np.ix_(keep, outs)],
                       p0=model.p0[keep])


@guarded
def reduced_data(data, output):
    """The record for the reduced model: the measured output becomes the last input.

    Parameters
    ----------
    data : FlightData
        The record of the full model.
    output : int
        The output that measures the removed state, 1-based.

    Returns
    -------
    FlightData
    """
    o = output - 1
    return FlightData(data.t, np.column_stack([data.u, data.y[:, o]]),
                      np.delete(data.y, o, axis=1),
                      data.input_names + [data.output_names[o]],
                      [n for i, n in enumerate(data.output_names) if i != o], data.source)


@guarded
def recover_disturbance(model, fitted, data, state, output):
    """Measurement minus the removed state's inertial history.

    The removed state's equation x_k' = F[k, others] x_others + F[k, k] y_meas
    + G[k] u is integrated along the states of the fitted reduced model (the
    measured value standing for the state wherever it appears, as in the
    reduction).

    Parameters
    ----------
    model : LinearModel
        The full model (its row of F and G for the removed state).
    fitted : LinearModel
        The reduced model at its estimate.
    data : FlightData
        The record of the full model.
    state, output : int
        As for ``reduce_measured_state``.

    Returns
    -------
    inertial : ndarray (nt,)
        The removed state's history from its own equation.
    disturbance : ndarray (nt,)
        The measurement minus it: disturbance (gust) plus measurement noise.
    """
    k, o = state - 1, output - 1
    keep = [i for i in range(model.nx) if i != k]
    _, states = simulate(fitted, data.t, np.column_stack([data.u, data.y[:, o]]))
    inputs = np.column_stack([states, data.y[:, o], data.u])
    coeff = np.r_[model.F[k, keep], model.F[k, k], model.G[k]]
    one = LinearModel([[0.0]], coeff[None, :], [[1.0]], x0=[model.x0[k]])
    sim, _ = simulate(one, data.t, inputs)
    return sim.y[:, 0], data.y[:, o] - sim.y[:, 0]
