"""Speed of the ATTAS lateral fit (cases/attas_lateral: 22 parameters, 1502
samples, 5 outputs) against the textbook software's recorded time in the
reference file (its header: Octave wall time of ml_oem2).  Measured side by
side in one run: the fit in-process (median of 20), the deck's record read
(median of 20), and a whole `mlid run` process (median of 5).  Target: at
least 300 times faster than the reference.

    python benchmarks/bench_attas_lateral.py
"""

import subprocess
import sys
from pathlib import Path

import mlid
from timing import median

REPO = Path(__file__).resolve().parent.parent
DECK = REPO / "cases" / "attas_lateral" / "attas_lat.nml"
REF = REPO.parent / "shared" / "data" / "refs" / "attas_lat_ailrud2_tc01model_fvsysid_octave.txt"


def reference_seconds():
    for line in REF.read_text().splitlines():
        if line.startswith("# Octave wall time:"):
            return float(line.split(":")[1].split()[0])
    raise SystemExit(f"no wall time in {REF}")


def main():
    if not REF.is_file():
        sys.exit(f"skipped: the reference is not at {REF}")
    ref = reference_seconds()
    case = mlid.read_deck(DECK)[0]
    data, opts = case.record(), case.options()
    res = mlid.fit(case.model, data, **opts)
    t_fit = median(lambda: mlid.fit(case.model, data, **opts), 20)
    t_read = median(lambda: mlid.read_deck(DECK)[0].record(), 20)
    mlid_exe = str(Path(sys.executable).parent / "mlid")
    t_run = median(lambda: subprocess.run([mlid_exe, "-q", "run", str(DECK)], check=True,
                                          capture_output=True), 5)
    print(f"ATTAS lateral (N = {data.nt}, nf = {len(res.names)}, {res.iterations} iterations)")
    print(f"  fit in-process     {1e3 * t_fit:8.1f} ms   {ref / t_fit:7.0f}x the reference's {ref} s")
    print(f"  deck + record read {1e3 * t_read:8.1f} ms")
    print(f"  whole mlid run     {1e3 * t_run:8.1f} ms   {ref / t_run:7.0f}x")


if __name__ == "__main__":
    main()
