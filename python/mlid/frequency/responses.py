"""Frequency responses and low-order equivalent systems (the core's
mlid_freq_response and mlid_transfer_fit do the numerics).

- ``record_response``: the response of one output to one input of a
  record, H = G_uy/G_uu from Welch-averaged spectra, with the coherence and
  Bendat & Piersol's random errors of gain and phase.
- ``model_response``: the response of an identified linear model,
  H (jwI - F)^-1 G + D (with its feedback K and time delays), with the
  sigma of gain and phase from the fit's Cramer-Rao covariance (delta
  method, analytic derivatives).
- ``fit_transfer_function``: a transfer function
  K (b_m s^m + ... + b_0) / (s^n + ... + a_0) e^(-tau s) fitted to a response by
  the handling-qualities mismatch 20/n sum[(dG)^2 + 0.01745 (dP)^2]
  (gain in dB, phase in deg), optionally weighted by coherence.

The handling-qualities forms, as orders (m, n) of ``fit_transfer_function``:

===========================  ============================================  ======
response                     form                                          (m, n)
===========================  ============================================  ======
pitch rate q/dE              K (s + 1/T_t2) e^-ts / (s^2 + 2 z w s + w^2)   (1, 2)
pitch attitude theta/dE      the same over s (``fixed={'a0': 0}``)          (1, 3)
normal load factor nz/dE     K e^-ts / (s^2 + 2 z w s + w^2)                (0, 2)
roll rate p/dA               K e^-ts / (s + 1/T_R)                          (0, 1)
sideslip, yaw r/dR           K (s + 1/T) e^-ts / (s^2 + 2 z_d w_d s + w_d^2) (1, 2)
===========================  ============================================  ======

Coefficients are in the core's units (rad, rad/s, s): gains in dB of the
output's unit per the input's.
"""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..checks import real_array, whole
from ..errors import InputError, check_status, guarded
from ..estimate.outcome import require_estimates
from ..estimate.result import FitResult
from ..model.calls import _set_model, _set_params
from ..model.maneuvers import Params
from .fourier import sample_step


DB = 20.0 / np.log(10.0)


class FrequencyResponse:
    """Gain and phase of one output over one input at a set of frequencies.

    Made by ``record_response`` and ``model_response`` (and
    ``TransferFunctionFit.response``).

    Parameters
    ----------
    **fields
        The attributes, by name.

    Attributes
    ----------
    frequency : ndarray (nf,)
        Hz.
    gain, phase : ndarray (nf,)
        dB (of the output's unit per the input's, core units) and deg,
        unwrapped along frequency.
    sigma_gain, sigma_phase : ndarray (nf,)
        One standard deviation of each: random error (record) or Cramer-Rao
        (model); zero for a model without a covariance.
    coherence : ndarray (nf,) or None
        gamma^2 of a record's response; None for a model's.
    averages : int
        Segments averaged (record); 0 otherwise.
    input_name, output_name, input_unit, output_unit : str
    source : str
        'record', 'model' or 'transfer function'.
    response : ndarray (nf,) complex
        H itself.
    """

    def __init__(self, **fields):
        self.coherence = None
        self.averages = 0
        self.__dict__.update(fields)

    @property
    def omega(self):
        """Frequencies in rad/s."""
        return 2 * np.pi * self.frequency

    def band(self, f_min=None, f_max=None, min_coherence=None):
        """The points within [f_min, f_max] Hz (and of coherence at least
        min_coherence, for a record's) where gain and phase are finite.

        Parameters
        ----------
        f_min, f_max : float, optional
            Hz; no bound where None.
        min_coherence : float, optional
            Ignored for a response without coherence.

        Returns
        -------
        ndarray of bool (nf,)
        """
        keep = np.isfinite(self.gain) & np.isfinite(self.phase)
        if f_min is not None:
            keep &= self.frequency >= f_min
        if f_max is not None:
            keep &= self.frequency <= f_max
        if min_coherence is not None and self.coherence is not None:
            keep &= self.coherence >= min_coherence
        return keep

    def __repr__(self):
        return (f"FrequencyResponse({self.output_name}/{self.input_name}, {self.source}, "
                f"{self.frequency.size} frequencies {self.frequency.min():.4g}-"
                f"{self.frequency.max():.4g} Hz)")


