"""Coloured measurement noise as an explanation of its own (issue 47 item 1).

Residuals that are not white need not mean a missing effect: the sensor's
noise itself may be coloured (an anti-aliasing filter, a vane's own
dynamics, a noise generator with memory).  Turbulence or a gust, which the
filter-error method predicts one step ahead, explains any such colour, so
mlid.diagnose accepts them only when they beat this model of the noise:

    y_i = h_i(x, u) + n + v,   ndot = -n / T + w,

a first-order (AR(1) when sampled) noise n on output i alone, entering no
state equation, with white noise v on top.  Its new state comes after the
model's own (every element name keeps its meaning); free: the pole
f(g,g) = -1/T, the noise's process noise q (Gamma = e_g) and every r not
free or tied already: filter error, like the gust of
mlid.discrepancy.effects.
"""

import math

import numpy as np

from ..errors import InputError
from ..model.models import LinearModel
from .effects import Extension, channel_name, first_order_noise, model_parts

#: The start of T when the residuals do not give one: a few samples.
START_SAMPLES = 3.0


def start_time_constant(residual, dt):
    """T from the residual's autocorrelation: rho(2) / rho(1) is the AR(1)
    factor a = exp(-dt / T) of a coloured part under white noise (the white
    part adds to lag 0 alone); START_SAMPLES dt when that ratio is not in
    (0, 1)."""
    e = np.asarray(residual, dtype=float)
    e = e - e.mean()
    c1, c2 = float(e[1:] @ e[:-1]), float(e[2:] @ e[:-2])
    a = c2 / c1 if c1 > 0 else 0.0
    if not 0.0 < a < 1.0:
        return START_SAMPLES * dt
    return -dt / math.log(a)


def measurement_colour(model, data, i, tau, intensity):
    """Output i's measurement noise made first-order coloured (the module's
    model).

    Parameters
    ----------
    model : LinearModel
        The current fit's model (its derivatives the start).
    data : FlightData
    i : int
        The output, 0-based.
    tau, intensity : float
        Starts of T [s] and of the coloured part's stationary standard
        deviation (in the output's unit), both > 0.

    Returns
    -------
    Extension
        options: method 'filter_error' and q >= 0; value(res): T [s] and the
        coloured part's standard deviation.
    """
    if not isinstance(model, LinearModel):
        raise InputError("measurement_colour extends a LinearModel, got "
                         f"{type(model).__name__}")
    if not (tau > 0 and intensity > 0):
        raise InputError(f"measurement_colour: tau and intensity must be > 0, got {tau!r}, "
                         f"{intensity!r}")
    out = channel_name(data.output_names, i, "y")
    unit = data.output_units[i] if data.output_units else ""
    parts = model_parts(model, 1, 1)
    parts["H"][i, model.nx] = 1.0
    labels, stats = first_order_noise(model, data, parts, tau, intensity, f"noise {{}} {out}")

    def convert(x, cov):
        T, sd_T, sd, sd_sigma = stats(x, cov)
        return [("noise time constant T", T, sd_T, "s",
                 f"correlation time of the measurement noise of {out}"),
                ("coloured noise standard deviation", sd, sd_sigma, unit,
                 f"stationary rms of the coloured part of {out}'s noise")]
    options = {"method": "filter_error", "bounds": {labels[1]: (0.0, None)}}
    return Extension(LinearModel(**parts), data, labels, options, convert)
