"""Structural effects as parameters of the Newton iteration.

Each builder extends a model by one effect whose size is one or two free
parameters, so that a single fit estimates the effect with its Cramer-Rao
sigma, instead of a golden-section search over whole fits:

    sensor_lag     output i read through a first- or second-order lag
    scale_factor   output i read with a gain error (1 + k)
    input_delay    input j reaching the aircraft late (udelay(j))
    gust           a first-order gust on an aerodynamic angle (report eq. 5.1)

Each returns an ``Extension``: the extended model, the record to fit it to,
the labels of the new parameters, the fit options it needs, and ``value(res)``,
the effect in physical quantities with delta-method sigmas.  Outputs, inputs
and states are numbered from 1, as in element names and decks, or named by
the record's channel names.

The lag and the gust are new states appended after the model's own, so
every element name of the model ('f(2,3)', 'x0(1)', 'q(1)') keeps its
meaning and the free set, ties and labels carry over unchanged.
"""

import math

import numpy as np

from ..errors import InputError, guarded
from ..model.models import LinearModel, Model

#: Damping of the second-order lag's default start: the usual design value
#: of a sensor or anti-aliasing filter.
LAG2_ZETA = 0.7
#: The gust's default start intensity: this fraction of the rms (about its
#: mean) of the output that reads the angle most strongly.
GUST_FRACTION = 0.1


class Extension:
    """A model extended by one structural effect, ready to fit.

    Fit it with ``mlid.fit(ext.model, ext.data, **ext.options)``.  The
    options are fit()'s keywords and may hold ``bounds``, which
    ``mlid.evaluate`` does not take: leave it out there.

    Parameters
    ----------
    model : LinearModel or Model
        The extended model: the new parameters free, with everything that
        was free before.
    data : FlightData
        The record to fit it to.
    params : list of str
        The new parameters' labels, as they appear in ``FitResult.names``.
    options : dict
        Extra fit options the effect needs ({'method': 'filter_error', ...}
        for the gust), else {}.
    convert : callable
        convert(x, cov) of the new parameters' estimates and covariance gives
        the list that ``value`` returns.
    """

    def __init__(self, model, data, params, options, convert):
        self.model, self.data, self.params, self.options = model, data, params, options
        self._convert = convert

    def value(self, res):
        """The effect in physical quantities, from a fit of ``model``.

        Parameters
        ----------
        res : FitResult
            A fit of this extension's model.

        Returns
        -------
        list of tuple
            (quantity, value, sigma, unit, meaning) per quantity; sigma by
            the delta method from the fit's Cramer-Rao covariance; unit
            's', 'rad/s', '-' (dimensionless), the record's unit of the
            angle, or '' when the record has none.

        Raises
        ------
        InputError
            The fit has not got this extension's parameters, or it failed.
        """
        missing = [p for p in self.params if p not in res.names]
        if missing:
            raise InputError(f"the fit has no parameter {missing[0]!r}: fit this extension's "
                             "model")
        if getattr(res, "failed", False):
            raise InputError(f"a failed fit has no estimates: {res.message}")
        k = [res.names.index(p) for p in self.params]
        return self._convert(np.asarray(res.estimate)[k],
                             np.asarray(res.covariance)[np.ix_(k, k)])

    def __repr__(self):
        return f"Extension(params={self.params}, options={self.options})"


# --- checks and names ------------------------------------------------------

def _linear(model, what):
    if not isinstance(model, LinearModel):
        raise InputError(f"{what} extends the matrices of a LinearModel, got "
                         f"{type(model).__name__}")


def _channel(which, n, names, what, kind):
    """A channel's 0-based index from a 1-based number or a name."""
    if isinstance(which, str):
        if which not in (names or []):
            raise InputError(f"{what}: no {kind} named {which!r} (the record has "
                             f"{', '.join(names or []) or 'no names'})")
        return list(names).index(which)
    if isinstance(which, (bool, np.bool_)) or not isinstance(which, (int, np.integer)) \
            or not 1 <= which <= n:
        raise InputError(f"{what}: {kind} {which!r} does not exist: give 1..{n} or a name")
    return int(which) - 1