def _channel(names, which, what):
    """The index of a channel given by name or index."""
    if isinstance(which, str):
        if which not in names:
            raise InputError(f"no {what} channel {which!r}; the record has {names}")
        return names.index(which)
    return whole(what, which, 0, max(len(names) - 1, 0))


def _column(record, k, what, name, unit):
    """The column of channel ``name`` ('input' or 'output') in record k
    (1-based), by name and in ``unit``; else one line naming both."""
    names, units = ((record.input_names, record.input_units) if what == "input"
                    else (record.output_names, record.output_units))
    where = f"record {k}" + (f" ({record.source})" if record.source else "")
    if name not in names:
        raise InputError(f"{where}: no {what} channel {name!r} (record 1 has it); this record "
                         f"has {names}")
    c = names.index(name)
    if units[c] != unit:
        raise InputError(f"{where}: {what} channel {name!r} is in {units[c]!r}, in record 1 in "
                         f"{unit!r}")
    return c


@guarded
def record_response(data, input=0, output=0, segment=None, overlap=0.5):
    """The frequency response of one output to one input of a record.

    ``H = G_uy / G_uu`` and ``gamma^2 = |G_uy|^2 / (G_uu G_yy)`` from one-sided
    spectra averaged over Hann-windowed segments, each with its mean
    removed (Welch).  The random errors are Bendat & Piersol's for n_d
    averages: ``eps = sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))``, sigma of the
    gain 20/ln10 eps dB, of the phase eps rad.

    Parameters
    ----------
    data : FlightData or list of FlightData
        A uniformly sampled record, or several manoeuvres of one sampling
        (their segments are averaged together; none spans two of them).
    input, output : str or int
        The channels, by name or index (an index is the first record's);
        each record's own column of that name is taken.
    segment : int, optional
        Samples per segment (default: the largest power of two not above a
        quarter of the longest manoeuvre); transformed zero-padded to a
        power of two.
    overlap : float
        Fraction of a segment shared with the next, in [0, 1).

    Returns
    -------
    FrequencyResponse
        At k / (N dt) Hz, k = 1 .. N/2 (N the transform's length).

    Raises
    ------
    InputError
        Unknown channel (in any record), a channel in another unit than in
        the first record, non-uniform time or manoeuvres of different
        sampling, a segment longer than the record, an overlap outside
        [0, 1), or a value that is not finite.
    """
    records = list(data) if isinstance(data, (list, tuple)) else [data]
    if not records:
        raise InputError("record_response needs a record (or a list of manoeuvres)")
    starts = np.cumsum([1] + [r.nt for r in records[:-1]]).astype(np.int32)
    dt = sample_step(np.concatenate([r.t for r in records]), starts)
    data = records[0]
    i = _channel(data.input_names, input, "input")
    j = _channel(data.output_names, output, "output")
    # each manoeuvre's own columns of the first one's channels
    u = np.concatenate([r.u[:, _column(r, k, "input", data.input_names[i], data.input_units[i])]
                        for k, r in enumerate(records, 1)])
    y = np.concatenate([r.y[:, _column(r, k, "output", data.output_names[j],
                                       data.output_units[j])]
                        for k, r in enumerate(records, 1)])
    if segment is None:
        longest = max(r.nt for r in records)
        segment = 2 ** int(np.floor(np.log2(max(longest / 4, 2))))
    segment = whole("segment", segment, 2)
    if not 0 <= overlap < 1:
        raise InputError(f"overlap must lie in [0, 1), got {overlap}")
    h = _call_handle()
    _put(h, u=u, y=y, dt=dt, segstart=starts, lseg=segment, nover=int(round(overlap * segment)))
    out = _run(h, _api.mlid_freq_response)
    return FrequencyResponse(
        frequency=out["frequency"], gain=out["gain"], phase=out["phase"],
        sigma_gain=out["sigma_gain"], sigma_phase=out["sigma_phase"],
        coherence=out["coherence"], averages=out["averages"],
        response=out["response_re"] + 1j * out["response_im"],
        input_spectrum=out["input_spectrum"], output_spectrum=out["output_spectrum"],
        segment=segment,
        input_name=data.input_names[i], output_name=data.output_names[j],
        input_unit=data.input_units[i], output_unit=data.output_units[j], source="record")


