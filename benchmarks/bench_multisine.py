"""Multisine phase optimisation (issue 43): 3 inputs x 20 harmonics (0.1-3.05 Hz,
T = 20 s, dt = 0.02 s), the core's Schroeder start + clipping/projection
(mlid.design.signals.multisine) against a straightforward scipy.optimize
implementation of the same criterion: each input's RPF over its sampled period,
minimised over its 20 phases by Nelder-Mead (as SIDPAC's mkmsswp does with
fminsearch), from Schroeder's flat-spectrum phases -pi n (n-1)/20 of its
components n = 1..20 (the core starts from Schroeder's phases in harmonic
numbers, his eq. 5).  Prints time and RPF per input,
side by side, and the ratios.

    python benchmarks/bench_multisine.py [iterations]
"""

import sys
import time

import numpy as np
from scipy.optimize import minimize

from mlid.design.signals import multisine

M, F_MIN, F_MAX, T, DT = 3, 0.1, 3.05, 20.0, 0.02


def rpf(u):
    return (u.max() - u.min()) / (2 * np.sqrt(2) * np.sqrt(np.mean(u ** 2)))


def scipy_input(f, a, ph0, t):
    """One input's phases minimising its sampled RPF (Nelder-Mead)."""
    c = np.cos(2 * np.pi * np.outer(t, f))
    s = np.sin(2 * np.pi * np.outer(t, f))

    def cost(ph):
        return rpf(c @ (a * np.cos(ph)) - s @ (a * np.sin(ph)))

    res = minimize(cost, ph0, method="Nelder-Mead",
                   options={"maxfev": 40000, "xatol": 1e-6, "fatol": 1e-9, "adaptive": True})
    return res.fun, cost(ph0)


def main(iterations=1000):
    t0 = time.perf_counter()
    ms = multisine(M, F_MIN, F_MAX, T, DT, iterations=iterations)
    core_time = time.perf_counter() - t0
    assert [len(f) for f in ms.frequencies] == [20, 20, 20]
    t = np.arange(int(round(T / DT))) * DT
    t0 = time.perf_counter()
    sp = []
    for j in range(M):
        # Schroeder's phases for a flat spectrum on this input's harmonics (its own start)
        k = np.arange(1, 21)
        ph0 = -np.pi * k * (k - 1) / 20.0
        sp.append(scipy_input(ms.frequencies[j], np.ones(20), ph0, t))
    sp_time = time.perf_counter() - t0
    print(f"multisine phase optimisation: {M} inputs x 20 harmonics, {F_MIN}-{F_MAX} Hz, "
          f"T = {T} s, dt = {DT} s")
    print(f"{'input':>5} {'Schroeder':>10} {'core RPF':>9} {'scipy RPF':>10} {'core/scipy':>11}")
    for j in range(M):
        print(f"{j + 1:5d} {ms.rpf_schroeder[j]:10.4f} {ms.rpf[j]:9.4f} {sp[j][0]:10.4f} "
              f"{ms.rpf[j] / sp[j][0]:11.3f}")
    print(f"time: core {core_time * 1e3:.1f} ms ({iterations} clipping steps per input), "
          f"scipy Nelder-Mead {sp_time * 1e3:.0f} ms; scipy/core {sp_time / core_time:.1f}x")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
