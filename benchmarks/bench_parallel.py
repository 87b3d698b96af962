"""Monte Carlo runs one after another, over threads (monte_carlo_parallel:
the core's wrappers release the GIL) and over spawned processes (how
monte_carlo_parallel ran before; kept here only to compare), side by side in
one run, on the C-8 case (output error, about 2 ms a fit) and the M2/F3 case
(filter error, 20 parameters, OpenMP inside each fit).  Every way gives the
same numbers; the table prints the wall times and their ratios to serial.

    python bench_parallel.py [workers]
"""

import os
import sys
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path

import numpy as np

import mlid
from mlid.design import monte_carlo

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "cases" / "c8_monte_carlo"))
sys.path.insert(0, str(HERE.parent / "cases" / "m2f3_gusts"))
from timing import median  # noqa: E402
import c8_mc  # noqa: E402
import m2f3  # noqa: E402


def c8():
    truth, start = c8_mc.models()
    t, us, _ = c8_mc.inputs()
    return (truth, start, t, us["optimal"]), {}, 2000


def m2():
    data, _ = m2f3.record()
    free = list(m2f3.ELEMENT.values()) + ["f(5,5)", "q(1)"] + [f"r({i})" for i in range(1, 6)]
    truth = m2f3.model(m2f3.WT, free=free)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.1, 1.0))
    return (truth, start, data.t, data.u), {"method": "filter_error"}, 8


def processes(args, options, runs, workers):
    call, runs, seed, names, truth = monte_carlo._mc_setup(*args, None, runs, 1, options)
    jobs = monte_carlo._mc_chunks(runs, seed, max(1, runs // (4 * workers)))
    with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
        parts = list(pool.map(monte_carlo._mc_runs, *zip(*[(call, s, n) for s, n in jobs])))
    return monte_carlo._mc_result(parts, names, truth)


def main(workers=2):
    print(f"{os.cpu_count()} cores, {workers} workers; median of 3 wall times")
    print(f"{'case':<8}{'runs':>6}{'serial s':>10}{'threads s':>11}{'ratio':>7}"
          f"{'processes s':>13}{'ratio':>7}")
    for name, case in (("C-8", c8), ("M2/F3", m2)):
        args, options, runs = case()
        out = {}
        ways = {"serial": lambda: mlid.monte_carlo(*args, runs=runs, progress=False, **options),
                "threads": lambda: mlid.monte_carlo_parallel(*args, runs=runs, workers=workers,
                                                             progress=False, **options),
                "processes": lambda: processes(args, options, runs, workers)}
        times = {}
        for way, fn in ways.items():
            out[way] = fn()
            times[way] = median(fn, 3)
        same = all(np.array_equal(out["serial"]["estimates"], out[w]["estimates"])
                   for w in ("threads", "processes"))
        print(f"{name:<8}{runs:>6}{times['serial']:10.3f}{times['threads']:11.3f}"
              f"{times['serial'] / times['threads']:7.2f}{times['processes']:13.3f}"
              f"{times['serial'] / times['processes']:7.2f}   same numbers: {same}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2)
