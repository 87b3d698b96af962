"""
Which input to fly
==================

The C-8 four-state longitudinal model of NASA CR-2200 §8.2 (2 s, energy 58, the five
short-period derivatives): the report's optimal input and the flight-test library's
doublet, 3-2-1-1, multisine, sweeps and PRBS, each scaled to the same energy, ranked by
the determinant of their information matrix (D-optimal).  The doublet is the report's
(halves of 0.3 s, so A = 9.83); the other shapes take their band and base pulse from the
model.  The same table comes from a deck, ``&design candidates = ...``, in the design
job's report and JSON.
"""

import numpy as np
import matplotlib.pyplot as plt

import mlid

F = [[-0.02, -32.2, 0.0, 33.74], [0.0, 0.0, 1.0, 0.0],
     [0.003, 0.0, -1.588, -0.562], [-0.004, 0.0, 1.0, -0.737]]
G = [[0.0], [0.0], [-1.658], [0.005]]
R_SAMPLE = np.array([0.125, 0.125, 0.125, 0.25])          # per-sample noise variances
DT, T, ENERGY = 0.02, 2.0, 58.0
UNKNOWNS = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]

# the design noise is the spectral density R dt of the sampled noise (eq. 7.11)
design = mlid.InputDesign(F, G, np.eye(4), np.diag(R_SAMPLE * DT), UNKNOWNS)
ranking = design.rank_inputs(T, energy=ENERGY, cells=int(round(T / DT)), pulse_width=0.3)
print(ranking)

# %%
# The peak and rms of each state over the 2 s (x = u, θ, q, α from trim): the optimal
# input buys its information with the largest excursions, which the state limits of
# §7.6 would bound.
frame = ranking.to_frame()
for j, state in enumerate(["u", "theta", "q", "alpha"]):
    frame[f"peak {state}"] = ranking.state_peak[:, j]
print(frame[["rank", "det M", "tr M", "peak u", "peak theta", "peak q", "peak alpha"]])

# %%
# The candidates and each derivative's Cramér-Rao σ relative to the best input's.
mlid.plots.input_ranking(ranking)
plt.show()
