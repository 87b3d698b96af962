"""Build step (not installed): the modules of fortran/api/ as one file for
f2py to read, with '!f2py threadsafe' in the numerical routines named below,
so their wrappers release the GIL while the core runs (Python threads then
run fits side by side: mlid.monte_carlo_parallel).

The core keeps no module state: what a caller keeps between calls is in a
handle of its own (fortran/case/mlid_handles.f90), and the core is compiled
-frecursive (locals on each thread's stack).  The routines that read decks
and records, and a deck case's run (mlid_deck_case_run), stay under the
GIL: they build text, and gfortran 12 keeps the length of a deferred-length
character result in a static variable, which two threads then share (two
threads running cases of one deck at once garbled a JSON object).  A deck
case's fit or Monte Carlo runs, which build no text, release it from inside
the run (the job runner's hooks, _gil.c).

    python f2py_threadsafe.py IN.f90... OUT.f90
"""

import re
import sys

THREADSAFE = ("mlid_fit", "mlid_evaluate", "mlid_simulate", "mlid_monte_carlo")


def mark(text):
    """text with the directive after the header (and its continuation lines)
    of each routine in THREADSAFE; every one must be found."""
    lines = text.split("\n")
    out, found, i = [], set(), 0
    head = re.compile(r"\s*subroutine\s+(\w+)\s*\(", re.I)
    while i < len(lines):
        m = head.match(lines[i])
        out.append(lines[i])
        if m and m.group(1).lower() in THREADSAFE:
            while lines[i].split("!")[0].rstrip().endswith("&"):
                i += 1
                out.append(lines[i])
            out.append("!f2py threadsafe")
            found.add(m.group(1).lower())
        i += 1
    missing = set(THREADSAFE) - found
    if missing:
        raise SystemExit(f"f2py_threadsafe: no subroutine {sorted(missing)} in the input")
    return "\n".join(out)


if __name__ == "__main__":
    *sources, dst = sys.argv[1:]
    parts = []
    for src in sources:
        with open(src, encoding="utf-8") as f:
            parts.append(f.read())
    text = mark("\n".join(parts))
    with open(dst, "w", encoding="utf-8") as f:
        f.write(text)
