"""Every case deck's results from two builds, compared number by number.

    python benchmarks/compare_cases.py run OUT [--mlid PATH]
        runs `mlid run DECK --json OUT/<folder>__<deck>.json` for every deck
        cases/*/*.nml of this checkout (with the mlid given, by default the
        one beside this Python; a command line such as 'env PYTHONPATH=DIR
        python -m mlid' for another build of the package), skipping a deck whose data file is missing
        and written by none of its own cases;
    python benchmarks/compare_cases.py compare A B
        compares two such folders case by case: the largest absolute and
        relative differences of the estimates, their sigma (Cramer-Rao and
        coloured-residual corrected) and the cost (of every number of
        another job's output), and the largest difference of the estimates
        in their sigma.  'bitwise' where the two JSON objects are the same
        (the core writes every number with 17 significant digits, so that
        equal text is equal doubles); 'rounding' where nothing differs by
        more than 1e-9 relative; 'in-tol' where estimates differ by less than
        1e-3 sigma (a fit stops at a relative cost change of 1e-8, which leaves
        its estimates uncertain by some 1e-3 sigma and more: rounding that
        changes a step moves them within that band); else 'DIFFERS'.

The decks run from this checkout's cases/ (records that decks simulate are
written there, as by `mlid run`), so that another build's mlid (say main's
venv) reads the same decks and writes nothing into its own checkout.
"""

import argparse
import json
import re
import shlex
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
FIELDS = ("estimate", "sigma", "sigma_corrected")


def decks():
    return sorted((REPO / "cases").glob("*/*.nml"))


def missing_data(deck):
    """Data files the deck reads that are neither there nor written by one of its cases."""
    text = re.sub(r"!.*", "", deck.read_text())
    wanted = re.findall(r"\bfile\s*=\s*'([^']+)'", text, flags=re.IGNORECASE)
    written = {Path(p).name for p in re.findall(r"\bout\s*=\s*'([^']+)'", text, flags=re.IGNORECASE)}
    return [w for w in wanted if not (deck.parent / w).exists() and Path(w).name not in written]


def run(out, mlid):
    out.mkdir(parents=True, exist_ok=True)
    for deck in decks():
        name = f"{deck.parent.name}__{deck.stem}"
        rel = deck.relative_to(REPO)
        missing = missing_data(deck)
        if missing:
            print(f"{rel}: skipped, data missing: {', '.join(missing)}")
            continue
        t0 = time.perf_counter()
        command = shlex.split(mlid)
        command += [] if Path(command[-1]).name.startswith("mlid-batch") else ["run"]
        proc = subprocess.run(command + [str(rel), "--json", str(out / f"{name}.json")],
                              cwd=REPO, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        note = "" if proc.returncode == 0 else f" (exit {proc.returncode})"
        print(f"{rel}: {wall:.1f} s{note}")
        if not (out / f"{name}.json").is_file():
            print(f"  no JSON: {proc.stderr.strip().splitlines()[-1:]}")


def flat(x):
    """The numbers of a JSON value (lists of lists flattened)."""
    if isinstance(x, list):
        return [v for item in x for v in flat(item)]
    return [x]


def differences(a, b):
    """Largest absolute and relative difference over the FIELDS and the cost
    of a fit, over every number of another job's object."""
    da = dr = 0.0
    keys = FIELDS + ("cost",) if "estimate" in a else [k for k in a if k != "seed"]
    for key in keys:
        x, y = a.get(key), b.get(key)
        if x is None or y is None:
            continue
        for p, q in zip(flat(x), flat(y)):
            if not isinstance(p, (int, float)) or not isinstance(q, (int, float)) or p == q:
                continue
            d = abs(p - q)
            da = max(da, d)
            dr = max(dr, d / max(abs(p), abs(q)))
    return da, dr


def in_sigma(a, b):
    """Largest difference of a fit's estimates in their (first) sigma; 0 for other jobs."""
    try:
        return max((abs(p - q) / s for p, q, s in zip(a["estimate"], b["estimate"], a["sigma"])
                    if s), default=0.0)
    except (KeyError, TypeError):
        return 0.0


def compare(a_dir, b_dir):
    names = sorted({p.name for p in a_dir.glob("*.json")} | {p.name for p in b_dir.glob("*.json")})
    print(f"{'deck':<38}{'case':>5}  {'result':<10}{'max abs diff':>14}{'max rel diff':>14}"
          f"{'est/sigma':>11}  iterations")
    counts = {}
    for name in names:
        pa, pb = a_dir / name, b_dir / name
        if not (pa.is_file() and pb.is_file()):
            print(f"{name[:-5]:<38}{'':>5}  only in {'A' if pa.is_file() else 'B'}")
            continue
        ca, cb = json.loads(pa.read_text()), json.loads(pb.read_text())
        for k, (x, y) in enumerate(zip(ca, cb), 1):
            ds = in_sigma(x, y)
            if x == y:
                verdict, da, dr = "bitwise", 0.0, 0.0
            elif x.get("status") != y.get("status"):
                verdict, da, dr = "status", float("nan"), float("nan")
            else:
                da, dr = differences(x, y)
                verdict = ("rounding" if dr < 1e-9 else "in-tol" if ds < 1e-3 else "DIFFERS")
            counts[verdict] = counts.get(verdict, 0) + 1
            its = f"{x.get('iterations', '')}/{y.get('iterations', '')}" if "iterations" in x else ""
            print(f"{name[:-5]:<38}{k:>5}  {verdict:<10}{da:>14.3e}{dr:>14.3e}{ds:>11.1e}  {its}")
    print("; ".join(f"{n} {v}" for v, n in sorted(counts.items())))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run")
    r.add_argument("out", type=Path)
    r.add_argument("--mlid", default=str(Path(sys.executable).parent / "mlid"))
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    args = ap.parse_args()
    if args.command == "run":
        run(args.out.resolve(), args.mlid)
    else:
        compare(args.a, args.b)


if __name__ == "__main__":
    main()