def channel_name(names, i, letter):
    """Channel i's name, or letter and its 1-based number when unnamed."""
    return names[i] if names else f"{letter}{i + 1}"


def sample_interval(data):
    """The sample interval (the median step, for a record with a rounding jitter)."""
    return float(np.median(np.diff(data.t)))


def is_fixed(model, element):
    """Is the model's element neither free nor tied?"""
    return element not in model.free and element not in model.ties


def _label(model, element):
    return model.names.get(element, element)


def _affine(offset, terms):
    """A tie's right-hand side, 'c + s*a - s*b', from offset and (scale, name)."""
    text = repr(float(offset)) if offset else ""
    for s, name in terms:
        if text:
            text += f" {'-' if s < 0 else '+'} {abs(float(s))!r}*{name}"
        else:
            text = f"{float(s)!r}*{name}"
    return text


def _sd(grad, cov):
    """Delta method: the sigma of a function with this gradient."""
    g = np.asarray(grad, dtype=float)
    return float(math.sqrt(max(g @ cov @ g, 0.0)))


# --- extending the matrices ------------------------------------------------

def model_parts(model, n=0, nw=0):
    """The LinearModel arguments of model with n more states and nw more
    process noises, all zero (their rows and columns of F, G, H, Gamma, K,
    bx, x0, stab, p0, q and S).  New ones come last, so every old element keeps
    its name, and free, ties and labels carry over (as copies to edit)."""
    def grow(a, rows, cols):
        return np.pad(np.asarray(a, dtype=float), ((0, rows), (0, cols)))
    parts = model._common()
    parts.update(F=grow(model.F, n, n), G=grow(model.G, n, 0), H=grow(model.H, 0, n),
                 D=model.D.copy(), Gamma=grow(model.Gamma, n, nw), K=grow(model.K, 0, n),
                 bx=np.r_[model.bx, np.zeros(n)], x0=np.r_[model.x0, np.zeros(n)],
                 q=np.r_[model.q, np.zeros(nw)], S=grow(model.S, nw, 0),
                 stab=grow(model.stab, n, 0), p0=np.r_[model.p0, np.zeros(n)],
                 bias=model.bias.copy(), r=model.r.copy(),
                 free=list(model.free), names=dict(model.names), ties=dict(model.ties))
    return parts


def _row(model, i):
    """Output i's elements: (element of H or D, its value, matrix, column)."""
    return ([(f"h({i + 1},{j + 1})", model.H[i, j], "F", j) for j in range(model.nx)]
            + [(f"d({i + 1},{j + 1})", model.D[i, j], "G", j) for j in range(model.nu)])


def _drive(model, parts, i, z, p, pval):
    """State row z driven by output i's reading: F[z, :nx] = -H_i p and
    G[z] = -D_i p, where p names the free element (-a or -wn^2) of row z
    and pval is its start.
    A fixed H_ij or D_ij ties its element to p (affine in p).  A free or tied
    one would make a product with p, which a tie cannot state: its element is
    made free instead, and then estimates -p H_ij (the derivative scaled by
    the lag's a or wn^2).  Output i's own elements leave the model."""
    names = model.element_names()
    row = {e for e, _, _, _ in _row(model, i)}
    for k, (_, sources) in model.tie_terms().items():
        if names[k] not in row and any(names[j] in row for j, _ in sources):
            raise InputError(f"sensor_lag: {names[k]} is tied to an element of output {i + 1}'s "
                             "row, which the lag replaces: tie it to another parameter")
    for e, value, mat, j in _row(model, i):
        dst = f"{mat.lower()}({z + 1},{j + 1})"
        if e in parts["free"]:
            parts["free"].remove(e)
        parts["ties"].pop(e, None)
        if is_fixed(model, e):
            if value != 0.0:
                parts[mat][z, j] = -value * pval
                parts["ties"][dst] = _affine(0.0, [(-value, p)])
        else:
            parts[mat][z, j] = -value * pval
            parts["free"].append(dst)
            parts["names"][dst] = f"{_label(model, e)} x lag gain"


