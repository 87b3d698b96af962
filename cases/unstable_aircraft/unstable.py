"""The simulated unstable aircraft (FVSysID test cases 6, 7 and 8): each deck
run through the Python front end and compared with the reference fit of the
textbook software; every number README.md quotes is printed here.

    python cases/unstable_aircraft/unstable.py
"""

import sys
from pathlib import Path

import numpy as np

from mlid.deck import iter_deck

HERE = Path(__file__).resolve().parent
REFS = HERE.parents[2] / "shared" / "data" / "refs"
CASES = {"tc06": "unstab_ac_tc06_regstart_fvsysid_octave.txt",
         "tc07": "unstab_ac_tc07_eqdecoup_fvsysid_octave.txt",
         "tc08": "unstab_ac_tc08_oem_fvsysid_octave.txt"}


def reference(name):
    """Estimates and sigmas, det R and the wall time of a reference file."""
    est, det_r, wall = {}, None, None
    for line in (REFS / name).read_text().splitlines():
        if line.startswith("# Result:"):
            det_r = float(line.split("det(R) =")[1].split()[0])
        elif line.startswith("# Octave wall time:"):
            wall = float(line.split(":")[1].split()[0])
        elif line and not line.startswith("#"):
            key, value, sigma = line.split()
            est[key] = (float(value), float(sigma))
    return est, det_r, wall


def compare(deck, ref_name):
    case, _, res, error = next(iter_deck(HERE / f"{deck}.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    est, det_r, wall = reference(ref_name)
    print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged}")
    print(f"{'parameter':<9} {'unit':<11} {'ours':>16} {'reference':>16} {'diff/sigma':>11} "
          f"{'sigma ratio':>12}")
    z, ratio = [], []
    for name, unit, value, sigma in zip(res.names, res.param_units, res.estimate, res.sigma):
        ref_value, ref_sigma = est[name]
        z.append((value - ref_value) / ref_sigma)
        ratio.append(sigma / ref_sigma)
        print(f"{name:<9} {unit:<11} {value:16.9e} {ref_value:16.9e} {z[-1]:11.2e} "
              f"{ratio[-1]:12.5f}")
    f = res.model.F
    print(f"largest |difference| {np.max(np.abs(z)):.3f} sigma; sigma ratios {min(ratio):.4f} to "
          f"{max(ratio):.4f}; det R {res.det_r:.6e} against {det_r:.6e} "
          f"(relative {abs(res.det_r / det_r - 1):.1e}); {1e3 * res.wall_time:.1f} ms against "
          f"{wall} s ({wall / res.wall_time:.0f}x); eigenvalues of F {np.linalg.eigvals(f)}")


def main():
    if not REFS.is_dir():
        sys.exit(f"the references are not at {REFS}")
    for deck, ref_name in CASES.items():
        compare(deck, ref_name)


if __name__ == "__main__":
    main()
