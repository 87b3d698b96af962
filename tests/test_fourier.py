"""The finite Fourier transform at chosen frequencies (fortran/numerics/mlid_fourier.f90)
against closed forms and a brute-force segment-by-segment integral."""

import numpy as np
import pytest

import mlid
from mlid import fourier_transform


def segment_integral(t, x, f):
    """Brute force: the integral of each straight piece between samples
    times exp(-i w t), in closed form, summed (a second implementation).
    Piece j: h e^{c t_j} [x_j E1(ch) + (x_{j+1} - x_j) E2(ch)], c = -i w,
    E1(z) = (e^z - 1)/z, E2(z) = int_0^1 v e^{zv} dv (series for small z)."""
    out = []
    h = np.diff(t)
    for fk in np.atleast_1d(f):
        z = -2j * np.pi * fk * h
        e1 = np.expm1(z) / z
        series = sum(z**m / (np.prod(np.arange(1, m + 1)) * (m + 2)) for m in range(12))
        closed = (np.exp(z) * (z - 1) + 1) / z**2
        e2 = np.where(np.abs(z) < 0.1, series, closed)
        c = -2j * np.pi * fk
        out.append(np.sum(h * np.exp(c * t[:-1]) * (x[:-1] * e1 + np.diff(x) * e2)))
    return np.array(out)


def test_ramp_is_exact():
    """A ramp is its own piecewise-linear interpolant: the transform is its
    closed form to rounding, at low, middle and near-Nyquist frequencies."""
    dt, n, t0 = 0.02, 1500, 3.0
    t = t0 + dt * np.arange(n)
    a, b = 0.7, -0.3
    f = np.array([0.013, 0.2, 1.0, 7.3, 24.9])
    w = 2 * np.pi * f
    t1 = t[-1]

    def prim(tt):   # antiderivative of (a + b t) e^{-iwt}
        return np.exp(-1j * w * tt) * ((a + b * tt) / (-1j * w) + b / w**2)

    exact = prim(t1) - prim(t0)
    got = fourier_transform(t, a + b * t, f)
    assert np.max(np.abs(got - exact) / np.abs(exact)) < 1e-11


def test_against_segment_sum():
    """A noisy record, several channels: the Goertzel-Reinsch sums with the
    end-point weights equal the brute-force integral of the linear pieces."""
    rng = np.random.default_rng(5)
    dt, n = 0.02, 1500
    t = dt * np.arange(n)
    x = np.column_stack([rng.standard_normal(n), np.cumsum(rng.standard_normal(n)),
                         np.sin(3 * t) + 0.1 * rng.standard_normal(n)])
    f = np.concatenate([[1e-4, 0.003], np.linspace(0.1, 5.0, 48), [24.0, 24.99]])
    got = fourier_transform(t, x, f)
    assert got.shape == (len(f), 3)
    for c in range(3):
        ref = segment_integral(t, x[:, c], f)
        scale = np.sum(np.abs(x[:, c])) * dt       # the size of the sum
        assert np.max(np.abs(got[:, c] - ref)) < 1e-11 * scale


def test_decaying_exponential_converges_as_dt_squared():
    """exp(-a t) on [0, T]: the transform of the interpolant tends to the
    closed form (1 - exp(-(a + iw) T))/(a + iw) with error O(dt^2)."""
    a, T = 1.5, 10.0
    f = np.array([0.05, 0.5, 2.0])
    s = a + 2j * np.pi * f
    exact = (1 - np.exp(-s * T)) / s
    errs = []
    for n in (501, 1001, 2001):
        t = np.linspace(0.0, T, n)
        errs.append(np.max(np.abs(fourier_transform(t, np.exp(-a * t), f) - exact)))
    ratios = np.array(errs[:-1]) / np.array(errs[1:])
    assert np.all((ratios > 3.9) & (ratios < 4.1))    # halving dt quarters the error
    # trapezoid-size error: dt^2/12 times the jump in the derivative of x e^{-iwt}
    dt = T / 2000
    assert errs[-1] < dt**2 / 12 * np.max(np.abs(s)) * 1.01


def test_bad_input():
    with pytest.raises(mlid.InputError, match="uniformly"):
        fourier_transform([0, 1, 3], [1, 2, 3], [0.1])
    with pytest.raises(mlid.InputError, match="two samples"):
        fourier_transform([0.0], [1.0], [0.1])
    with pytest.raises(mlid.InputError, match="not finite"):
        fourier_transform([0, 1, 2], [1, np.nan, 3], [0.1])
