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

import sys

import numpy as np
import matplotlib.pyplot as plt

import mlid

from _records import CASES

# the C-8 four-state model, its unknowns, noise, length and energy, asked of the case
# that holds them (cases/c8_monte_carlo/c8_longitudinal.py)
sys.path.insert(0, str(CASES / "c8_monte_carlo"))
from c8_longitudinal import F0 as F, G0 as G, R_SAMPLE, DT, T, ENERGY, UNKNOWNS  # noqa: E402

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