def _initial_reading(model, parts, i, z, u0):
    """x0 of state z = H_i x0 + D_i u(0), the sensor settled at the start: a
    constant, tied to the free x0(j) it reads through fixed H_ij, or free
    where a term is a product of two parameters (a free H_ij or D_ij with a
    nonzero factor, a tied x0(j))."""
    offset, terms = 0.0, []
    parts["x0"][z] = model.H[i] @ model.x0 + model.D[i] @ u0
    for e, value, mat, j in _row(model, i):
        if value == 0.0 and is_fixed(model, e):
            continue
        factor = f"x0({j + 1})" if mat == "F" else None
        known = model.x0[j] if mat == "F" else u0[j]
        if factor in model.ties or (not is_fixed(model, e)
                                    and (known != 0.0 or factor in model.free)):
            parts["free"].append(f"x0({z + 1})")
            return
        if factor in model.free:
            terms.append((value, factor))
        else:
            offset += value * known
    if terms:
        parts["ties"][f"x0({z + 1})"] = _affine(offset, terms)


# --- the effects -----------------------------------------------------------

@guarded
def sensor_lag(model, data, i, order=1, start=None):
    """Output i read through a first- or second-order lag.

    Order 1: a new state z, zdot = a (H_i x + D_i u - z), y_i = z (+ bias),
    a = 1/tau free as f(z,z) = -a.  Order 2: new states z, zdot with
    z'' = wn^2 (H_i x + D_i u - z) - 2 zeta wn z'; f(z2,z) = -wn^2 and
    f(z2,z2) = -2 zeta wn free (matrix elements themselves, so that the row's
    other elements stay affine in them: wn and zeta would need products).  The other elements of the driven row are tied to the
    free one through each fixed element of H_i, D_i (F[z,j] = -H_ij f(z,z));
    a free or tied element of H_i, D_i cannot be tied (a product) and its
    element of row z is made free instead: it then estimates the derivative
    times a (or wn^2).  x0 of z is H_i x0 + D_i u(0).  The lag states get no
    stabilising gain (stab), no feedback (K) and no process noise.

    Parameters
    ----------
    model : LinearModel
    data : FlightData
        The record (its first input sample and sample interval are used).
    i : int or str
        The output, 1-based, or its channel name.
    order : {1, 2}
    start : float or (float, float), optional
        Order 1: tau in s (default two sample intervals).  Order 2:
        (wn in rad/s, zeta) (default 1/(2 dt) and LAG2_ZETA).  RK4 needs
        model.substeps above about dt a / 2.8 to stay stable.

    Returns
    -------
    Extension
        value(res): tau [s] (order 1), or wn [rad/s] and zeta [-] (order 2).

    Raises
    ------
    InputError
        Not a LinearModel, no such output, order not 1 or 2, a start that is
        not positive, or a parameter tied to an element of output i's row.
    """
    _linear(model, "sensor_lag")
    i = _channel(i, model.ny, data.output_names, "sensor_lag", "output")
    if order not in (1, 2):
        raise InputError(f"sensor_lag: order must be 1 or 2, got {order!r}")
    dt, z, out = sample_interval(data), model.nx, channel_name(data.output_names, i, "y")
    parts = model_parts(model, order)
    _initial_reading(model, parts, i, z, data.u[0])
    F = parts["F"]
    if order == 1:
        tau = 2.0 * dt if start is None else float(start)
        if not tau > 0:
            raise InputError(f"sensor_lag: the start tau must be > 0, got {start!r}")
        F[z, z] = -1.0 / tau
        new = [f"f({z + 1},{z + 1})"]
        labels = [f"-1/tau lag {out}"]
        driven = z
    else:
        wn, zeta = (0.5 / dt, LAG2_ZETA) if start is None else (float(v) for v in start)
        if not (wn > 0 and zeta > 0):
            raise InputError(f"sensor_lag: the start (wn, zeta) must be > 0, got {start!r}")
        driven = z + 1
        F[z, driven] = 1.0
        F[driven, z] = -wn * wn
        F[driven, driven] = -2.0 * zeta * wn
        new = [f"f({driven + 1},{z + 1})", f"f({driven + 1},{driven + 1})"]
        labels = [f"-wn^2 lag {out}", f"-2 zeta wn lag {out}"]
    _drive(model, parts, i, driven, new[0], F[driven, z])
    parts["H"][i] = 0.0
    parts["H"][i, z] = 1.0
    parts["D"][i] = 0.0
    parts["free"] += new
    parts["names"].update(zip(new, labels))
    m = LinearModel(**parts)
    convert = _lag1_value if order == 1 else _lag2_value
    return Extension(m, data, labels, {}, convert)


