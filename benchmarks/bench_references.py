"""Speed of every case deck that names a reference fit of the textbook
software (a line `! reference: ../../../shared/data/refs/<file>`) against the
time that reference records (its header's Octave wall time).  Each deck's
first case is fitted in-process: the median of 20 calls, taken in 5 rounds
over all the decks in turn, each deck's 4 calls after an untimed one (a busy
spell of the shared machine falls on all of them).  Target of issue 14: at least 300
times faster.

    python benchmarks/bench_references.py
"""

import sys
from pathlib import Path

import mlid
from mlid.report.reference import read_reference
from timing import interleaved_medians

REPO = Path(__file__).resolve().parent.parent


def reference_of(deck):
    """The reference file a deck names, or None."""
    for line in deck.read_text().splitlines():
        if line.startswith("! reference:"):
            return (deck.parent / line.split(":", 1)[1].strip()).resolve()
    return None


def main():
    decks = [(d, reference_of(d)) for d in sorted(REPO.glob("cases/*/*.nml"))]
    decks = [(d, r) for d, r in decks if r is not None]
    if not decks or not decks[0][1].is_file():
        sys.exit("skipped: the references under ../shared/data/refs are not there")
    print(f"{'deck':<38}{'N':>6}{'nf':>4}{'it':>4}{'fit ms':>10}{'reference s':>13}{'ratio':>8}")
    runs = []
    for deck, ref in decks:
        case = mlid.read_deck(deck)[0]
        data, opts = case.record(), case.options()
        res = mlid.fit(case.model, data, **opts)
        runs.append((deck, ref, data, res, lambda m=case.model, d=data, o=opts: mlid.fit(m, d, **o)))
    times = interleaved_medians([r[-1] for r in runs], 5, 4)
    for (deck, ref, data, res, _), t in zip(runs, times):
        seconds = read_reference(ref).seconds
        nt = sum(d.nt for d in data) if isinstance(data, list) else data.nt
        print(f"{str(deck.relative_to(REPO / 'cases')):<38}{nt:>6}{len(res.names):>4}"
              f"{res.iterations:>4}{1e3 * t:10.1f}{seconds:13.1f}{seconds / t:8.0f}x")


if __name__ == "__main__":
    main()
