"""Speed of the linear time-invariant output-error path (mlid_lti_predict)
and of the C-8 Monte Carlo, old build against new, side by side.

1. The ATTAS lateral fit of cases/attas_lateral/attas_lat.nml (the real
   record, the linear model: 22 free parameters), in-process: median wall
   time of mlid.fit.  Target: <= 10 ms.
2. One C-8 identification of the Monte Carlo (cases/c8_monte_carlo: four
   states, five unknowns, 101 samples, R estimated): median wall time.
3. The C-8 Monte Carlo (mlid.monte_carlo, the optimal input, one thread):
   fits per second of the process's CPU time.  Target: >= 3,000.

Each build runs in its own process (its own Python and mlid), the two in
turn round after round, so a busy spell of this shared machine falls on
both; the table gives the median over the rounds of each process's figures.

    python benchmarks/bench_lti.py [--old PYTHON] [--new PYTHON] [--rounds N]

--old defaults to main's venv (/work/main/.venv/bin/python), --new to this
Python.
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
ATTAS = ROOT / "cases" / "attas_lateral" / "attas_lat.nml"
C8 = ROOT / "cases" / "c8_monte_carlo"


def worker(fits, mc_runs):
    """This process's figures (one mlid): a dict, printed as JSON."""
    import mlid
    from mlid.cli.deck import read_deck
    from timing import median

    sys.path.insert(0, str(C8))
    import c8_longitudinal as c8
    import c8_mc

    case = read_deck(ATTAS)[0]
    data, opts = case.record(), case.options()
    res = mlid.fit(case.model, data, **opts)
    out = {"attas_samples": int(data.nt), "attas_free": int(len(res.estimate)),
           "attas_iterations": int(res.iterations),
           "attas_ms": 1e3 * median(lambda: mlid.fit(case.model, data, **opts), fits)}

    truth = c8.model(c8.DESIGN_VALUES * np.array([1.5, 0.5, 0.5, 0.5, 0.5]))   # the README's
    start = c8.model()
    u = c8_mc.held(c8_mc.inputs()["optimal"])
    t = np.arange(len(u)) * c8.DT
    rec, _ = mlid.simulate(truth, t, u, seed=1)
    out["c8_ms"] = 1e3 * median(lambda: mlid.fit(start, rec), fits)

    mlid.monte_carlo(truth, start, t, u, runs=20, seed=1, progress=False)     # warm
    c0 = time.process_time()
    mc = mlid.monte_carlo(truth, start, t, u, runs=mc_runs, seed=1, progress=False)
    cpu = time.process_time() - c0
    out["mc_fits_per_cpu_s"] = mc_runs / cpu
    out["mc_failed"] = int(np.sum(mc["status"] != 0))
    out["mc_sample_sigma"] = list(mc["summary"]["sample_sigma"])
    return out


def run_worker(python, fits, mc_runs):
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(HERE))
    r = subprocess.run([python, __file__, "--worker", str(fits), str(mc_runs)], env=env,
                       capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"{python}: {r.stderr.strip()}")
    return json.loads(r.stdout.splitlines()[-1])


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--old", default="/work/main/.venv/bin/python")
    p.add_argument("--new", default=sys.executable)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--fits", type=int, default=30)
    p.add_argument("--mc-runs", type=int, default=3000)
    args = p.parse_args()
    builds = {"old": args.old, "new": args.new}
    got = {k: [] for k in builds}
    for _ in range(args.rounds):
        for name, python in builds.items():
            got[name].append(run_worker(python, args.fits, args.mc_runs))
    med = {k: {q: float(np.median([r[q] for r in v])) for q in
               ("attas_ms", "c8_ms", "mc_fits_per_cpu_s")} for k, v in got.items()}
    first = got["new"][0]
    print(f"ATTAS lateral: {first['attas_samples']} samples, {first['attas_free']} free "
          f"parameters, {first['attas_iterations']} iterations; C-8: 101 samples, 5 free; "
          f"Monte Carlo {args.mc_runs} runs, one thread; median of {args.rounds} rounds")
    print(f"  {'':<34}{'old':>10}{'new':>10}{'old/new':>10}")
    for q, label, better in (("attas_ms", "ATTAS lateral fit [ms]", "lower"),
                             ("c8_ms", "C-8 fit [ms]", "lower"),
                             ("mc_fits_per_cpu_s", "C-8 Monte Carlo [fits/CPU s]", "higher")):
        o, n = med["old"][q], med["new"][q]
        ratio = o / n if better == "lower" else n / o
        print(f"  {label:<34}{o:10.2f}{n:10.2f}{ratio:9.2f}x")
    print(f"  targets: ATTAS <= 10 ms: {'met' if med['new']['attas_ms'] <= 10 else 'NOT met'}; "
          f"Monte Carlo >= 3000 fits/CPU s: "
          f"{'met' if med['new']['mc_fits_per_cpu_s'] >= 3000 else 'NOT met'}")
    so, sn = (np.array(got[k][0]["mc_sample_sigma"]) for k in ("old", "new"))
    print(f"  Monte Carlo sample sigma, largest relative difference old/new: "
          f"{np.max(np.abs(sn / so - 1)):.1e}; failed runs {got['old'][0]['mc_failed']} / "
          f"{got['new'][0]['mc_failed']}")


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--worker":
        print(json.dumps(worker(int(sys.argv[2]), int(sys.argv[3]))))
    else:
        main()
