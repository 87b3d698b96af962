"""
Flight-test input signals and their spectra
===========================================

The inputs of ``mlid.design.signals``: three orthogonal multisines with minimised
relative peak factor (SIDPAC's example settings: 0.1-1.5 Hz, T = 20 s), a linear and
a logarithmic sweep with fades, a maximal-length PRBS and a 3-2-1-1 multistep, each
beside its one-sided amplitude spectrum.
"""

import numpy as np
import matplotlib.pyplot as plt

from mlid.design.signals import multisine, multistep, prbs, sweep

DT, T = 0.02, 20.0
NT = int(round(T / DT)) + 1
t = np.arange(NT) * DT

ms = multisine(3, 0.1, 1.5, T, DT)
print(ms)

signals = [(f"multisine {j + 1} (RPF {ms.rpf[j]:.2f}, Schroeder {ms.rpf_schroeder[j]:.2f})",
            ms.u[:, j]) for j in range(3)]
signals += [
    ("linear sweep 0.1-1.5 Hz, 2 s fades", sweep("linear", 0.1, 1.5, T, DT, fade=2.0)),
    ("log sweep 0.1-1.5 Hz, amplitude 1 to 0.5",
     sweep("log", 0.1, 1.5, T, DT, amplitude_end=0.5, fade=2.0, zero=True)),
    ("PRBS order 5, 0.3 s clock", prbs(5, 15, DT, NT)),
    ("3-2-1-1, 0.6 s base pulse", multistep("3211", 1.0, 2.0, 0.6, DT, NT, zero=True)),
]

fig, axes = plt.subplots(len(signals), 2, figsize=(9, 1.5 * len(signals)),
                         gridspec_kw={"width_ratios": [2, 1]})
f = np.fft.rfftfreq(NT - 1, DT)
for (name, u), (ax_t, ax_f) in zip(signals, axes):
    ax_t.plot(t, u, lw=0.8)
    ax_t.set_title(name, fontsize=8, loc="left")
    ax_t.set_xlim(0, T)
    ax_f.plot(f, 2 * np.abs(np.fft.rfft(u[:-1])) / (NT - 1), lw=0.8)
    ax_f.set_xlim(0, 3.0)
axes[-1, 0].set_xlabel("t [s]")
axes[-1, 1].set_xlabel("f [Hz]")
fig.tight_layout()
plt.show()
