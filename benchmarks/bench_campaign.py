"""A flight-test campaign (issue 18): 200 cases, the HFB-320 record's
output-error fit (cases/hfb320, case 1) on 200 windows of the real record
(../shared/data), each with its own condition (a made-up Mach for the
table), run by `mlid run` serially, on 2 local worker processes and on a
local Dask cluster of 2 single-threaded workers, side by side in one run.
Prints wall time, throughput and parallel efficiency, and checks that the
printout, JSON and campaign table are the serial run's.

    python benchmarks/bench_campaign.py [cases]
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
BIN = Path(sys.executable).parent


def deck(folder, n):
    """n cases: case 1 of hfb320.nml on windows ending 30 ... 60 s."""
    text = DECK.read_text()
    one = text[text.index("&case"):text.index("&case", text.index("&case") + 5)]
    one = one.replace("'../../../shared/", f"'{(REPO.parent / 'shared').resolve()}/")
    body = one[one.index("\n&model"):]
    cases = []
    for k in range(n):
        t_end = 30.0 + 30.0 * k / max(n - 1, 1)
        cases.append(f"&case title = 'window {k + 1}', job = 'estimate', mach = "
                     f"{0.3 + 0.001 * k:.3f} /"
                     + body.replace("output_cols = 'TASCG',", f"t_end = {t_end:.3f},\n"
                                    "    output_cols = 'TASCG',"))
    path = Path(folder) / "campaign.nml"
    path.write_text("\n".join(cases))
    return path


def run(path, extra, out):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    t0 = time.perf_counter()
    p = subprocess.run([str(BIN / "mlid"), "run", "-q", str(path), "--json", f"{out}.json",
                        "--campaign", f"{out}.csv", *extra], capture_output=True, text=True,
                       env=env)
    wall = time.perf_counter() - t0
    return wall, (p.returncode, p.stdout, p.stderr, Path(f"{out}.json").read_text(),
                  Path(f"{out}.csv").read_text())


def main(n=200):
    os.environ["OMP_NUM_THREADS"] = "1"         # the cluster's workers too: one thread a fit
    from distributed import LocalCluster
    with tempfile.TemporaryDirectory() as tmp:
        path = deck(tmp, n)
        serial, ref = run(path, ["--workers", "1"], f"{tmp}/serial")
        two, out2 = run(path, ["--workers", "2"], f"{tmp}/two")
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster:
            dask, outd = run(path, ["--scheduler", cluster.scheduler_address], f"{tmp}/dask")
    print(f"{n} HFB-320 output-error fits (windows 30-60 s of the real record), one thread each")
    print(f"{'run':<28} {'wall s':>8} {'fits/s':>8} {'efficiency':>10}  same output")
    for name, wall, out, workers in (("serial", serial, ref, 1), ("2 local processes", two,
                                     out2, 2), ("Dask, 2 workers", dask, outd, 2)):
        print(f"{name:<28} {wall:8.2f} {n / wall:8.1f} {serial / (workers * wall):10.2f}  "
              f"{'yes' if out == ref else 'NO'}")
    if ref[0] != 0:
        print("some cases failed:", ref[2][-500:])


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200)
