"""ATTAS lateral-directional: the deck attas_lat.nml (FVSysID test case 1's
model on the repeat aileron and rudder record) run through the Python front
end and compared with the reference fit of the textbook software; every
number README.md quotes is printed here.

    python cases/attas_lateral/attas_lat.py
"""

import sys
from pathlib import Path

import numpy as np

from mlid.cli.deck import iter_deck
from mlid.report.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
REF = DATA / "refs" / "attas_lat_ailrud2_tc01model_fvsysid_octave.txt"


def main():
    if not REF.is_file():
        sys.exit(f"the reference is not at {REF}")
    case, _, res, error = next(iter_deck(HERE / "attas_lat.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    ref = read_reference(REF)
    data = case.record()
    print(f"{case.title}: {data.nt} samples, t = {data.t[0]:g} to {data.t[-1]:g} s "
          f"(time rebuilt at dt = 0.04 s across the recording gap), {res.iterations} iterations, "
          f"converged={res.converged}")
    print("\n".join(compare(res, ref)["lines"]))
    print(f"diag R relative differences up to {np.max(np.abs(np.diag(res.rhat) / ref.diag_r - 1)):.1e}")
    print(f"fit {1e3 * res.wall_time:.0f} ms in-process against the reference's {ref.seconds:.1f} s "
          f"(benchmarks/bench_references.py times it side by side)")


if __name__ == "__main__":
    main()
