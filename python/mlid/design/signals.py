"""Flight-test input signals: standard shapes and multisteps (the core's
mlid_inputs), orthogonal minimum-peak-factor multisines, sweeps, PRBS and
their finishing (the core's mlid_signals)."""

import numpy as np

from .._bridge import api as _api
from ..checks import pandas_for, real_array, whole
from ..errors import InputError, check_status, guarded


@guarded
def input_signal(shape, amplitude, t_start, pulse_width, dt, nt):
    """A standard input shape on t = 0, dt, ..., (nt-1) dt.

    Parameters
    ----------
    shape : {'none', 'step', 'pulse', 'doublet', '211', '3211'}
        The shape; a 3211's pulses are 3, 2, 1 and 1 times pulse_width,
        a 211's 2, 1 and 1.
    amplitude : float
        Its height (the doublet and 3211 alternate its sign).
    t_start, pulse_width : float
        When it starts and its unit pulse width [s]; edges fall on whole
        samples.
    dt : float
        Sample step [s].
    nt : int
        Samples.

    Returns
    -------
    ndarray (nt,)

    Raises
    ------
    InputError
        An unknown shape, dt not > 0, a pulse shorter than one sample, nt
        out of range.

    Examples
    --------
    >>> from mlid.design.signals import input_signal
    >>> input_signal("doublet", 1.0, 0.1, 0.2, 0.1, 8)
    array([ 0.,  1.,  1., -1., -1.,  0.,  0.,  0.])
    """
    nt = whole("nt", nt, 1, 10**7)
    if not isinstance(shape, str):
        raise InputError(f"shape must be a name ('none', 'step', 'pulse', 'doublet', '211', '3211'), "
                         f"got {type(shape).__name__}")
    u, status, msg = _api.mlid_input_signal(shape, float(amplitude), float(t_start),
                                            float(pulse_width), float(dt), nt)
    check_status(status, msg)
    return u


