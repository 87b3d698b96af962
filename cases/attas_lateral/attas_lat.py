"""ATTAS lateral-directional: the deck attas_lat.nml (FVSysID test case 1's
model on the repeat aileron and rudder record) run through the Python front
end and compared with the reference fit of the textbook software; every
number README.md quotes is printed here.

    python cases/attas_lateral/attas_lat.py
"""

import sys
from pathlib import Path

import numpy as np

from mlid.deck import iter_deck

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
REF = DATA / "refs" / "attas_lat_ailrud2_tc01model_fvsysid_octave.txt"


def reference():
    """Estimates and Cramer-Rao sigmas, det R, diag R and the wall time of
    the reference file (its header states them)."""
    est, det_r, diag, wall = {}, None, None, None
    for line in REF.read_text().splitlines():
        if line.startswith("# Result:"):
            det_r = float(line.split("det(R) =")[1].split()[0])
        elif line.startswith("#   diag(R)"):
            diag = np.array([float(v) for v in line.split(":")[1].split()])
        elif line.startswith("# Octave wall time:"):
            wall = float(line.split(":")[1].split()[0])
        elif line and not line.startswith("#"):
            name, value, sigma = line.split()
            est[name] = (float(value), float(sigma))
    return est, det_r, diag, wall


def main():
    if not REF.is_file():
        sys.exit(f"the reference is not at {REF}")
    case, _, res, error = next(iter_deck(HERE / "attas_lat.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    est, det_r, diag, wall = reference()
    data = case.record()
    print(f"{case.title}: {data.nt} samples, t = {data.t[0]:g} to {data.t[-1]:g} s "
          f"(time rebuilt at dt = 0.04 s across the recording gap), {res.iterations} iterations, "
          f"converged={res.converged}")
    print(f"{'parameter':<9} {'unit':<11} {'ours':>15} {'reference':>15} {'diff/sigma':>11} "
          f"{'sigma ratio':>12}")
    z, ratio = [], []
    for name, unit, value, sigma in zip(res.names, res.param_units, res.estimate, res.sigma):
        ref_value, ref_sigma = est[name]
        z.append((value - ref_value) / ref_sigma)
        ratio.append(sigma / ref_sigma)
        print(f"{name:<9} {unit:<11} {value:15.8e} {ref_value:15.8e} {z[-1]:11.2e} "
              f"{ratio[-1]:12.5f}")
    print(f"largest |difference| {np.max(np.abs(z)):.3f} sigma; sigma ratios {min(ratio):.4f} to "
          f"{max(ratio):.4f}")
    print(f"det R {res.det_r:.6e} against {det_r:.6e} (relative {abs(res.det_r / det_r - 1):.1e}); "
          f"diag R relative differences up to "
          f"{np.max(np.abs(np.diag(res.rhat) / diag - 1)):.1e}")
    print(f"fit {1e3 * res.wall_time:.0f} ms in-process against the reference's {wall:.1f} s "
          f"(benchmarks/bench_references.py times it side by side)")


if __name__ == "__main__":
    main()
