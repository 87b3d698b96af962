"""
Smoothing and differentiating a channel
=======================================

A rate gyro's signal, a sum of three sines at 0.2, 0.55 and 1.1 Hz plus white noise
(σ 0.05) sampled at 50 Hz, smoothed and differentiated by the global Fourier smoother
(``mlid.smooth``, ``mlid.deriv``; the decks' ``smooth(p)``, ``deriv(p)``) and by the local
one (``method="local"``; ``smooth_local(p)``, ``deriv_local(p)``, the textbook's
preprocessing). Left: the raw and smoothed amplitude spectra with the cut-off the rule
chose where the spectrum meets the noise floor — the check to make on a real record.
Right: each derivative's error against the true one; the printed rms errors are over
the middle 90 % and over the first and last 5 %.
"""

import numpy as np
import matplotlib.pyplot as plt

import mlid

DT = 0.02
t = DT * np.arange(1001)
lines = [(1.0, 0.2, 0.3), (0.5, 0.55, 1.1), (0.25, 1.1, 2.0)]
truth = sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in lines)
truth_dot = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * t + p) for a, f, p in lines)
x = truth + 0.05 * np.random.default_rng(1).standard_normal(t.size)

xs, fc = mlid.smooth(t, x, cutoff=True)
derivs = {"Fourier": mlid.deriv(t, x), "local": mlid.deriv(t, x, method="local")}


def rms(e):
    return np.sqrt(np.mean(e ** 2))


ends = t.size // 20
print(f"cut-off chosen by the rule: {fc:.2f} Hz")
for name, d in derivs.items():
    e = d - truth_dot
    print(f"{name:8s} deriv: rms error {rms(e[ends:-ends]):.3f} in the middle, "
          f"{rms(np.r_[e[:ends], e[-ends:]]):.3f} at the ends (true rms {rms(truth_dot):.2f})")

fig, (ax_f, ax_d) = plt.subplots(1, 2, figsize=(10, 3.6))
f = np.fft.rfftfreq(t.size, DT)
for y, label in ((x, "raw"), (xs, "smoothed (Fourier)")):
    line = np.linspace(y[0], y[-1], y.size)     # the end line, removed as the smoother does
    ax_f.semilogy(f, np.abs(np.fft.rfft(y - line)), lw=0.8, label=label)
ax_f.axvline(fc, color="k", ls="--", lw=0.8, label=f"cut-off {fc:.2f} Hz")
ax_f.set(xlabel="frequency [Hz]", ylabel="|X(f)|", title="spectra", xlim=(0, 25))
ax_f.legend(fontsize=8)
for name, d in derivs.items():
    ax_d.plot(t, d - truth_dot, lw=0.7, label=f"{name} deriv")
ax_d.set(xlabel="t [s]", ylabel="error [1/s²]", title="derivative error")
ax_d.legend(fontsize=8)
fig.tight_layout()
plt.show()
