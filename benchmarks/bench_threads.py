"""CPU and wall time of a fit on two OpenMP threads as the threads that
wait between the core's parallel regions spin or sleep: libgomp's default
(spin 300,000 rounds, about 7 ms here, then sleep), passive (sleep at
once), and mlid's (spin python/mlid/openmp.py's SPIN_COUNT rounds, a
quarter of a millisecond, then sleep; mlid-batch's too, fortran/app/mlid_wait_policy.f90),
with one thread for reference; and the same for mlid-batch on the whole
HFB-320 deck (user + system CPU time against wall time).  Each setting in
its own process (libgomp reads the setting once, when loaded), the
settings taking turns round by round so that the shared machine's load
falls on all of them; the figures are the medians over the rounds of each
process's least and median.

    .venv/bin/python benchmarks/bench_threads.py [--rounds N]

The fits: HFB-320 output error (cases/hfb320 case 1), ATTAS lateral
(cases/attas_lateral), ATTAS short period on two manoeuvres
(cases/attas_channels case 2), the flight-path reconstruction of test case
22 (cases/flight_path/tc22.nml) and HFB-320 filter error (cases/hfb320 case
3, about a second a fit).  The values computed are the same in every
setting (the core's sums do not depend on the threads); only the time
differs.

Measured (ours, 2 cores, --rounds 5; median CPU / median wall time, ms):
                          1 thread     spin 300000   passive       mlid's (10000)
  HFB-320 output error    4.69 / 4.69   9.05 / 5.03   5.07 / 4.87   5.38 / 4.68
  ATTAS lateral           7.00 / 7.00  14.29 / 6.42   7.32 / 6.67   8.03 / 6.60
  ATTAS, 2 manoeuvres     1.54 / 1.54   1.22 / 1.21   2.38 / 2.13   1.19 / 1.19
  flight path tc22        70.6 / 70.6   97.1 / 49.2   77.0 / 46.8   83.8 / 48.4
  HFB-320 filter error     962 / 962    1111 / 557     995 / 562     985 / 541
  mlid-batch hfb320.nml   1170 / 1171   1609 / 820    1351 / 772    1479 / 822
The output-error fits of one manoeuvre have no parallel region but the
coloured-residual correction's, at the fit's end: the long spin after it
nearly doubles their CPU time for nothing.  Sleeping at once costs a
wake-up at every region instead: the two-manoeuvre fit runs its
manoeuvres side by side every evaluation, a few hundred microseconds
apart, and took nearly 80 % more wall time passive than spinning.  The
short spin keeps the second thread's gain there, and costs 6-10 % more CPU
time than passive on the single-manoeuvre fits (against libgomp's 80-95 %
more) and 9-10 % more on tc22 and the whole deck.
"""

import argparse
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from mlid.openmp import BINDING_VARIABLES, WAIT_VARIABLES

REPO = Path(__file__).resolve().parent.parent
#: name: (deck, case index, fits per process)
FITS = {"HFB-320 output error": (REPO / "cases/hfb320/hfb320.nml", 0, 60),
        "ATTAS lateral": (REPO / "cases/attas_lateral/attas_lat.nml", 0, 40),
        "ATTAS short period, 2 manoeuvres": (REPO / "cases/attas_channels/attas_sp.nml", 1, 60),
        "flight path tc22": (REPO / "cases/flight_path/tc22.nml", 0, 6),
        "HFB-320 filter error": (REPO / "cases/hfb320/hfb320.nml", 2, 3)}
#: setting: the environment it adds (to one where nothing chooses how
#: threads wait or binds them)
SETTINGS = {"1 thread": {"OMP_NUM_THREADS": "1"},
            "2 threads, spin 300000": {"OMP_NUM_THREADS": "2", "GOMP_SPINCOUNT": "300000"},
            "2 threads, passive": {"OMP_NUM_THREADS": "2", "OMP_WAIT_POLICY": "passive"},
            "2 threads, mlid's": {"OMP_NUM_THREADS": "2"}}

CHILD = """
import sys, time, mlid
case = mlid.read_deck(sys.argv[1])[int(sys.argv[2])]
data, opts = case.record(), case.options()
mlid.fit(case.model, data, **opts)
cpu, wall = [], []
for _ in range(int(sys.argv[3])):
    c0, w0 = time.process_time(), time.perf_counter()
    mlid.fit(case.model, data, **opts)
    cpu.append(time.process_time() - c0)
    wall.append(time.perf_counter() - w0)
cpu.sort(); wall.sort()
print(cpu[0], cpu[len(cpu) // 2], wall[0], wall[len(wall) // 2])
"""


def environment(setting):
    env = {k: v for k, v in os.environ.items() if k not in WAIT_VARIABLES + BINDING_VARIABLES}
    env.update(SETTINGS[setting])
    return env


def fit_times(fit, setting):
    """Least and median CPU and wall time (ms) of one process's fits."""
    deck, index, n = FITS[fit]
    out = subprocess.run([sys.executable, "-c", CHILD, str(deck), str(index), str(n)],
                         env=environment(setting), capture_output=True, text=True, check=True)
    return [1e3 * float(v) for v in out.stdout.split()]


def batch_times(setting):
    """CPU (user + system) and wall time (s) of mlid-batch on the HFB-320 deck."""
    batch = REPO / "build" / "fortran" / "mlid-batch"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    subprocess.run([str(batch), "hfb320.nml"], cwd=REPO / "cases/hfb320", env=environment(setting),
                   capture_output=True, check=True)
    wall = time.perf_counter() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return [cpu, wall]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    print(f"{os.cpu_count()} cores; {args.rounds} rounds, the settings taking turns")
    for fit in FITS:
        runs = {s: [] for s in SETTINGS}
        for _ in range(args.rounds):
            for s in SETTINGS:
                runs[s].append(fit_times(fit, s))
        print(f"{fit} ({FITS[fit][2]} fits a process): CPU least / median, wall least / median, ms")
        for s, r in runs.items():
            c0, c1, w0, w1 = np.median(np.array(r), axis=0)
            print(f"  {s:22s} CPU {c0:8.2f} / {c1:8.2f}   wall {w0:8.2f} / {w1:8.2f}   "
                  f"CPU/wall {c1 / w1:4.2f}")
    batch = REPO / "build" / "fortran" / "mlid-batch"
    if not batch.exists():
        print("mlid-batch: not built (build/fortran/mlid-batch)")
        return
    runs = {s: [] for s in SETTINGS}
    for _ in range(args.rounds):
        for s in SETTINGS:
            runs[s].append(batch_times(s))
    print("mlid-batch hfb320.nml (4 cases): CPU and wall time, s (medians)")
    for s, r in runs.items():
        cpu, wall = np.median(np.array(r), axis=0)
        print(f"  {s:22s} CPU {cpu:6.3f}   wall {wall:6.3f}   CPU/wall {cpu / wall:4.2f}")


if __name__ == "__main__":
    main()
