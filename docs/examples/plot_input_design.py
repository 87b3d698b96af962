"""
An optimal input and its Monte Carlo
====================================

The report's loop (NASA CR-2200 §VII–VIII) on the C-8 four-state longitudinal model:
design the input of 2 s and energy 58 that maximises the trace of the information matrix
of the five short-period derivatives (the design operator's eigenfunction, eq. 7.39),
compare its Cramér-Rao σ with a doublet of the same energy, then fly both on the model
with measurement noise and identify the derivatives in seeded Monte Carlo runs: the
sample σ of the estimates against the Cramér-Rao σ.
"""

import sys

import numpy as np
import matplotlib.pyplot as plt

import mlid

from _records import CASES

# the C-8 four-state model, its unknowns, noise, length and energy, asked of the case
# that holds them (cases/c8_monte_carlo/c8_longitudinal.py)
sys.path.insert(0, str(CASES / "c8_monte_carlo"))
from c8_longitudinal import (F0 as F, G0 as G, R_SAMPLE, DT, T, ENERGY,  # noqa: E402
                             UNKNOWNS, NAMES as LONG_NAMES)
NAMES = [LONG_NAMES[u] for u in UNKNOWNS]

design = mlid.InputDesign(F, G, np.eye(4), np.diag(R_SAMPLE * DT), UNKNOWNS)
optimal = design.optimal_input(T, ENERGY, cells=50)

# a doublet on the same 50 cells, scaled to the same energy
cells = optimal.u.shape[0]
doublet = np.where(np.arange(cells) < cells // 2, 1.0, -1.0).reshape(-1, 1)
doublet *= np.sqrt(ENERGY / (np.sum(doublet**2) * T / cells))
sigma = {"optimal": np.sqrt(np.diag(np.linalg.inv(optimal.M))),
         "doublet": np.sqrt(np.diag(np.linalg.inv(design.information(T, doublet))))}
for name, s in sigma.items():
    print(f"{name:8s} Cramér-Rao sigma: " + "  ".join(f"{n} {v:.4f}" for n, v in zip(NAMES, s)))

# %%
# Fly each input on the model (held over its cells, sampled every 0.02 s) and identify
# the five derivatives 100 times, each run with new noise, from start values 30 % off.
t = np.arange(0.0, T + DT / 2, DT)
cell = np.minimum((t / (T / cells)).astype(int), cells - 1)
truth = mlid.LinearModel(F, G, np.eye(4), r=R_SAMPLE, free=UNKNOWNS,
                         names=dict(zip(UNKNOWNS, NAMES)))
start_f = np.array(F) * np.where(np.isin(np.arange(16).reshape(4, 4), [10, 11, 15]), 1.3, 1.0)
start = mlid.LinearModel(start_f, np.array(G) * 1.3, np.eye(4), r=R_SAMPLE, free=UNKNOWNS,
                         names=dict(zip(UNKNOWNS, NAMES)))
sample = {}
for name, u in (("optimal", optimal.u), ("doublet", doublet)):
    mc = mlid.monte_carlo(truth, start, t, u[cell], runs=100, seed=1, progress=False)
    ok = mc["status"] == 0
    sample[name] = mc["estimates"][ok].std(axis=0, ddof=1)
    print(f"{name:8s} {ok.sum()} of 100 runs converged; sample sigma / CR sigma: "
          + "  ".join(f"{v:.2f}" for v in sample[name] / sigma[name]))

# %%
# The two inputs, and each derivative's σ: Cramér-Rao (bars) and the Monte Carlo's sample
# σ (points), relative to the doublet's Cramér-Rao σ.
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.4), layout="constrained")
edges = optimal.t_edges
ax1.stairs(optimal.u[:, 0], edges, label="optimal")
ax1.stairs(doublet[:, 0], edges, label="doublet")
ax1.set(xlabel="t [s]", ylabel="δe", title=f"inputs of equal energy, ∫δe² dt = {ENERGY:g}")
ax1.legend()
x = np.arange(len(NAMES))
ref = sigma["doublet"]
for k, name in enumerate(("doublet", "optimal")):
    ax2.bar(x + 0.38 * (k - 0.5), sigma[name] / ref, 0.36, label=f"{name}: Cramér-Rao σ")
    ax2.plot(x + 0.38 * (k - 0.5), sample[name] / ref, "k.", ms=8)
ax2.plot([], [], "k.", label="Monte Carlo sample σ (100 runs)")
ax2.set_xticks(x, NAMES)
ax2.set(ylabel="σ / doublet's Cramér-Rao σ", title="1σ of each derivative")
ax2.legend(fontsize=7)
plt.show()