def _lag1_value(x, cov):
    a = -x[0]                        # f(z,z) = -a = -1/tau
    return [("time constant tau", 1.0 / a, _sd([1.0 / a**2], cov), "s",
             "time constant of a first-order lag between the quantity and its sensor")]


def _lag2_value(x, cov):
    w2, c = -x[0], -x[1]             # f(z2,z) = -wn^2, f(z2,z2) = -2 zeta wn
    if not w2 > 0:                   # not an oscillator: no wn or zeta
        return [("natural frequency wn", math.nan, math.nan, "rad/s", "no second-order lag: "
                 "wn^2 <= 0"), ("damping ratio zeta", math.nan, math.nan, "-", "")]
    wn = math.sqrt(w2)
    zeta = c / (2.0 * wn)
    return [("natural frequency wn", wn, _sd([-1.0 / (2.0 * wn), 0.0], cov), "rad/s",
             "natural frequency of a second-order lag between the quantity and its sensor"),
            ("damping ratio zeta", zeta, _sd([c / (4.0 * w2 * wn), -1.0 / (2.0 * wn)], cov), "-",
             "damping ratio of that second-order sensor lag")]


@guarded
def scale_factor(model, data, i):
    """Output i read with a gain error: y_i = (1 + k)(H_i x + D_i u) (+ bias).

    The first fixed nonzero element c0 of output i's row (H, then D) is made
    free as p0, and the row's other fixed nonzero elements c_j are tied to it
    (c_j / c0 p0); k = p0 / c0 - 1.  The row's free elements stay free and
    then estimate their value times (1 + k).

    Parameters
    ----------
    model : LinearModel
    data : FlightData
    i : int or str
        The output, 1-based, or its channel name.

    Returns
    -------
    Extension
        value(res): k [-], starting at the model's current row (k = 0).

    Raises
    ------
    InputError
        Not a LinearModel, no such output, or a row with no fixed nonzero
        element (a scale factor is then the same as its free elements).
    """
    _linear(model, "scale_factor")
    i = _channel(i, model.ny, data.output_names, "scale_factor", "output")
    out = channel_name(data.output_names, i, "y")
    fixed = [(e, c) for e, c, _, _ in _row(model, i) if c != 0.0 and is_fixed(model, e)]
    if not fixed:
        raise InputError(f"scale_factor: output {out}'s row of H and D has no fixed nonzero "
                         "element, so a scale factor cannot be told from its free elements")
    e0, c0 = fixed[0]
    parts = model_parts(model)
    parts["free"].append(e0)
    parts["ties"].update({e: _affine(0.0, [(c / c0, e0)]) for e, c in fixed[1:]})
    parts["names"].setdefault(e0, f"gain {out}")
    label = parts["names"][e0]

    def convert(x, cov):
        return [("scale factor k", float(x[0] / c0 - 1.0), _sd([1.0 / c0], cov), "-",
                 f"gain error of the {out} sensor: it reads (1 + k) times the quantity")]
    return Extension(LinearModel(**parts), data, [label], {}, convert)


@guarded
def input_delay(model, data, j, start=None):
    """Input j reaching the aircraft late: udelay(j) free (output error only;
    fortran/numerics/mlid_delay.f90 says how the input is interpolated).

    Parameters
    ----------
    model : Model
        A kind that gives its input Jacobians (linear, equations, sixdof,
        flight path); the core refuses the others when fitting.
    data : FlightData
    j : int or str
        The input, 1-based, or its channel name.
    start : float, optional
        The delay's start in s (default half a sample interval: a delay of
        exactly zero or a whole number of samples sits on a kink of the
        interpolation).

    Returns
    -------
    Extension
        value(res): the delay [s].

    Raises
    ------
    InputError
        Not a model, no such input, or udelay(j) already free or tied.
    """
    if not isinstance(model, Model):
        raise InputError(f"input_delay needs a mlid model, got {type(model).__name__}")
    j = _channel(j, model.nu, data.input_names, "input_delay", "input")
    e, inp = f"udelay({j + 1})", channel_name(data.input_names, j, "u")
    if not is_fixed(model, e):
        raise InputError(f"input_delay: {e} is already free or tied")
    delay = model.udelay.copy()
    delay[j] = 0.5 * sample_interval(data) if start is None else float(start)
    m = model.with_free(list(model.free) + [e])
    m.udelay = delay
    m.names.setdefault(e, f"delay {inp}")
    label = m.names[e]

    def convert(x, cov):
        return [("time delay", float(x[0]), _sd([1.0], cov), "s",
                 f"time between the recorded {inp} and the aircraft's response to it")]
    return Extension(m, data, [label], {}, convert)