def free_map(fit_or_model):
    """d theta / d q: how a model's theta (one manoeuvre's layout) moves with
    each free parameter q (of a fit, or of the model), ties included.  A
    manoeuvre's own entries (initial states, biases) map to nothing: they do
    not enter a frequency response.

    Parameters
    ----------
    fit_or_model : FitResult or Model

    Returns
    -------
    ndarray (nth, nf)
    """
    fitted = isinstance(fit_or_model, FitResult)
    model = getattr(fit_or_model, "start_model", fit_or_model.model) if fitted else fit_or_model
    params = Params(model, len(getattr(fit_or_model, "manoeuvres", ())) or 1)
    jac = np.zeros((model.theta.size, params.free.size))
    for c, k in enumerate(params.free):
        if params.seg[k] == 0:
            jac[params.map[k], c] = 1.0
    for a, (_, sources) in model.tie_terms().items():
        jac[a] += sum(s * jac[j] for j, s in sources)
    return jac


@guarded
def model_response(fit_or_model, frequency, input=0, output=0, covariance=None):
    """The frequency response of a linear model with Cramer-Rao bands.

    T(jw) = C (jw I - A)^-1 B + D with A = F + G K, B = G, C = H + D K, times
    exp(-jw (tau_y + tau_u)) for the output's and input's delays; the sigma
    of gain and phase by the delta method, sigma^2 = g' P g with g the
    analytic derivatives of gain (dB) or phase (deg) with respect to the
    free parameters and P their covariance.

    Parameters
    ----------
    fit_or_model : FitResult or LinearModel
        A fit of a linear model (its estimate and covariance), or a model
        (no bands unless ``covariance`` is given over its free parameters).
    frequency : array_like
        Frequencies in Hz (positive).
    input, output : str or int
        The channels, by name (a fit's record's) or index.
    covariance : array_like (nf, nf), optional
        Instead of the fit's Cramer-Rao covariance (e.g. its
        ``covariance_corrected``).

    Returns
    -------
    FrequencyResponse
        With ``derivatives`` (nf_freq, nq) complex: dT/dq of the pair.

    Raises
    ------
    InputError
        Not a linear model, a failed fit, unknown channel, a covariance of
        the wrong size, frequencies not positive.
    SingularInformationError
        A pole on the imaginary axis at one of the frequencies.

    Examples
    --------
    The first-order lag 2/(s + 2): unit gain at low frequency, and at its
    corner, omega = 2 rad/s (1/pi Hz), 3 dB down and 45 degrees behind.

    >>> import numpy as np
    >>> import mlid
    >>> lag = mlid.LinearModel([[-2.0]], [[2.0]], [[1.0]])
    >>> r = mlid.model_response(lag, [0.01, 1 / np.pi])
    >>> r.gain.round(2) + 0.0, r.phase.round(1)
    (array([ 0.  , -3.01]), array([ -1.8, -45. ]))
    """
    if isinstance(fit_or_model, FitResult):
        require_estimates(fit_or_model, "frequency response")
        model, data = fit_or_model.model, fit_or_model.data
        jac = free_map(fit_or_model)
        cov = fit_or_model.covariance if covariance is None else covariance
        names_u, names_y = data.input_names, data.output_names
        units_u, units_y = data.input_units, data.output_units
    else:
        model = fit_or_model
        jac = free_map(model)
        cov = np.zeros((jac.shape[1],) * 2) if covariance is None else covariance
        names_u = [f"u{k + 1}" for k in range(model.nu)]
        names_y = [f"y{k + 1}" for k in range(model.ny)]
        units_u, units_y = [""] * model.nu, [""] * model.ny
    cov = real_array("covariance", cov)
    if cov.shape != (jac.shape[1],) * 2:
        raise InputError(f"covariance must be {jac.shape[1]}x{jac.shape[1]} (free parameters), "
                         f"got {cov.shape}")
    f = real_array("frequency", frequency).ravel()
    if f.size == 0 or np.any(f <= 0):
        raise InputError("frequencies must be positive (Hz)")
    i = _channel(names_u, input, "input")
    j = _channel(names_y, output, "output")
    params = Params(model)
    h = _call_handle()
    _put(h, w=2 * np.pi * f, jac=jac, cov=cov, input=i + 1, output=j + 1)
    _set_model(h, model)
    _set_params(h, params)
    out = _run(h, _api.mlid_model_freq_response)
    return FrequencyResponse(
        frequency=f, gain=out["gain"], phase=out["phase"], sigma_gain=out["sigma_gain"],
        sigma_phase=out["sigma_phase"], response=out["response_re"] + 1j * out["response_im"],
        derivatives=out["derivatives_re"] + 1j * out["derivatives_im"],
        input_name=names_u[i], output_name=names_y[j], input_unit=units_u[i],
        output_unit=units_y[j], source="model")


