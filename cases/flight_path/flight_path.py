"""ATTAS flight-path reconstruction: the decks tc22.nml (sensor biases),
tc22b.nml (and vane calibration), tc32.nml (biases per manoeuvre) and
tc33.nml (time delays, each manoeuvre's initial state free), FVSysID test
cases 22, its variant, 32 and 33, and compatibility.nml (tc22b by the kind),
run through the Python front end and compared with the reference fits of the
textbook software; every number README.md quotes is printed here.

    python cases/flight_path/flight_path.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid

from mlid import compatibility
from mlid.deck import iter_deck
from mlid.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
DECKS = {"tc22.nml": "attas_fpr_tc22_fvsysid_octave.txt",
         "tc22b.nml": "attas_fpr_tc22b_albe_fvsysid_octave.txt",
         "tc32.nml": "attas_fpr_tc32_segbias_fvsysid_octave.txt",
         "tc33.nml": "attas_fpr_tc33_delays_fvsysid_octave.txt",
         "compatibility.nml": "attas_fpr_tc22b_albe_fvsysid_octave.txt"}


def derived_against_record():
    """How far the records' angular accelerations (columns 46-48) are from
    the ones the reference used (refs/derived/attas_fpr_pqrdot.asc)."""
    rec = np.vstack([np.loadtxt(DATA / f"fAttas{n}_pqrDot.asc")[:, 45:48]
                     for n in ("Elv1", "Ail1", "Rud1")])
    ref = np.loadtxt(DATA / "refs" / "derived" / "attas_fpr_pqrdot.asc")[:, 2:5]
    return np.max(np.abs(rec - ref))


def with_reference_channels(case):
    """tc22 fitted with the angular accelerations the reference used: the
    deck's records with inputs 7-9 replaced by refs/derived/attas_fpr_pqrdot.asc."""
    records = case.record()
    derived = np.loadtxt(DATA / "refs" / "derived" / "attas_fpr_pqrdot.asc")[:, 2:5]
    start = 0
    for rec in records:
        rec.u[:, 6:9] = derived[start:start + rec.nt]
        start += rec.nt
    return mlid.fit(case.model, records, **case.options())


def refit_of_corrected(case, res):
    """The records with the estimated corrections undone, fitted again:
    how far from neutral each correction then stands."""
    again = mlid.fit(case.model, compatibility.corrected_record(res), **case.options())
    z = {n: abs(v - compatibility.neutral(n)) / s
         for n, v, s in zip(again.names, again.estimate, again.sigma) if not n.startswith("x0")}
    worst = max(z, key=z.get)
    others = max(v for n, v in z.items() if n != worst)
    return (f"every correction within {others:.2f} Cramer-Rao sigma of neutral but {worst} "
            f"({z[worst]:.2f})")


def main():
    if not (DATA / "refs" / DECKS["tc22.nml"]).is_file():
        sys.exit(f"the references are not under {DATA / 'refs'}")
    print(f"records' angular accelerations against the reference's: at most "
          f"{derived_against_record():.1e} rad/s^2 apart")
    for deck, ref_name in DECKS.items():
        case, _, res, error = next(iter_deck(HERE / deck))
        if error:
            sys.exit(f"{case.where()}: {error}")
        ref = read_reference(DATA / "refs" / ref_name)
        print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged}")
        # each manoeuvre's initial state: x0_u#2 here, x0_u_s2 there
        print("\n".join(compare(res, ref, {n: n.replace("#", "_s") for n in res.names})["lines"]))
        print(f"diag R relative differences up to "
              f"{np.max(np.abs(np.diag(res.rhat) / ref.diag_r - 1)):.1e}")
        if deck == "tc22.nml":
            exact = compare(with_reference_channels(case), ref)["lines"][-1]
            print(f"with the reference's angular accelerations: {exact}")
        print("\n".join(compatibility.significance(res)["lines"]))
        if deck == "tc33.nml":
            print(f"the corrected records refitted: {refit_of_corrected(case, res)}")
        print(f"fit {1e3 * res.wall_time:.0f} ms in-process against the reference's {ref.seconds:.1f} s "
              f"(benchmarks/bench_references.py times it side by side)")


if __name__ == "__main__":
    main()