def _dynamic_rows(model):
    """The state equations with a free or tied element of F or G: the
    aerodynamic ones.  A row with none is kinematics (phi-dot = p + tan(theta)
    r), where a gust does not enter."""
    return [r for r in range(model.nx)
            if any(not is_fixed(model, f"{k}({r + 1},{j + 1})")
                   for k, n in (("f", model.nx), ("g", model.nu)) for j in range(n))]


def _same_as(model, parts, src, dst):
    """Element dst equal to src: src's value (already copied) when it is
    fixed, tied to it when it is free, the same tie when it is tied."""
    if src in model.free:
        parts["ties"][dst] = src
    elif src in model.ties:
        parts["ties"][dst] = model.ties[src]


def gust_variance(T, dt):
    """The stationary variance of a first-order gust x_g per unit q.

    xdot_g = -x_g / T + w with w held over each sample interval dt with
    variance q (mlid's process noise): x_{k+1} = a x_k + T (1 - a) w_k with
    a = exp(-dt / T), so var = q T^2 (1 - a) / (1 + a) (about q T dt / 2
    for dt << T).  The core integrates the interval by RK4; its a differs
    from exp(-dt/T) by about (dt/T)^5 / 120.

    Parameters
    ----------
    T, dt : float
        Time constant and sample interval, s.

    Returns
    -------
    (v, dv/dT) : (float, float)
    """
    a = math.exp(-dt / T)
    v = T * T * (1.0 - a) / (1.0 + a)
    return v, 2.0 * T * (1.0 - a) / (1.0 + a) - 2.0 * a * dt / (1.0 + a) ** 2


