"""What --report costs: `mlid run DECK`, `mlid run DECK --report DIR` and
`mlid-batch DECK` as processes, side by side, round by round in turn (a busy
spell of a shared machine falls on all three), on the C-8 deck and an ATTAS
deck.  Wall time and CPU time (user + system of the process), min and
median, and the ratios report / run (the target of issue 42: <= 2).

    python benchmarks/bench_report.py [--rounds N] [--mlid PATH ...]

--mlid names other installs' `mlid` to time beside this one (e.g. a build
of main: the before and after in one table); each gets its own rows.
--breakdown also says where a report's time goes, in one process (CPU s):
the run, the imports a report needs (matplotlib, scipy.signal with
scipy.stats, jinja2) and each figure of FIT_SECTIONS, made and written.
The ATTAS deck reads the shared data (../shared/data) and is skipped
without it.
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
C8 = REPO / "cases" / "c8_short_period" / "c8.nml"
ATTAS = REPO / "cases" / "attas_channels" / "attas_sp.nml"
ATTAS_DATA = REPO.parent / "shared" / "data" / "fAttasElv1_pqrDot.asc"
BIN = Path(sys.executable).parent


def timed(argv, cwd):
    """(wall s, cpu s) of one process; its output discarded."""
    t0 = time.perf_counter()
    p = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode not in (0, 1):
        raise SystemExit(f"bench_report: {' '.join(map(str, argv))} exit {p.returncode}")
    return wall, usage.ru_utime + usage.ru_stime


def commands(deck, work, mlids):
    """The command lines timed for deck: per mlid, run and run --report;
    then mlid-batch."""
    out = {}
    for k, mlid in enumerate(mlids):
        tag = "" if k == 0 else f" [{mlid}]"
        out[f"mlid run{tag}"] = [str(mlid), "run", str(deck)]
        out[f"mlid run --report{tag}"] = [str(mlid), "run", str(deck), "--report",
                                          str(work / f"report{k}")]
    out["mlid-batch"] = [str(BIN / "mlid-batch"), str(deck)]
    return out


def bench(deck, mlids, rounds):
    work = Path(tempfile.mkdtemp(prefix="mlid_bench_report_"))
    try:
        if deck == C8:            # its simulate case writes its record beside the deck
            shutil.copy(C8, work / C8.name)
            deck = work / C8.name
        cmds = commands(deck, work, mlids)
        times = {name: [] for name in cmds}
        for name, argv in cmds.items():          # untimed: caches, the report folder
            timed(argv, deck.parent)
        for _ in range(rounds):
            for name, argv in cmds.items():
                times[name].append(timed(argv, deck.parent))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return {name: np.array(t) for name, t in times.items()}


def show(title, times, mlids):
    print(f"\n{title}")
    print(f"  {'':44s} {'wall min':>9s} {'median':>8s} {'cpu min':>8s} {'median':>8s}")
    for name, t in times.items():
        print(f"  {name:44s} {t[:, 0].min():9.3f} {np.median(t[:, 0]):8.3f} "
              f"{t[:, 1].min():8.3f} {np.median(t[:, 1]):8.3f}")
    for k, mlid in enumerate(mlids):
        tag = "" if k == 0 else f" [{mlid}]"
        run, rep = times[f"mlid run{tag}"], times[f"mlid run --report{tag}"]
        print(f"  report / run{tag}: wall {rep[:, 0].min() / run[:, 0].min():.1f}x (min) "
              f"{np.median(rep[:, 0]) / np.median(run[:, 0]):.1f}x (median), cpu "
              f"{rep[:, 1].min() / run[:, 1].min():.1f}x (min) "
              f"{np.median(rep[:, 1]) / np.median(run[:, 1]):.1f}x (median)")


def breakdown(deck):
    """CPU seconds of each stage of a C-8 report, in this process."""
    clock = time.process_time
    work = Path(tempfile.mkdtemp(prefix="mlid_bench_report_"))
    try:
        shutil.copy(deck, work / deck.name)
        t0 = clock()
        import mlid
        cases = mlid.run_deck(work / deck.name)
        stages = [("import mlid, run the deck", clock() - t0)]
        for name, stmt in (("import matplotlib (Agg), pyplot", "import matplotlib; "
                            "matplotlib.use('Agg'); import matplotlib.pyplot"),
                           ("import scipy.signal (and scipy.stats)", "import scipy.signal"),
                           ("import jinja2", "import jinja2")):
            t0 = clock()
            exec(stmt, {})
            stages.append((name, clock() - t0))
        from mlid.report import html_report
        fit = next(r for _, _, r, _ in cases if r is not None)
        for part in html_report.FIT_SECTIONS:
            if part.when is not None and not part.when(fit):
                continue
            for item in part.items:
                t0 = clock()
                block = item(fit)
                if isinstance(block, html_report.Figure):
                    stages.append((f"figure {block.id}", clock() - t0))
        t0 = clock()
        html_report.write_report(work / "report", work / deck.name, cases)
        stages.append(("write_report (all of it, imports done)", clock() - t0))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"\nwhere the time of a report goes ({deck.name}, one process, CPU s)")
    for name, t in stages:
        print(f"  {name:44s} {t:8.3f}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--mlid", action="append", default=[], metavar="PATH",
                   help="another install's mlid, timed beside this one")
    p.add_argument("--breakdown", action="store_true", help="where a report's time goes")
    args = p.parse_args(argv)
    if args.breakdown:
        breakdown(C8)
        return 0
    mlids = [BIN / "mlid", *args.mlid]
    print(f"rounds: {args.rounds}, seconds per process; cores: {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.1f}")
    show(f"C-8 ({C8.relative_to(REPO)})", bench(C8, mlids, args.rounds), mlids)
    if ATTAS_DATA.is_file():
        show(f"ATTAS ({ATTAS.relative_to(REPO)})", bench(ATTAS, mlids, args.rounds), mlids)
    else:
        print(f"\nskipped the ATTAS deck: shared data not found at {ATTAS_DATA}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
