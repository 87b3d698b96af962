"""The one-step global table fit (issue 46 item 2, mlid.fit_global) of the
30-manoeuvre campaign (tests/table_campaign.py: alpha 0 .. 0.18 at 10
points x Mach 0.3, 0.5, 0.7; 500 samples a manoeuvre; 17 table values and
each manoeuvre's two biases, 77 free parameters) on 1 and 2 OpenMP threads,
against the two-step route: the 30 local fits one at a time (7 free
parameters each) plus mlid.fit_tables.  The local fits twice: with the
linear model the campaign's local route uses (its exact discrete-time
step, mlid_lti_predict) and with the same model written as equations, the
global model's kind (RK4 of the core's expression graphs): the second is
like for like.

Each variant runs in its own Python thread whose fits open OpenMP teams of
1 or 2 threads (mlid.openmp.team_size: a per-thread setting).  Wall time
and CPU time (the process's, every thread's) are medians over rounds in
which the variants take turns (benchmarks/timing.py interleaved_medians),
so that a busy spell of the shared machine falls on all of them.  The
values do not depend on the threads (tests/test_global_fit.py).

    .venv/bin/python benchmarks/bench_global_fit.py [--rounds N]

Prints each variant's wall and CPU time, the global fit's parallel
efficiency (wall on 1 thread / (2 x wall on 2)), the share of its CPU time
each of the two threads did (from /proc: that the manoeuvres really run
side by side, which a loaded machine's wall times cannot show), the
machine's load average, and the ratios to the two-step route's CPU time
(the target: the one-step global fit within 3x the local fits').
"""

import argparse
import os
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import mlid
from mlid.openmp import team_size

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))
from timing import interleaved_medians  # noqa: E402
import table_campaign as tc  # noqa: E402


def thread_cpu():
    """{native thread id: user + system CPU ticks} of this process's threads
    (Linux /proc), to see which threads did a call's work whatever the
    machine's load."""
    out = {}
    for tid in os.listdir("/proc/self/task"):
        try:
            with open(f"/proc/self/task/{tid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:                       # a thread that ended meanwhile
            continue
        out[int(tid)] = int(fields[11]) + int(fields[12])
    return out


def shares(pool, fn, calls):
    """The share of fn's CPU time (calls calls in pool's thread) that the
    pool's own thread did and that the other threads (OpenMP's) did."""
    me = pool.submit(threading.get_native_id).result()
    before = thread_cpu()
    for _ in range(calls):
        pool.submit(fn).result()
    after = thread_cpu()
    used = {t: after[t] - before.get(t, 0) for t in after}
    total = sum(used.values()) or 1
    return used.get(me, 0) / total, 1 - used.get(me, 0) / total


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--calls", type=int, default=3, help="timed calls a variant a round")
    args = ap.parse_args()
    conds = tc.grid(10, [0.3, 0.5, 0.7])
    recs = [tc.record(c, k) for k, c in enumerate(conds)]
    model = tc.global_model()
    linear = [tc.local_model(c) for c in conds]          # started off the truth, as the global
    equations = [tc.local_equation_model(c) for c in conds]
    tabs = tc.global_tables()

    def one_step():
        return mlid.fit_global(model, recs, conds, variables=tc.VARIABLES)

    def two_step(models):
        local = [mlid.fit(m, d) for m, d in zip(models, recs)]
        return mlid.fit_tables(local, tabs, conds, variables=tc.VARIABLES)

    pools = {n: ThreadPoolExecutor(1, initializer=team_size, initargs=(n,)) for n in (1, 2)}

    def on(n, fn):
        return lambda: pools[n].submit(fn).result()

    variants = {"one-step global, 1 thread": on(1, one_step),
                "one-step global, 2 threads": on(2, one_step),
                "two-step, linear local fits": on(1, lambda: two_step(linear)),
                "two-step, equations local fits": on(1, lambda: two_step(equations))}
    fns = list(variants.values())
    load0 = os.getloadavg()
    g = fns[0]()
    wall = interleaved_medians(fns, args.rounds, args.calls)
    cpu = interleaved_medians(fns, args.rounds, args.calls, clock=time.process_time)
    print(f"{len(conds)} manoeuvres x {tc.NT} samples, {len(g.result.names)} free parameters in "
          f"the global fit ({g.result.iterations} iterations), 7 in each local fit; medians of "
          f"{args.rounds} interleaved rounds x {args.calls} calls:")
    for (name, _), w, c in zip(variants.items(), wall, cpu):
        print(f"  {name:<32} {1e3 * w:8.1f} ms wall  {1e3 * c:8.1f} ms CPU")
    print(f"  parallel efficiency of the global fit on 2 threads: "
          f"{wall[0] / (2 * wall[1]):.2f} (speed-up {wall[0] / wall[1]:.2f})")
    print(f"  one-step CPU (1 thread) / two-step CPU, linear local fits:    {cpu[0] / cpu[2]:.2f}"
          f"  (target <= 3)")
    print(f"  one-step CPU (1 thread) / two-step CPU, equations local fits: {cpu[0] / cpu[3]:.2f}")
    print(f"  one-step CPU (2 threads) / two-step CPU, linear local fits:   {cpu[1] / cpu[2]:.2f}")
    own, others = shares(pools[2], one_step, 10 * args.calls)
    print(f"  the global fit on 2 threads: {100 * own:.0f} % of its CPU time in the calling "
          f"thread, {100 * others:.0f} % in OpenMP's other thread (/proc, whatever the load)")
    print(f"  load average before and after: {load0[0]:.1f}, {os.getloadavg()[0]:.1f} "
          f"(2 cores; above 2, other work shares them)")
    for p in pools.values():
        p.shutdown()


if __name__ == "__main__":
    main()
