"""Two builds side by side: each checkout's own benchmark scripts run in turn
(A B A B ...), the ratio B/A taken pair by pair, so that a comparison holds
on a shared machine whose speed drifts.

    python benchmarks/compare_builds.py BASE HEAD [--pairs N] [speed lti deck]

BASE and HEAD are checkouts with their venvs installed (`make install` in
each); each runs its own benchmarks/ with its own .venv, one thread.  The
figures: bench_speed.py's HFB-320, ATTAS lateral and C-8 fits (CPU and
wall), bench_lti.py's C-8 Monte Carlo (fits per CPU second, in its worker
mode), bench_deck.py's deck reader.  Printed: each figure's medians and the
median, least and largest ratio HEAD/BASE (above 1: HEAD takes longer,
except for rates, marked 'per').
"""

import argparse
import json
import os
import re
import statistics
import subprocess
from pathlib import Path

NUM = r"([0-9][0-9,]*\.?[0-9]*)"

#: Each script's figures: a name and the pattern of its number in the output.
FIGURES = {
    "speed": [("HFB-320 fit CPU ms", r"CPU time \(a loaded.*?mlid\.fit " + NUM + " ms"),
              ("HFB-320 fit wall ms", r"\(a\).*\n  mlid\.fit " + NUM + " ms"),
              ("ATTAS lateral fit CPU ms", r"\(b\) ATTAS.*?CPU time " + NUM + " ms"),
              ("ATTAS lateral fit wall ms", r"\(b\) ATTAS.*?iterations: " + NUM + " ms"),
              ("C-8 fit CPU ms", r"\(c\) C-8.*?CPU time " + NUM + " ms"),
              ("C-8 fit wall ms", r"\(c\) C-8.*?iterations: " + NUM + " ms")],
    "deck": [("decks read ms", r"read in " + NUM + " ms"),
             ("us per case", NUM + " us per case"),
             ("HFB-320 case set-up ms", r"\(deck, model, options, record\): " + NUM + " ms"),
             ("record by the core's reader ms", r"core reader " + NUM + " ms")],
}
SCRIPTS = {"speed": ["benchmarks/bench_speed.py"], "deck": ["benchmarks/bench_deck.py"],
           "lti": ["benchmarks/bench_lti.py", "--worker", "30", "3000"]}


def run(which, root):
    """The figures of one run of a script in checkout root."""
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(root / "benchmarks"))
    out = subprocess.run([str(root / ".venv" / "bin" / "python"), *SCRIPTS[which]], cwd=root,
                         env=env, capture_output=True, text=True, check=True).stdout
    if which == "lti":
        d = json.loads(out.splitlines()[-1])
        return {"C-8 Monte Carlo fits per CPU s": d["mc_fits_per_cpu_s"],
                "C-8 Monte Carlo one fit wall ms": d["c8_ms"]}
    figures = {}
    for name, pattern in FIGURES[which]:
        m = re.search(pattern, out, re.S)
        if m:
            figures[name] = float(m.group(1).replace(",", ""))
    return figures


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("base", type=Path)
    ap.add_argument("head", type=Path)
    ap.add_argument("--pairs", type=int, default=5)
    ap.add_argument("scripts", nargs="*", default=["speed", "lti", "deck"])
    args = ap.parse_intermixed_args()
    base, head = args.base.resolve(), args.head.resolve()
    print(f"BASE {base}\nHEAD {head}\n{args.pairs} pairs, one thread")
    print(f"{'figure':36s}{'BASE':>10s}{'HEAD':>10s}{'ratio':>8s}{'least':>8s}{'most':>8s}")
    for which in args.scripts:
        pairs = [(run(which, base), run(which, head)) for _ in range(args.pairs)]
        for name in pairs[0][0]:
            a = [p[0][name] for p in pairs if name in p[0] and name in p[1]]
            b = [p[1][name] for p in pairs if name in p[0] and name in p[1]]
            ratios = [y / x for x, y in zip(a, b)]
            print(f"{name:36s}{statistics.median(a):10.4g}{statistics.median(b):10.4g}"
                  f"{statistics.median(ratios):8.3f}{min(ratios):8.3f}{max(ratios):8.3f}")


if __name__ == "__main__":
    main()