@guarded
def gust(model, data, state, tau=0.5, intensity=None):
    """A first-order (Dryden-like) gust on an aerodynamic angle, as the
    report's M2/F3 model (eq. 5.1): a new state x_g, xdot_g = -x_g / T + w,
    entering wherever the angle does aerodynamically.  Its column of F is
    the angle's in the dynamic rows (those with a free or tied derivative;
    kinematic rows get 0), its column of H is the angle's in every output
    (a vane reads angle + gust, an accelerometer's derivative sees it);
    fixed elements are copied, free ones tied equal, tied ones tied alike.
    Free: the pole f(g,g) = -1/T, the gust's process noise q (Gamma = e_g)
    and every r not free or tied already: filter error.

    Parameters
    ----------
    model : LinearModel
        Usually the output-error fit's model (the derivatives' start).
    data : FlightData
    state : int or str
        The angle's state, 1-based, or the name of the output that reads it.
    tau : float
        The start of T in s.
    intensity : float, optional
        The start of the gust's stationary standard deviation, in the
        angle's unit (default GUST_FRACTION of the rms about its mean of the
        output that reads the angle most strongly, over that reading).

    Returns
    -------
    Extension
        options: method 'filter_error' and bounds q >= 0 (fit()'s ``bounds``);
        value(res): T [s] and the stationary standard deviation of the gust
        [the angle's unit] (gust_variance).  The r start where the model's
        are zero: half the variance of each output's sample-to-sample
        differences (the noise, where the signal is smooth).

    Raises
    ------
    InputError
        Not a LinearModel, no such state, tau or intensity not > 0, or no
        output reads the angle.
    """
    _linear(model, "gust")
    if isinstance(state, str):
        i = _channel(state, model.ny, data.output_names, "gust", "output")
        read = np.flatnonzero(model.H[i])
        if len(read) != 1:
            raise InputError(f"gust: output {state!r} does not read one state alone")
        s = int(read[0])
    else:
        s = _channel(state, model.nx, None, "gust", "state")
    if not (tau > 0 and (intensity is None or intensity > 0)):
        raise InputError(f"gust: tau and intensity must be > 0, got {tau!r}, {intensity!r}")
    readers = [i for i in range(model.ny)
               if model.H[i, s] != 0.0 or not is_fixed(model, f"h({i + 1},{s + 1})")]
    if not readers:
        raise InputError(f"gust: no output reads state {s + 1} (its column of H is zero)")
    best = max(readers, key=lambda i: abs(model.H[i, s]))
    # the angle by the output that reads it alone (a vane), for names and unit
    alone = [i for i in readers if model.H[i, s] == 1.0 and np.count_nonzero(model.H[i]) == 1
             and not model.D[i].any()]
    angle = channel_name(data.output_names, alone[0], "y") if alone else f"x{s + 1}"
    unit = data.output_units[alone[0]] if alone else ""
    g = model.nx
    parts = model_parts(model, 1, 1)
    for r in _dynamic_rows(model):
        parts["F"][r, g] = model.F[r, s]
        _same_as(model, parts, f"f({r + 1},{s + 1})", f"f({r + 1},{g + 1})")
    for i in range(model.ny):
        parts["H"][i, g] = model.H[i, s]
        _same_as(model, parts, f"h({i + 1},{s + 1})", f"h({i + 1},{g + 1})")
    if intensity is None:
        h = model.H[best, s] if model.H[best, s] else 1.0
        intensity = GUST_FRACTION * float(np.std(data.y[:, best])) / abs(h)
    labels, stats = first_order_noise(model, data, parts, tau, intensity, f"gust {{}} {angle}")

    def convert(x, cov):
        T, sd_T, sd, sd_sd = stats(x, cov)
        return [("gust time constant T", T, sd_T, "s",
                 f"correlation time of the gust in {angle}: how long a gust lasts"),
                ("gust standard deviation", sd, sd_sd, unit,
                 f"stationary rms of the gust, as equivalent {angle}")]
    options = {"method": "filter_error", "bounds": {labels[1]: (0.0, None)}}
    return Extension(LinearModel(**parts), data, labels, options, convert)


def first_order_noise(model, data, parts, tau, intensity, label):
    """A first-order noise state appended to parts (the model's matrices,
    model_parts(model, 1, 1)) at state nx, driven by a new white noise: its
    pole -1/tau, q for the stationary rms intensity, r started where it is
    zero, the pole, q and the fixed r free; what the gust and the coloured
    measurement noise share.

    Returns
    -------
    labels : list of str
        The pole's and q's labels, label.format('pole') and .format('q').
    stats : callable
        stats(x, cov) of the fitted (pole, q) and their covariance: T, its
        sigma, the stationary rms and its sigma (delta method).
    """
    dt, nw, g = sample_interval(data), model.nw, model.nx
    parts["F"][g, g] = -1.0 / tau
    parts["Gamma"][g, nw] = 1.0
    parts["q"][nw] = intensity**2 / gust_variance(tau, dt)[0]
    guess = 0.5 * np.var(np.diff(data.y, axis=0), axis=0)
    parts["r"] = np.where(model.r > 0, model.r, guess)
    pole, q = f"f({g + 1},{g + 1})", f"q({nw + 1})"
    labels = [label.format("pole"), label.format("q")]
    parts["free"] += [pole, q] + [f"r({i + 1})" for i in range(model.ny)
                                  if is_fixed(model, f"r({i + 1})")]
    parts["names"].update({pole: labels[0], q: labels[1]})

    def stats(x, cov):
        T, qv = -1.0 / x[0], x[1]
        v, dv = gust_variance(T, dt)
        sd = math.sqrt(max(qv, 0.0) * v)
        # d sd / d pole = d sd / dT * dT / d pole, dT / d pole = 1 / pole^2 = T^2
        grad = ([dv * math.sqrt(qv / v) / 2.0 * T * T, math.sqrt(v / qv) / 2.0]
                if qv > 0 else None)
        return T, _sd([T * T, 0.0], cov), sd, _sd(grad, cov) if grad else math.nan

    return labels, stats