class TransferFunctionFit:
    """A transfer function (b_m s^m + ... + b_0) / (s^n + ... + a_0) e^(-tau s)
    fitted to a frequency response (``fit_transfer_function``).

    Parameters
    ----------
    **fields
        The attributes, by name (``fit_transfer_function`` sets them).

    Attributes
    ----------
    m, n : int
        Numerator and denominator orders.
    names : list of str
        'b0' .. 'bm', 'a0' .. 'a(n-1)' and 'tau' when the delay is fitted.
    estimate, sigma, start : ndarray
        The parameters in ``names`` order; sigma from the residuals'
        scatter, s^2 (J'J)^-1 (zero for fixed ones).
    covariance : ndarray
    numerator, denominator : ndarray
        Coefficients, highest power first (numpy.polyval's order); the
        denominator's first is 1.
    delay : float
        tau (s); 0 without a delay.
    mismatch : float
        20/n sum W [(dG)^2 + 0.01745 (dP)^2] at the fit.
    iterations : int
    frequency_range : (float, float)
        Hz, of the points fitted.
    coherence_weighted : bool
    """

    def __init__(self, **fields):
        self.__dict__.update(fields)

    @property
    def numerator(self):
        """Numerator coefficients b_m .. b_0, highest power first."""
        return self.estimate[:self.m + 1][::-1].copy()

    @property
    def denominator(self):
        """Denominator coefficients 1, a_(n-1) .. a_0, highest power first."""
        return np.concatenate([[1.0], self.estimate[self.m + 1:self.m + 1 + self.n][::-1]])

    @property
    def delay(self):
        """The time delay tau (s); 0 when none was fitted."""
        return float(self.estimate[-1]) if self.has_delay else 0.0

    @property
    def poles(self):
        """Roots of the denominator."""
        return np.roots(self.denominator)

    @property
    def zeros(self):
        """Roots of the numerator."""
        return np.roots(self.numerator)

    def value(self, name):
        """A parameter by name.

        Parameters
        ----------
        name : str
            'b0', 'a1', 'tau', ...

        Returns
        -------
        float

        Raises
        ------
        InputError
            If the fit has no such parameter.
        """
        if name not in self.names:
            raise InputError(f"no parameter {name!r}; the fit has {self.names}")
        return float(self.estimate[self.names.index(name)])

    def second_order(self):
        """Damping ratio and natural frequency of each complex pole pair.

        Returns
        -------
        list of (float, float)
            (zeta, omega_n in rad/s), one per pair with positive imaginary part.
        """
        out = []
        for p in self.poles:
            if p.imag > 0:
                wn = abs(p)
                out.append((float(-p.real / wn), float(wn)))
        return out

    @guarded
    def response(self, frequency):
        """The fitted transfer function's response.

        Parameters
        ----------
        frequency : array_like
            Hz.

        Returns
        -------
        FrequencyResponse
            Gain (dB) and phase (deg, unwrapped); no sigma.

        Raises
        ------
        InputError
            An estimate whose length is not the orders' parameter count.
        """
        f = real_array("frequency", frequency).ravel()
        gain, phase, status, msg = _api.mlid_tf_response(
            w=2 * np.pi * f, m=self.m, n=self.n, delay=int(self.has_delay),
            x=real_array("estimate", self.estimate).ravel())
        check_status(status, msg)
        return FrequencyResponse(
            frequency=f, gain=gain, phase=phase, sigma_gain=np.zeros_like(f),
            sigma_phase=np.zeros_like(f), input_name=self.input_name,
            output_name=self.output_name, input_unit=self.input_unit,
            output_unit=self.output_unit, source="transfer function")

    def report(self):
        """The fit as text.

        Returns
        -------
        str
            Orders, range, parameters with sigma, pole pairs and the mismatch.
        """
        lines = [f"transfer function {self.output_name}/{self.input_name}: numerator order "
                 f"{self.m}, denominator order {self.n}"
                 + (", with time delay" if self.has_delay else ""),
                 f"  {self.frequency_range[0]:.4g} to {self.frequency_range[1]:.4g} Hz, "
                 f"{self.points} frequencies"
                 + (", coherence-weighted" if self.coherence_weighted else ""),
                 f"  {'parameter':<10s} {'estimate':>14s} {'sigma':>12s}"]
        for name, e, s in zip(self.names, self.estimate, self.sigma):
            lines.append(f"  {name:<10s} {e:14.6g} {s:12.4g}")
        for zeta, wn in self.second_order():
            lines.append(f"  pole pair: zeta {zeta:.4f}, omega_n {wn:.4f} rad/s")
        lines.append(f"  mismatch {self.mismatch:.4f} ({self.iterations} iterations)")
        return "\n".join(lines)

    def __repr__(self):
        return (f"TransferFunctionFit(m={self.m}, n={self.n}, delay={self.delay:.4g}, "
                f"mismatch={self.mismatch:.4g})")


