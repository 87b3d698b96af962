"""ATTAS short period from the raw flight records: the deck attas_sp.nml
run through the Python front end, test case 11 compared with the reference
fit of the textbook software, the second manoeuvre predicted by a fit of
the first, and the text and .mat records of the same
manoeuvre read by name to the same channels.  Every number README.md
quotes is printed here.

    python cases/attas_channels/attas_sp.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.cli.deck import iter_deck
from mlid.report.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
REF = DATA / "refs" / "attas_sp_tc11_fvsysid_octave.txt"
# Our labels -> the reference's names; 1+Z_q is stated as 1 + Zq there.
REF_NAMES = {"Z_alpha": "Zal", "1+Z_q": "Zq", "M_alpha": "Mal", "M_q": "Mq", "Z_de": "Zde",
             "Z_0": "Z0", "M_de": "Mde", "M_0": "M0"}


def main():
    if not DATA.is_dir():
        sys.exit(f"the flight records are not at {DATA}")
    cases = mlid.read_deck(HERE / "attas_sp.nml")
    results = {}
    for case, out, result, error in iter_deck(HERE / "attas_sp.nml"):
        if error:
            sys.exit(f"{case.where()}: {error}")
        results[case.index] = result
        print(f"case {case.index}: {case.title}: {result.iterations} iterations, "
              f"converged={result.converged}, det R = {result.det_r:.6e}")

    data = cases[0].record()
    print(f"\ncase 1 record: {data.nt} samples, t = {data.t[0]:g} to {data.t[-1]:g} s; "
          f"inputs {data.input_names} [{', '.join(data.input_units)}], outputs "
          f"{data.output_names} [{', '.join(data.output_units)}], shown in "
          f"{[u for u, _, _ in data.output_display]}")

    res = results[2]
    print("\ncase 2 against FVSysID test case 11 (refs/attas_sp_tc11_fvsysid_octave.txt; its Zq "
          "plus 1 for 1+Z_q)")
    print("\n".join(compare(res, read_reference(REF), REF_NAMES, {"1+Z_q": 1.0})["lines"]))

    v = results[3].validation
    print("\ncase 3: fitted on fAttasElv1.mat, fAttasElv2.mat predicted (its initial state fitted)")
    print(v.report())

    args = dict(time_col="T", input_cols=["DELV"], output_cols=["ALCG", "QRGY"],
                columns=["T[s]"] + [f"c{k}" for k in range(2, 8)] + ["QRGY[deg/s]"]
                + [f"c{k}" for k in range(9, 13)] + ["ALCG[deg]"]
                + [f"c{k}" for k in range(14, 22)] + ["DELV[deg]"])
    text = mlid.FlightData.load(DATA / "fAttasElv1_pqrDot.asc", **args)
    mat = mlid.FlightData.load(DATA / "fAttasElv1.mat", **args)
    diff = max(np.max(np.abs(text.u - mat.u)), np.max(np.abs(text.y - mat.y)))
    print(f"\nfAttasElv1_pqrDot.asc and fAttasElv1.mat, alpha, q and de by name: largest "
          f"difference {diff:.1e} rad over {text.nt} samples")


if __name__ == "__main__":
    main()
