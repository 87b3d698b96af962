"""
Frequency domain: a fit and its Bode plot
=========================================

The C-8 short period flown with a frequency sweep of the elevator (0.05 to 1.5 Hz over
60 s, simulated with measurement noise) and identified by frequency-domain output error
over 0.05–1.5 Hz: the record's finite Fourier transform at 60 frequencies, each
manoeuvre's transient solved out. The Bode plot sets the identified model, with its
±2σ Cramér-Rao band, against the record's own frequency response (Welch spectra) and
its coherence; a low-order equivalent system (LOES) is fitted to the measured response.
"""

import numpy as np
import matplotlib.pyplot as plt

import mlid
from mlid.report import plots

F = [[-0.02, -32.2, 0.0, 33.74], [0.0, 0.0, 1.0, 0.0],
     [0.003, 0.0, -1.588, -0.562], [-0.004, 0.0, 1.0, -0.737]]
G = [[0.0], [0.0], [-1.658], [0.005]]
FREE = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]
NAMES = dict(zip(FREE, ["M_q", "M_alpha", "Z_alpha", "M_delta", "Z_delta"]))
OUTPUTS = ["u", "theta", "q", "alpha"]

# a linear frequency sweep of 0.02 rad, tapered at both ends
t = np.arange(0.0, 60.0, 0.02)
phase = 2 * np.pi * (0.05 * t + (1.5 - 0.05) * t**2 / (2 * 60.0))
de = 0.02 * np.sin(phase) * np.clip(np.minimum(t, 60.0 - t) / 2.0, 0.0, 1.0)
truth = mlid.LinearModel(F, G, np.eye(4))
data, _ = mlid.simulate(truth, t, de.reshape(-1, 1), noise_std=[0.05, 0.002, 0.002, 0.002],
                        seed=3, input_names=["delta_e"], output_names=OUTPUTS)

start = mlid.LinearModel(np.array(F) + np.diag([0, 0, 0.6, 0.25]), np.array(G) * 1.35,
                         np.eye(4), free=FREE, names=NAMES)
res = mlid.fit(start, data, method="frequency_output_error", f_min=0.05, f_max=1.5,
               n_freq=60)
print(f"converged: {res.converged} after {res.iterations} iterations")
print(res.params[["estimate", "sigma_cr"]].to_string(float_format=lambda v: f"{v:.4f}"))

# %%
# The record's response of the pitch rate to the elevator up to 2 Hz, and a second-order LOES
# with a time delay fitted to it where the coherence is at least 0.8.
measured = mlid.record_response(data, "delta_e", "q", segment=1024)
keep = measured.frequency <= 2.0               # past the sweep, the record holds only noise
measured = mlid.FrequencyResponse(**{
    k: v[keep] if isinstance(v, np.ndarray) and v.shape == keep.shape else v
    for k, v in vars(measured).items()})
loes = mlid.fit_transfer_function(measured, 1, 2, delay=True, f_min=0.05, f_max=1.5,
                                  min_coherence=0.8)
print(loes)

# %%
# The identified model against the record: gain, phase and coherence.
plots.bode_measured(res, "delta_e", "q", measured=measured, loes=loes)
plt.show()
