"""Deck cases fitted from two Python threads at once against one after the
other (issue 40: a deck case's run releases the GIL while it fits, through
mlid_run's hooks and python/mlid/_gil.c, as main's deck fits did through
mlid_fit).  The ATTAS lateral case (cases/attas_lateral/attas_lat.nml: the
real record, 22 free parameters), each thread with a deck of its own, one
OpenMP thread; rounds alternate serial and threaded runs, and the figures
are the medians.  With the GIL held for the whole run the speed-up is about
1 (measured 0.94 on 2 cores with the hooks left out); released, near the
core count (1.87).

    .venv/bin/python benchmarks/bench_deck_threads.py [--rounds N] [--fits N]
"""

import argparse
import os
import statistics
import sys
import threading
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import mlid  # noqa: E402

ATTAS = Path(__file__).resolve().parent.parent / "cases" / "attas_lateral" / "attas_lat.nml"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--fits", type=int, default=20)
    args = ap.parse_args()
    if not (ATTAS.parent.parent.parent.parent / "shared" / "data").is_dir():
        print("skipped: the real flight records (../shared/data) are not there")
        return 0
    decks = [mlid.read_deck(ATTAS) for _ in range(2)]
    from mlid.cli.deck import run_case

    def work(deck):
        for _ in range(args.fits):
            run_case(deck[0])

    for deck in decks:
        work(deck)                                  # warm
    serial, threaded = [], []
    for _ in range(args.rounds):
        start = time.perf_counter()
        for deck in decks:
            work(deck)
        serial.append(time.perf_counter() - start)
        threads = [threading.Thread(target=work, args=(deck,)) for deck in decks]
        start = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        threaded.append(time.perf_counter() - start)
    s, t = statistics.median(serial), statistics.median(threaded)
    print(f"ATTAS lateral deck case, {2 * args.fits} fits, medians of {args.rounds} rounds: "
          f"one after another {1e3 * s:.0f} ms, two threads {1e3 * t:.0f} ms, "
          f"speed-up {s / t:.2f} ({os.cpu_count()} cores)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