def _real(name, value):
    """A finite float, or one line saying what is wrong."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InputError(f"{name} must be a number, got {value!r}")
    value = float(value)
    if not np.isfinite(value):
        raise InputError(f"{name} must be finite, got {value}")
    return value


def _samples(T, dt):
    """The whole samples of a record of length T at step dt."""
    T, dt = _real("T", T), _real("dt", dt)
    if not dt > 0 or not T > 0:
        raise InputError(f"T and dt must be > 0, got T={T}, dt={dt}")
    return whole("T/dt", int(round(T / dt)), 2, 10**7)


class Multisine:
    """Orthogonal multisines and their report (see :func:`multisine`).

    Attributes
    ----------
    t : ndarray (nt+1,)
        0, dt, ..., T.
    u : ndarray (nt+1, m)
        The inputs, one a column; each starts and ends at zero.
    frequencies, phases, amplitudes : list of m ndarrays
        Each input's harmonic frequencies [Hz], the phases [rad] and
        amplitudes of its cosines ``u_j(t) = sum a cos(2 pi f t + phase)``.
    rpf, rpf_schroeder : ndarray (m,)
        Each input's relative peak factor as returned, and with Schroeder's
        phases on the same harmonics (RPF = (max - min) / (2 sqrt(2) rms),
        over one period).
    peak, rms : ndarray (m,)
        Each input's largest |u| and rms over one period.
    """

    def __init__(self, t, u, kh, owner, ph, ampl, rpf0, rpf):
        T = t[-1]
        m = u.shape[1]
        self.t, self.u = t, u
        self.frequencies = [kh[owner == j + 1] / T for j in range(m)]
        self.phases = [ph[owner == j + 1] for j in range(m)]
        self.amplitudes = [ampl[owner == j + 1] for j in range(m)]
        self.rpf, self.rpf_schroeder = rpf, rpf0
        self.peak = np.max(np.abs(u), axis=0)
        self.rms = np.sqrt(np.mean(u[:-1] ** 2, axis=0))

    def table(self):
        """The report as a DataFrame, a row per input: RPF, Schroeder RPF,
        peak, rms, number of harmonics and their frequencies [Hz].

        Raises
        ------
        InputError
            If pandas is not installed.
        """
        pd = pandas_for("Multisine.table")
        return pd.DataFrame({
            "rpf": self.rpf, "rpf_schroeder": self.rpf_schroeder,
            "peak": self.peak, "rms": self.rms,
            "harmonics": [len(f) for f in self.frequencies],
            "frequencies_hz": [" ".join(f"{x:.4g}" for x in f) for f in self.frequencies]},
            index=pd.RangeIndex(1, len(self.rpf) + 1, name="input"))

    def __repr__(self):
        rows = "\n".join(f"  input {j + 1}: RPF {self.rpf[j]:.4f} (Schroeder "
                         f"{self.rpf_schroeder[j]:.4f}), peak {self.peak[j]:.4g}, rms "
                         f"{self.rms[j]:.4g}, {len(self.frequencies[j])} harmonics "
                         f"{self.frequencies[j].min():.4g}-{self.frequencies[j].max():.4g} Hz"
                         for j in range(len(self.rpf)))
        return f"Multisine ({self.u.shape[1]} inputs, T = {self.t[-1]:.6g} s)\n{rows}"


@guarded
def multisine(n_inputs, f_min, f_max, T, dt, amplitude=1.0, power=None, iterations=1000):
    """Mutually orthogonal multisines with minimised relative peak factor.

    The harmonics k/T in [f_min, f_max] (below Nyquist) are dealt to the
    inputs in turn (input 1 gets the 1st, 4th, ... of three), so that the
    inputs are orthogonal over T.  Each input starts from Schroeder's phases
    for its power spectrum; ``iterations`` clipping/projection steps (clip
    the signal at 90 % of its half range, keep the amplitudes, take the
    clipped signal's Fourier phases; the best RPF seen is kept) lower its
    RPF; a time shift then makes it start and end at zero, and it is scaled
    to its peak ``amplitude``.

    Parameters
    ----------
    n_inputs : int
        m, the number of inputs.
    f_min, f_max : float
        The band [Hz].
    T, dt : float
        Length and sample step [s]; T/dt is rounded to whole samples.
    amplitude : float or sequence of m floats
        Each input's peak |u|.
    power : None or array (nh,)
        Relative power of each harmonic of the band, in frequency order
        (all inputs' harmonics interleaved; each input's is normalised);
        None: flat.  :func:`multisine_harmonics` gives nh.
    iterations : int
        Clipping/projection steps; 0 gives Schroeder-phased multisines.

    Returns
    -------
    Multisine

    Raises
    ------
    InputError
        Fewer harmonics in the band than inputs, a bad band, T or dt,
        amplitudes not > 0, powers < 0 or of the wrong length.

    Examples
    --------
    >>> from mlid.design.signals import multisine
    >>> ms = multisine(3, 0.1, 1.5, 20.0, 0.02)
    >>> ms.u.shape, [len(f) for f in ms.frequencies]
    ((1001, 3), [10, 10, 9])
    >>> bool(all(ms.rpf <= ms.rpf_schroeder)), abs(float(ms.u[:-1, 0] @ ms.u[:-1, 1])) < 1e-10
    (True, True)
    """
    m = whole("n_inputs", n_inputs, 1, 1000)
    nt = _samples(T, dt)
    f_min, f_max = _real("f_min", f_min), _real("f_max", f_max)
    iterations = whole("iterations", iterations, 0, 10**6)
    nh = multisine_harmonics(m, f_min, f_max, T, dt)
    amp = real_array("amplitude", np.broadcast_to(np.asarray(amplitude, dtype=float)
                                                  if np.ndim(amplitude) else float(amplitude),
                                                  (m,)) if np.ndim(amplitude) == 0
                     else amplitude)
    if amp.shape != (m,):
        raise InputError(f"amplitude must be one number or {m}, got shape {amp.shape}")
    pw = np.ones(nh) if power is None else real_array("power", power)
    if pw.shape != (nh,):
        raise InputError(f"power must hold one value per harmonic of the band ({nh}), "
                         f"got shape {pw.shape}")
    u, harm, rpf, status, msg = _api.mlid_multisine(
        np.array([f_min, f_max, float(dt)]), nt, pw, np.ascontiguousarray(amp), iterations)
    check_status(status, msg)
    kh, owner = np.rint(harm[:, 0]).astype(int), np.rint(harm[:, 1]).astype(int)
    return Multisine(np.arange(nt + 1) * float(dt), u, kh, owner, harm[:, 2].copy(),
                     harm[:, 3].copy(), rpf[:, 0].copy(), rpf[:, 1].copy())


@guarded
def multisine_harmonics(n_inputs, f_min, f_max, T, dt):
    """How many harmonics of 1/T the band [f_min, f_max] holds below Nyquist
    (the length of :func:`multisine`'s ``power``).

    Examples
    --------
    >>> from mlid.design.signals import multisine_harmonics
    >>> multisine_harmonics(3, 0.1, 1.5, 20.0, 0.02)
    29
    """
    m = whole("n_inputs", n_inputs, 1, 1000)
    nt = _samples(T, dt)
    nh, status, msg = _api.mlid_multisine_count(_real("f_min", f_min), _real("f_max", f_max),
                                               float(dt), nt, m)
    check_status(status, msg)
    return int(nh)


@guarded
def sweep(kind, f_start, f_end, T, dt, amplitude=1.0, amplitude_end=None, fade=0.0,
          zero=False, limit=0.0):
    """A frequency sweep on t = 0, dt, ..., T.

    ``u(t) = a(t) g(t) sin(phi(t))``: the frequency goes from f_start to
    f_end linearly in time (``kind='linear'``) or exponentially
    (``'log'``: f(t) = f_start (f_end/f_start)^(t/T), equal time per
    octave); a(t) goes linearly from amplitude to amplitude_end; g is a
    raised-cosine fade-in and fade-out of ``fade`` seconds.

    Parameters
    ----------
    kind : {'linear', 'log'}
    f_start, f_end : float
        [Hz], > 0 and at most Nyquist.
    T, dt : float
        Length and step [s].
    amplitude, amplitude_end : float
        Amplitude at the start and at the end (None: the same).
    fade : float
        Fade-in and fade-out time [s], at most T/2.
    zero : bool
        Make it start and end at zero with zero mean (:func:`finish`).
    limit : float
        > 0: scale it so that max |u| <= limit (:func:`finish`).

    Returns
    -------
    ndarray (nt+1,)

    Examples
    --------
    >>> from mlid.design.signals import sweep
    >>> u = sweep("log", 0.1, 2.0, 30.0, 0.02, fade=2.0, zero=True)
    >>> u.shape, float(u[0]), float(u[-1]), abs(float(u.mean())) < 1e-12
    ((1501,), 0.0, 0.0, True)
    """
    if kind not in ("linear", "log"):
        raise InputError(f"kind must be 'linear' or 'log', got {kind!r}")
    nt = _samples(T, dt) + 1
    a0 = _real("amplitude", amplitude)
    a1 = a0 if amplitude_end is None else _real("amplitude_end", amplitude_end)
    u, status, msg = _api.mlid_sweep(kind, _real("f_start", f_start), _real("f_end", f_end),
                                     a0, a1, _real("fade", fade), float(dt), nt)
    check_status(status, msg)
    return finish(u, zero=zero, limit=limit)


@guarded
def prbs(order, clock, dt, nt, amplitude=1.0, zero=False, limit=0.0):
    """A maximal-length pseudo-random binary sequence.

    A shift register of ``order`` n with a primitive feedback polynomial
    gives a sequence of period 2^n - 1 bits; each bit is held ``clock``
    samples, and is +amplitude or -amplitude; the sequence repeats to fill
    nt samples.  One period's line spectrum is flat-ish with the sinc²
    envelope of a bit ((N+1)/N² a² sinc²(k/N) at k/(N clock dt), N = 2^n-1).

    Parameters
    ----------
    order : int
        n, 2 to 20.
    clock : int
        Samples per bit.
    dt : float
        Sample step [s] (for the signature's symmetry; the sequence is in
        samples).
    nt : int
        Samples.
    amplitude, zero, limit
        As :func:`sweep`'s.

    Returns
    -------
    ndarray (nt,)

    Examples
    --------
    >>> from mlid.design.signals import prbs
    >>> u = prbs(3, 2, 0.1, 14)
    >>> u[:10]
    array([ 1.,  1.,  1.,  1.,  1.,  1., -1., -1.,  1.,  1.])
    """
    order = whole("order", order, 2, 20)
    clock = whole("clock", clock, 1, 10**7)
    _real("dt", dt)
    nt = whole("nt", nt, 1, 10**7)
    u, status, msg = _api.mlid_prbs(order, clock, _real("amplitude", amplitude), nt)
    check_status(status, msg)
    return finish(u, zero=zero, limit=limit)


@guarded
def multistep(shape, amplitude, t_start, pulse_width, dt, nt, zero=False, limit=0.0):
    """A multistep ('doublet', '211', '3211', or 'step', 'pulse') of base
    pulse ``pulse_width``: :func:`input_signal`, then :func:`finish`.

    Examples
    --------
    >>> from mlid.design.signals import multistep
    >>> multistep("211", 1.0, 0.1, 0.1, 0.1, 7)
    array([ 0.,  1.,  1., -1.,  1.,  0.,  0.])
    """
    u = input_signal(shape, amplitude, t_start, pulse_width, dt, nt)
    return finish(u, zero=zero, limit=limit)


@guarded
def finish(u, zero=True, limit=0.0):
    """A signal made to start and end at zero with zero mean, and/or
    limited in amplitude.

    ``zero``: the line through the end values is taken off, then the mean
    with a half-sine bump (which keeps the ends at zero).  ``limit`` > 0:
    the signal is scaled down (not clipped: its shape and spectrum stay) so
    that max |u| <= limit.

    Examples
    --------
    >>> import numpy as np
    >>> from mlid.design.signals import finish
    >>> v = finish(np.array([1.0, 3.0, 2.0, 2.0, 1.0]), zero=True, limit=0.5)
    >>> float(v[0]), float(v[-1]), abs(float(v.mean())) < 1e-15, float(abs(v).max())
    (0.0, 0.0, True, 0.5)
    """
    x = real_array("u", u)
    if x.ndim != 1 or x.size < 1:
        raise InputError(f"u must be one signal (1-D, not empty), got shape {x.shape}")
    v, status, msg = _api.mlid_finish_signal(x, int(bool(zero)), _real("limit", limit))
    check_status(status, msg)
    return v
