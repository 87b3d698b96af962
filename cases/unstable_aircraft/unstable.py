"""The simulated unstable aircraft (FVSysID test cases 6, 7 and 8): each deck
run through the Python front end and compared with the reference fit of the
textbook software; every number README.md quotes is printed here.

    python cases/unstable_aircraft/unstable.py
"""

import sys
from pathlib import Path

import numpy as np

from mlid.deck import iter_deck
from mlid.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
REFS = HERE.parents[2] / "shared" / "data" / "refs"
CASES = {"tc06": "unstab_ac_tc06_regstart_fvsysid_octave.txt",
         "tc07": "unstab_ac_tc07_eqdecoup_fvsysid_octave.txt",
         "tc08": "unstab_ac_tc08_oem_fvsysid_octave.txt",
         "tc09": "unstab_ac_tc09_stabilized_fvsysid_octave.txt",
         "tc10": "unstab_ac_tc10_eigtransf_fvsysid_octave.txt"}


def plant(model):
    """The short period's F = [[Zw, u0 + Zq], [Mw, Mq]] from the deck's
    derivatives: tc08's and tc09's F itself; not tc06's and tc07's F, which
    take measured states as inputs, nor tc10's, whose equations carry the
    shift of the transformed data."""
    v = model.value
    return np.array([[v("Zw"), 44.5695 - 1.4768], [v("Mw"), v("Mq")]])


def main():
    if not REFS.is_dir():
        sys.exit(f"the references are not at {REFS}")
    for deck, ref_name in CASES.items():
        case, _, res, error = next(iter_deck(HERE / f"{deck}.nml"))
        if error:
            sys.exit(f"{case.where()}: {error}")
        print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged}")
        print("\n".join(compare(res, read_reference(REFS / ref_name))["lines"]))
        what = "F" if deck in ("tc08", "tc09") else "the plant (from Zw, Mw, Mq, Zq, u0)"
        print(f"eigenvalues of {what} {np.linalg.eigvals(plant(res.model))}")


if __name__ == "__main__":
    main()
