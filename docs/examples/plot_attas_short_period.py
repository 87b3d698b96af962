"""
ATTAS short period in Python
============================

The ATTAS elevator manoeuvre ``fAttasElv1.mat`` (DLR's VFW-614 research aircraft; channels
in ``../shared/data/ATTAS_CHANNELS.md``) fitted with the two-state short-period model of
FVSysID test case 11,

.. math::

   \\dot\\alpha = Z_0 + Z_\\alpha \\alpha + (1 + Z_q) q + Z_{\\delta_e} \\delta_e, \\qquad
   \\dot q = M_0 + M_\\alpha \\alpha + M_q q + M_{\\delta_e} \\delta_e,

with the trim terms :math:`Z_0, M_0` as state-equation biases ``bx``. The record is read by
name from the raw file, degrees converted to radians on reading and shown back in degrees.
Where the shared records are not beside the repository, the same model at the reference's
estimates flies the recorded-like elevator input, and its simulated record is fitted
instead.
"""

import numpy as np
import matplotlib.pyplot as plt

import mlid
from mlid.report import plots
from mlid.design.signals import input_signal

from _records import DATA

# the raw file's first 22 columns, with their units (ATTAS_CHANNELS.md)
COLUMNS = ["T[s]", "AXCG[m/s2]", "AYCG[m/s2]", "AZCG[m/s2]", "AYCKP[m/s2]", "AZCKP[m/s2]",
           "PRGX[deg/s]", "QRGY[deg/s]", "RRGZ[deg/s]", "PHI[deg]", "THE[deg]", "PSI[deg]",
           "ALCG[deg]", "BECG[deg]", "VTASCG[m/s]", "HQNH[ft]", "PDOT[deg/s2]",
           "QDOT[deg/s2]", "RDOT[deg/s2]", "HRADIO[m]", "VCAS[m/s]", "DELV[deg]"]

# start values: those of the reference software (refs/attas_sp_tc11_fvsysid_octave.txt)
F0 = [[-0.213832, 1.0278189], [-2.73646, -1.08034]]
G0 = [[0.166147], [-3.18940]]
BX0 = [-2.52504e-3, 0.271618]
FREE = ["f(1,1)", "f(1,2)", "f(2,1)", "f(2,2)", "g(1,1)", "g(2,1)", "bx(1)", "bx(2)",
        "x0(1)", "x0(2)"]
NAMES = dict(zip(FREE, ["Z_alpha", "1+Z_q", "M_alpha", "M_q", "Z_de", "M_de", "Z_0", "M_0",
                        "alpha_0", "q_0"]))


def simulated_record():
    """A record of the model at the reference's estimates, flown with a 3-2-1-1 on the
    elevator and measured with the reference's residual noise (used without ../shared)."""
    truth = mlid.LinearModel([[-0.4834, 1.1042], [-4.9265, -2.0057]], [[0.6763], [-7.2081]],
                             np.eye(2), bx=[-8.99e-3, 0.4752], x0=[0.0389, -0.0027])
    t = np.arange(0.0, 22.0, 0.04)
    u = input_signal("3211", 0.02, 2.0, 0.6, 0.04, t.size).reshape(-1, 1)
    data, _ = mlid.simulate(truth, t, u, noise_std=[1.65e-3, 2.82e-3], seed=11,
                            input_names=["de"], output_names=["ALCG", "QRGY"])
    return data


if DATA is not None:
    data = mlid.FlightData.load(DATA / "fAttasElv1.mat", time_col="T", input_cols=["de"],
                                output_cols=["ALCG", "QRGY"], columns=COLUMNS,
                                derived={"de": "DELV"}, t_start=2.0, t_end=24.0,
                                show={"ALCG": "deg", "QRGY": "deg/s", "de": "deg"})
    title = "ATTAS fAttasElv1.mat (../shared/data), 2-24 s: output error"
    print(f"flight record ../shared/data/fAttasElv1.mat: {data.nt} samples")
else:
    data = simulated_record()
    title = "simulated record of the ATTAS short-period model: output error"
    print(f"simulated record (no ../shared/data here): {data.nt} samples")

model = mlid.LinearModel(F0, G0, np.eye(2), bx=BX0, x0=data.y[0], free=FREE, names=NAMES)
res = mlid.fit(model, data, noise="diagonal", max_iter=30)
print(f"converged: {res.converged} after {res.iterations} iterations")

# %%
# The estimates by name, with their Cramér-Rao σ, as a DataFrame.
print(res.params[["estimate", "sigma_cr"]].to_string(float_format=lambda v: f"{v:.5g}"))

# %%
# Measured and model outputs, residuals and the estimates.
plots.fit_overview(res, title=title)
plt.show()
