"""The same real lateral record (fAttasAilRud2) fitted with the linear kind
(the deck attas_lat.nml: test case 1's model) and with the six-degree-of-
freedom kind in its lateral form, side by side: fit, residuals per output and
the roll and yaw damping each finds.  Every number README.md quotes for this
comparison is printed here.

    python cases/attas_lateral/sixdof_vs_linear.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.cli.deck import iter_deck

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
RECORD = DATA / "fAttasAilRud2.mat"

#: ATTAS (the reference's umr_reg_attas.m constants, refs/attas_aero_reg_tc23 header), full span b.
CONSTANTS = dict(m=17631.0, Ix=1.33367e5, Iy=2.52687e5, Iz=3.59593e5, Ixz=1.14420e4, S=64.0,
                 cbar=3.159, b=21.5, g=9.80665)
COLUMNS = ["T[s]", "AXCG[m/s2]", "AYCG[m/s2]", "AZCG[m/s2]", "AYCKP[m/s2]", "AZCKP[m/s2]",
           "PRGX[deg/s]", "QRGY[deg/s]", "RRGZ[deg/s]", "PHI[deg]", "THE[deg]", "PSI[deg]",
           "ALCG[deg]", "BECG[deg]", "VTASCG[m/s]", "HQNH[ft]", "PDOT[deg/s2]", "QDOT[deg/s2]",
           "RDOT[deg/s2]", "HRADIO[m]", "VCAS[m/s]", "DELV[deg]", "IHTRM[deg]", "N1T1L[%]",
           "N1T2R[%]", "DLC_L[deg]", "DLC_R[deg]", "DAIL_L[deg]", "DAIL_R[deg]", "DRUD[deg]",
           "MACH", "SAT[K]", "PSTAT[hPa]", "RHO[kg/m3]"]
OUTPUTS = ["PDOT", "RDOT", "AYCG", "PRGX", "RRGZ"]
#: The lateral aerodynamics: each coefficient linear over beta, the rates and the surfaces.
TERMS = {"CY": ["0", "b", "p", "r", "da", "dr"], "Cl": ["0", "b", "p", "r", "da", "dr"],
         "Cn": ["0", "b", "p", "r", "da", "dr"]}
REGRESSOR = {"0": "1", "b": "beta", "p": "phat", "r": "rhat", "da": "da", "dr": "dr"}
#: Start values: a transport aircraft's textbook signs and sizes, not this record's answer
#: (from zero the rates never move and nothing is identifiable).
START = dict(CYb=-1.0, Clb=-0.1, Clp=-0.5, Clr=0.1, Clda=-0.1, Cnb=0.1, Cnr=-0.15, Cndr=-0.07)


def sixdof_model():
    """States p, r; v, u, w from the measured V, alpha, beta and q, phi,
    theta, rho measured: inputs (the lateral decoupled form)."""
    params = {f"{c}{t}": 0.0 for c, terms in TERMS.items() for t in terms}
    params.update(START)
    defs = {c: " + ".join(f"{c}{t}*{REGRESSOR[t]}" for t in terms) for c, terms in TERMS.items()}
    return mlid.SixDofModel(
        CONSTANTS, ["p", "r"], {"pdot": "pdot", "rdot": "rdot", "ay": "ay", "p": "p", "r": "r"},
        inputs=["da", "dr", "u", "v", "w", "q", "phi", "theta", "rho"], params=params,
        definitions=dict(defs), free=list(params) + [f"bias({k})" for k in range(1, 6)])


def sixdof_record():
    return mlid.FlightData.load(
        RECORD, time_col="T", columns=COLUMNS, dt=0.04,
        input_cols=["da", "DRUD", "u", "v", "w", "QRGY", "PHI", "THE", "RHO"], output_cols=OUTPUTS,
        derived={"da": "(DAIL_R - DAIL_L)/2", "u": "VTASCG*cos(ALCG)*cos(BECG)",
                 "v": "VTASCG*sin(BECG)", "w": "VTASCG*sin(ALCG)*cos(BECG)"})


def mean_flight(data):
    """The record's mean dynamic pressure and airspeed (inputs u, v, w, rho)."""
    V = np.mean(np.linalg.norm(data.u[:, 2:5], axis=1))
    return 0.5 * np.mean(data.u[:, 8]) * V ** 2, V


def damping(six, data):
    """L_p = d(pdot)/dp and N_r = d(rdot)/dr of the six-DOF fit at the
    record's mean flight condition, the linear model's dimensional form."""
    qbar, V = mean_flight(data)
    c, est = CONSTANTS, dict(zip(six.names, six.estimate))
    gam = c["Ix"] * c["Iz"] - c["Ixz"] ** 2
    k = qbar * c["S"] * c["b"] * c["b"] / (2 * V)
    return (k * (c["Iz"] * est["Clp"] + c["Ixz"] * est["Cnp"]) / gam,
            k * (c["Ixz"] * est["Clr"] + c["Ix"] * est["Cnr"]) / gam)


def per_output(res, data):
    rms = np.sqrt(np.mean(res.residuals ** 2, axis=0))
    return rms, rms / np.std(data.y, axis=0)


def main():
    if not RECORD.is_file():
        sys.exit(f"the record is not at {RECORD}")
    case, _, lin, error = next(iter_deck(HERE / "attas_lat.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    lin_data = case.record()
    six_data = sixdof_record()
    six = mlid.fit(sixdof_model(), six_data, noise="diagonal", max_iter=50)
    print(f"{'':22}{'linear (TC1 model)':>20}{'six-DOF lateral':>20}")
    print(f"{'free parameters':22}{len(lin.names):>20}{len(six.names):>20}")
    print(f"{'iterations':22}{lin.iterations:>20}{six.iterations:>20}")
    print(f"{'det R':22}{np.linalg.det(lin.rhat):>20.4e}{np.linalg.det(six.rhat):>20.4e}")
    lr, ln = per_output(lin, lin_data)
    sr, sn = per_output(six, six_data)
    for k, name in enumerate(OUTPUTS):
        print(f"{'rms ' + name + ' / std':22}{ln[k]:>20.4f}{sn[k]:>20.4f}")
    lp, nr = damping(six, six_data)
    names = dict(zip(lin.names, lin.estimate))
    qbar, V = mean_flight(six_data)
    print(f"{'L_p [1/s]':22}{names['Lp']:>20.4f}{lp:>20.4f}")
    print(f"{'N_r [1/s]':22}{names['Nr']:>20.4f}{nr:>20.4f}")
    print(f"(six-DOF derivatives at the record's mean qbar {qbar:.0f} Pa and V {V:.1f} m/s)")
    print("\n".join(f"  {n:<6}{v: .5f}  sigma {s:.5f}" for n, v, s in
                    zip(six.names, six.estimate, six.sigma) if not n.startswith("bias")))


if __name__ == "__main__":
    main()
