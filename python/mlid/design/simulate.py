"""Simulation: a model's outputs along given times and inputs, with its
process and measurement noise, seeded (the core's mlid_simulate)."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle
from ..checks import real_array, whole
from ..data.flight_data import FlightData
from ..errors import InputError, check_status, guarded
from ..estimate.options import _flat_options
from ..model.calls import _check_model, _set_simulation, _time_and_inputs


TIMINGS = ("forward", "backward")


@guarded
def simulate(model, t, u, noise_std=None, seed=0, output_names=None, input_names=None,
             timing="forward"):
    """Outputs of the model along t with inputs u, with the model's process
    and measurement noise (seeded).

    The process noise is held over each sample interval with variances q,
    correlated with the measurement noise through S; RK4 integrates each
    interval over its own length.

    Parameters
    ----------
    model : Model
        The model and its current parameters, q, r and S.
    t : array_like (nt,)
        Sample times, finite and increasing; uneven steps are taken as
        they are.
    u : array_like (nt, nu)
        Inputs, one row per sample.
    noise_std : array_like (ny,), optional
        Measurement-noise standard deviations replacing the model's
        (r = noise_std**2).
    seed : int
        Seed of the noise; the same seed gives the same record.
    output_names, input_names : list of str, optional
        Channel names of the record.
    timing : {'forward', 'backward'}
        Outputs that carry the process noise (accelerometers of the X-22
        model) get that of the interval after the sample ('forward', as the
        filter assumes) or before it ('backward'), report §5.1.5.

    Returns
    -------
    data : FlightData
        t, u and the noisy outputs.
    states : ndarray (nt, nx)
        The states along the record.

    Raises
    ------
    InputError
        Bad model, sizes, times, inputs, noise_std, seed or timing; noise
        covariances that are not positive semi-definite.
    DivergenceError
        The simulation diverged.
    """
    if timing not in TIMINGS:
        raise InputError(f"timing must be one of {TIMINGS}, got {timing!r}")
    _check_model(model)
    seed = whole("seed", seed)
    t, u = _time_and_inputs(model, t, u)
    if noise_std is not None:
        noise = real_array("noise_std", noise_std).ravel()
        if np.any(noise < 0):
            raise InputError(f"noise_std must be >= 0, got {noise.tolist()}")
        if noise.shape != (model.ny,):
            raise InputError(f"noise_std needs {model.ny} values (one per output), got "
                             f"{noise.size}")
        model = model.with_theta(model.theta)
        model.r = noise**2
    iopt, ropt, _ = _flat_options(model, {})
    h = _call_handle()
    _set_simulation(h, model, (t, u.T), iopt, ropt, free=False)
    y, x, status, msg = _api.mlid_simulate(h.value, seed=int(seed), timing=TIMINGS.index(timing),
                                           ny=model.ny, nx=model.nx, nt=t.size)
    check_status(status, msg)
    return FlightData(t, u, y.T, input_names, output_names), x.T.copy()
