"""The finite Fourier transform of records at chosen frequencies (the core's
mlid_fourier): what the frequency-domain methods of ``fit`` work on; and the
recursive frequency-domain equation error over a moving window."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..checks import real_array, whole
from ..data.flight_data import FlightData
from ..errors import InputError, check_status, guarded
from ..model.calls import _record
from ..model.models import LinearModel


@guarded
def sample_step(t, starts=(1,)):
    """The one sample step of a record whose manoeuvres start at samples
    ``starts`` (1-based): each uniformly sampled, all at one step, as the
    core checks it for every frequency-domain tool (fortran/case/mlid_record.f90,
    record_common_step).

    Parameters
    ----------
    t : ndarray (n,)
        Times, the manoeuvres one after another.
    starts : sequence of int
        The first sample of each manoeuvre.

    Returns
    -------
    float

    Raises
    ------
    InputError
        Fewer than two samples, or sampling not uniform, naming the sample
        (and the manoeuvre, when there are several).
    """
    dt, status, msg = _api.mlid_uniform_step(np.asarray(t, dtype=float),
                                             np.asarray(starts, dtype=np.int32))
    check_status(status, msg)
    return float(dt)


@guarded
def fourier_transform(t, x, freq):
    """X(f) = integral over the record of x(t) exp(-i 2 pi f t) dt.

    Exact (to rounding) for the straight lines between the samples: the sum
    over the samples times the interior weight W(w dt) plus end-point terms
    (fortran/numerics/mlid_fourier.f90), at any frequencies, not an FFT grid.

    Parameters
    ----------
    t : array_like (n,)
        Uniformly spaced sample times.
    x : array_like (n,) or (n, nch)
        The channels, one column each.
    freq : array_like (nf,)
        Frequencies in Hz.

    Returns
    -------
    ndarray, complex (nf,) or (nf, nch)
        The transform of each channel at each frequency.

    Raises
    ------
    InputError
        Fewer than two samples, sampling not uniform, values not finite.

    Examples
    --------
    A constant over one second: its transform is 1 s at 0 Hz and, exactly,
    nothing at 1 Hz, where an FFT's sum over the samples would leave the
    end points' half weights.

    >>> import numpy as np
    >>> import mlid
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> X = mlid.fourier_transform(t, np.ones_like(t), [0.0, 1.0])
    >>> np.round(abs(X), 12)
    array([1., 0.])
    """
    t = real_array("t", t)
    xa = real_array("x", x)
    one = xa.ndim == 1
    xa = xa.reshape(len(xa), -1) if one else xa
    f = np.atleast_1d(real_array("freq", freq))
    if t.ndim != 1 or xa.ndim != 2 or len(t) != xa.shape[0]:
        raise InputError(f"x must have one row per sample of t ({len(t)}), got shape "
                         f"{np.shape(x)}")
    dt = sample_step(t)
    xre, xim, status, msg = _api.mlid_fourier_transform(
        np.asfortranarray(xa.T), dt, t[0], 2.0 * np.pi * f)
    check_status(status, msg)
    xf = (xre + 1j * xim).T
    return xf[:, 0] if one else xf


@guarded
def recursive_frequency_fit(model, data, window, stride=1, f_min=None, f_max=None, n_freq=20):
    """Frequency-domain equation error over a moving window, recursively.

    The window's Fourier transform is updated sample by sample (each
    frequency's sum gains the entering sample and loses the leaving one:
    a complex multiply-add each), and every ``stride`` samples the state
    equations i w X = F X + G U are solved by least squares over it, with
    the transient terms of ``fit``'s frequency equation error: a window over
    the whole record gives its estimates and Cramer-Rao sigmas
    (fortran/estimation/frequency_domain/mlid_recursive_fd.f90).

    Parameters
    ----------
    model : LinearModel
        Outputs the states (H the identity, D zero); its free entries of F
        and G are estimated, the others held.
    data : FlightData
        Uniformly sampled.
    window, stride : int
        Samples in a window, and between the ends of successive windows.
    f_min, f_max : float
        The band, Hz.
    n_freq : int
        Frequencies evenly spaced over the band.

    Returns
    -------
    dict
        ``t_end`` (nwin,) each window's last time, ``estimates`` and
        ``sigma`` (nwin, np), ``names`` of the free parameters.

    Raises
    ------
    InputError
        Not a linear model measuring its states, a free entry outside F and
        G, a bad window, stride or band, non-uniform sampling.
    SingularInformationError
        A window whose regressors are dependent.
    """
    if not isinstance(model, LinearModel) or not isinstance(data, FlightData):
        raise InputError("recursive_frequency_fit takes a LinearModel and a FlightData")
    if model.H.shape != (model.nx, model.nx) or not np.array_equal(model.H, np.eye(model.nx)) \
            or np.any(model.D != 0):
        raise InputError("recursive_frequency_fit needs the states as the outputs (H the "
                         "identity, D zero)")
    if model.ties or np.any(model.K != 0) or np.any(np.asarray(model.delay) != 0) \
            or np.any(np.asarray(model.udelay) != 0):
        raise InputError("recursive_frequency_fit takes no ties, input feedback K or delays "
                         "(its state equations are x' = F x + G u)")
    # the free entries by the core's layout of theta: F, then G, each column by column
    mask = model.free_mask                 # its own order: F, then G
    f, g = model._layout.slice("f"), model._layout.slice("g")
    outside = mask.astype(bool)
    outside[f] = outside[g] = False
    outside = np.flatnonzero(outside)
    if outside.size:
        raise InputError(f"recursive_frequency_fit estimates entries of F and G, not "
                         f"{model.element_names()[outside[0]]!r}")
    free_f = mask[f].reshape((model.nx, model.nx), order="F")
    free_g = mask[g].reshape((model.nx, model.nu), order="F")
    t, u, x = _record(model, data)
    h = _call_handle()
    _put(h, f0=model.F, g0=model.G, free_f=free_f, free_g=free_g,
         n_freq=whole("n_freq", n_freq, -2**31), f_min=_band_edge("f_min", f_min),
         f_max=_band_edge("f_max", f_max), window=int(window), stride=int(stride))
    check_status(*_api.mlid_set_record(h.value, t=t, u=u, y=x, segstart=[1]))
    out = _run(h, _api.mlid_recursive_fdee)
    return {"t_end": out["t_end"], "estimates": out["estimates"].T.copy(),
            "sigma": out["sigma"].T.copy(),
            "names": [model.names.get(n, n) for n in np.array(model.element_names())[mask > 0]]}


def _band_edge(name, value):
    """f_min or f_max as the core takes it: 0 (not given, refused by the
    core's band check) when None."""
    return 0.0 if value is None else float(real_array(name, value))