def transfer_names(m, n, delay):
    """The parameter names of orders m, n: b0..bm, a0..a(n-1), tau."""
    return ([f"b{i}" for i in range(m + 1)] + [f"a{i}" for i in range(n)]
            + (["tau"] if delay else []))


@guarded
def fit_transfer_function(response, m, n, delay=True, f_min=None, f_max=None,
                          min_coherence=None, coherence_weighting=False, start=None,
                          fixed=None, delay_start=0.0, max_iter=200):
    """Fit (b_m s^m + ... + b_0) / (s^n + ... + a_0) e^(-tau s) to a response.

    The handling-qualities mismatch 20/n sum W_k [(G_k - Gm_k)^2 + 0.01745
    (P_k - Pm_k)^2] (gain dB, phase deg) is minimized by Levenberg-Marquardt
    with analytic derivatives (the core's mlid_transfer_fit), from Levy's
    least squares (Sanathanan-Koerner passes) with the delay at delay_start,
    or from ``start``.  W_k = 1, or [1.58 (1 - exp(-gamma_k^2))]^2 with
    coherence_weighting.

    Parameters
    ----------
    response : FrequencyResponse
        A record's or a model's.
    m, n : int
        Numerator and denominator orders (n >= 1).
    delay : bool
        Fit a time delay tau.
    f_min, f_max : float, optional
        The frequency range fitted (Hz).
    min_coherence : float, optional
        Leave out a record's points of lower coherence.
    coherence_weighting : bool
        Weight by coherence (a record's response only).
    start : dict, optional
        Start values by name ('b0', 'a1', 'tau', ...); all of them, or none.
    fixed : dict, optional
        Parameters held at the given values (e.g. {'a0': 0.0}: a pure integrator).
    delay_start : float
        The delay's start (s) for the automatic start.
    max_iter : int

    Returns
    -------
    TransferFunctionFit

    Raises
    ------
    InputError
        Bad orders or names, too few points, coherence weighting without coherence.
    NonConvergenceError
        No convergence in max_iter iterations.
    SingularInformationError
        Parameters not identifiable from the points.
    """
    m, n = whole("m", m, 0, 20), whole("n", n, 1, 20)
    names = transfer_names(m, n, delay)
    keep = response.band(f_min, f_max, min_coherence)
    if coherence_weighting and response.coherence is None:
        raise InputError("coherence weighting needs a record's response (it has coherence)")
    coh = response.coherence[keep] if response.coherence is not None else np.ones(keep.sum())
    x0 = np.zeros(len(names))
    isfree = np.ones(len(names), dtype=np.int32)
    for what, given in (("start", start), ("fixed", fixed)):
        for name, value in (given or {}).items():
            if name not in names:
                raise InputError(f"{what}: no parameter {name!r}; orders ({m}, {n}) have {names}")
            x0[names.index(name)] = float(value)
            if what == "fixed":
                isfree[names.index(name)] = 0
    if start and set(start) | set(fixed or {}) != set(names):
        raise InputError(f"start must give every parameter not fixed: {names}")
    h = _call_handle()
    _put(h, w=2 * np.pi * response.frequency[keep], gain=response.gain[keep],
         phase=response.phase[keep], coh=coh, use_coh=int(coherence_weighting), m=m, n=n,
         delay=int(delay), tau0=float(delay_start), use_start=int(bool(start)), x0=x0,
         isfree=isfree, max_iter=whole("max_iter", max_iter, 1))
    out = _run(h, _api.mlid_tf_fit)
    f = response.frequency[keep]
    cov = out["covariance"]
    return TransferFunctionFit(
        m=m, n=n, has_delay=bool(delay), names=names, start=out["start"], estimate=out["estimate"],
        sigma=np.sqrt(np.maximum(np.diag(cov), 0.0)), covariance=cov, mismatch=out["mismatch"],
        iterations=out["iterations"], frequency_range=(float(f.min()), float(f.max())),
        points=int(f.size), coherence_weighted=bool(coherence_weighting), free=isfree == 1,
        input_name=response.input_name, output_name=response.output_name,
        input_unit=response.input_unit, output_unit=response.output_unit)


@guarded
def transfer_mismatch(fit, response, coherence_weighting=False):
    """The handling-qualities mismatch of a fitted transfer function against
    a response, at the response's points in the fit's frequency range.

    Parameters
    ----------
    fit : TransferFunctionFit
    response : FrequencyResponse
    coherence_weighting : bool
        Weight by the response's coherence.

    Returns
    -------
    float
        20/n sum W [(dG)^2 + 0.01745 (dP)^2] (the core's residuals, r'r).

    Raises
    ------
    InputError
        An estimate whose length is not the orders' parameter count.
    """
    keep = response.band(*fit.frequency_range)
    coh = response.coherence[keep] if response.coherence is not None else np.ones(keep.sum())
    h = _call_handle()
    _put(h, w=2 * np.pi * response.frequency[keep], gain=response.gain[keep],
         phase=response.phase[keep], coh=coh, use_coh=int(coherence_weighting), m=fit.m, n=fit.n,
         delay=int(fit.has_delay), x=real_array("estimate", fit.estimate).ravel())
    r = _run(h, _api.mlid_tf_residuals)["residuals"]
    return float(r @ r)
