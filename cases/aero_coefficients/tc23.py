"""ATTAS six aerodynamic coefficients by regression, FVSysID test case 23:
an equations model with no states (kind 'equations', nx = 0), its outputs the
force and moment coefficients the reference's preprocessing measured, fitted
by the output-error machinery as the reference does; every number README.md
quotes is printed here.

    python cases/aero_coefficients/tc23.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
REF = DATA / "refs" / "attas_aero_reg_tc23_fvsysid_octave.txt"
COEFFS = DATA / "refs" / "derived" / "attas_reg_tc23_tc24_coeffs.asc"
D2R = np.pi / 180

#: The reference's model (its header): coefficients linear in their parameters,
#: rates non-dimensional with the raw measured rates and the smoothed V.
OUTPUTS = {
    "CD": "CD0 + CDal*al",
    "CL": "CL0 + CLal*al",
    "Cm": "Cm0 + Cmal*al + Cmq*q*c/V + Cmde*de",
    "CY": "CY0 + CYbe*be",
    "Cl": "Cl0 + Clbe*be + Clp*p*b/V + Clr*r*b/V + Clda*da",
    "Cn": "Cn0 + Cnbe*be + Cnp*p*b/V + Cnr*r*b/V + Cndr*dr",
}
#: The parameters in the reference's order.
PARAMS = ["CD0", "CDal", "CY0", "CYbe", "CL0", "CLal", "Cl0", "Clbe", "Clp", "Clr", "Clda",
          "Cm0", "Cmal", "Cmq", "Cmde", "Cn0", "Cnbe", "Cnp", "Cnr", "Cndr"]


def record():
    """Inputs de, da, dr, p, q, r from the three records (deg -> rad), the
    smoothed al, be, V and the measured coefficients from the reference's
    derived file, row for row."""
    raw = np.vstack([np.loadtxt(DATA / f"fAttas{n}_pqrDot.asc") for n in ("Elv1", "Ail1", "Rud1")])
    der = np.loadtxt(COEFFS)
    u = np.column_stack([raw[:, 21] * D2R, (raw[:, 28] - raw[:, 27]) / 2 * D2R, raw[:, 29] * D2R,
                         raw[:, 6] * D2R, raw[:, 7] * D2R, raw[:, 8] * D2R, der[:, 8], der[:, 9],
                         der[:, 10]])
    t = np.arange(len(der)) * 0.04
    return mlid.FlightData(t, u, der[:, 2:8], input_names=["de", "da", "dr", "p", "q", "r", "al",
                                                           "be", "V"], output_names=list(OUTPUTS))


def model():
    return mlid.EquationModel(OUTPUTS, inputs=["de", "da", "dr", "p", "q", "r", "al", "be", "V"],
                              params=dict.fromkeys(PARAMS, 0.0),
                              definitions={"c": "3.159", "b": "10.75"}, free=PARAMS)


def main():
    if not REF.is_file():
        sys.exit(f"the reference is not at {REF}")
    ref = read_reference(REF)
    res = mlid.fit(model(), record(), noise="diagonal", max_iter=50)
    print(f"test case 23: {res.iterations} iterations, converged={res.converged}, no states")
    print("\n".join(compare(res, ref)["lines"]))
    print(f"diag R relative differences up to {np.max(np.abs(np.diag(res.rhat) / ref.diag_r - 1)):.1e}")
    print(f"fit {1e3 * res.wall_time:.0f} ms in-process against the reference's {ref.seconds:.1f} s")


if __name__ == "__main__":
    main()
