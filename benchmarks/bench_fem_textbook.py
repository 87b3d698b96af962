"""Speed of FVSysID's filter error ml_fem2 on the real HFB-320 record
(cases/hfb320, case 5: noise_criterion = 'textbook', 15 parameters, 601
samples, 7 outputs, nonlinear model), in-process (the core called from
Python), median of 20 fits on one thread, against the reference's 84.4 s
of Octave CPU (read from the header of
../shared/data/refs/hfb320_fem_tc04_fvsysid_octave.txt).  Target: at least
1000 times faster.

    OMP_NUM_THREADS=1 python benchmarks/bench_fem_textbook.py
"""

import re
import time
from pathlib import Path

import numpy as np

import mlid

REPO = Path(__file__).resolve().parent.parent
DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
REF = REPO.parent / "shared" / "data" / "refs" / "hfb320_fem_tc04_fvsysid_octave.txt"


def main():
    if not REF.is_file():
        print(f"skipped: the reference is not at {REF}")
        return
    cpu = float(re.search(r"Octave CPU ([\d.]+) s", REF.read_text(encoding="utf-8")).group(1))
    case = mlid.read_deck(DECK)[4]
    data, opts = case.record(), case.options()
    times = []
    for _ in range(20):
        t0 = time.perf_counter()
        res = mlid.fit(case.model, data, **opts)
        times.append(time.perf_counter() - t0)
    wall = float(np.median(times))
    print(f"HFB-320 ml_fem2 (noise_criterion = 'textbook'), in-process: {1e3 * wall:.1f} ms "
          f"(median of 20; min {1e3 * min(times):.1f} ms), {res.iterations} iterations, "
          f"{1e3 * wall / res.iterations:.2f} ms per iteration, det R {res.det_r:.6e}")
    print(f"FVSysID ml_fem2: {cpu} s of Octave CPU; ratio {cpu / wall:.0f}x "
          f"(target >= 1000x: {'met' if cpu / wall >= 1000 else 'NOT met'})")


if __name__ == "__main__":
    main()
