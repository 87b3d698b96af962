"""Smoothing and differentiation of one channel (issue 43): mlid.smooth and
mlid.deriv (the core's global Fourier smoother, cut-off chosen from the
noise floor) against scipy.signal.savgol_filter (a local cubic over 31
samples, its smoothed value and first derivative) on 10,000 samples of a
sum of sines plus white noise: time per sample side by side, the ratios,
and each one's rms error against the true signal and derivative (the
middle 90% and the first and last 5%).  A record of 10,000 samples has a
mirror of 19,998 = 2 * 3^2 * 11 * 101: not 2^a 3^b 5^c, so Bluestein's
transform; 10,001 samples (mirror 20,000) take the FFT directly.  The
local variant (method='local': Spencer's 15-point average, the 17-point
central difference) is timed in the same rounds, against the same savgol.

    python benchmarks/bench_smooth.py
"""

import sys
from pathlib import Path

import numpy as np
from scipy.signal import savgol_filter

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import interleaved_medians  # noqa: E402

WINDOW, ORDER = 31, 3


def record(n, dt=0.01, sigma=0.05):
    t = dt * np.arange(n)
    lines = [(1.0, 0.2, 0.3), (0.5, 0.55, 1.1), (0.25, 1.1, 2.0)]
    x = sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in lines)
    xd = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * t + p) for a, f, p in lines)
    return t, x + sigma * np.random.default_rng(1).standard_normal(n), x, xd


def errors(est, truth):
    e = est - truth
    k = int(0.05 * e.size)
    return np.sqrt(np.mean(e[k:-k] ** 2)), np.sqrt(np.mean(np.r_[e[:k], e[-k:]] ** 2))


def main():
    for n in (10_000, 10_001):
        t, x, true, true_dot = record(n)
        dt = t[1] - t[0]
        fns = [lambda: mlid.smooth(t, x), lambda: mlid.deriv(t, x),
               lambda: savgol_filter(x, WINDOW, ORDER),
               lambda: savgol_filter(x, WINDOW, ORDER, deriv=1, delta=dt),
               lambda: mlid.smooth(t, x, method="local"),
               lambda: mlid.deriv(t, x, method="local")]
        ts, td, ss, sd, tls, tld = interleaved_medians(fns, rounds=5, n=5)
        _, fc = mlid.smooth(t, x, cutoff=True)
        print(f"{n} samples (cut-off {fc:.3f} Hz; Savitzky-Golay: cubic over {WINDOW} samples)")
        print(f"  {'':10s} {'mlid us/sample':>15s} {'savgol us/sample':>17s} {'ratio':>7s}"
              f"   rms error mlid (ends)      savgol (ends)")
        for name, tm, ts_, est, sg, truth in (
                ("smooth", ts, ss, mlid.smooth(t, x), savgol_filter(x, WINDOW, ORDER), true),
                ("deriv", td, sd, mlid.deriv(t, x),
                 savgol_filter(x, WINDOW, ORDER, deriv=1, delta=dt), true_dot),
                ("smooth_lo", tls, ss, mlid.smooth(t, x, method="local"),
                 savgol_filter(x, WINDOW, ORDER), true),
                ("deriv_lo", tld, sd, mlid.deriv(t, x, method="local"),
                 savgol_filter(x, WINDOW, ORDER, deriv=1, delta=dt), true_dot)):
            em, eme = errors(est, truth)
            es, ese = errors(sg, truth)
            print(f"  {name:10s} {1e6 * tm / n:15.4f} {1e6 * ts_ / n:17.4f} {tm / ts_:7.2f}"
                  f"   {em:.4g} ({eme:.4g})   {es:.4g} ({ese:.4g})")


if __name__ == "__main__":
    main()
