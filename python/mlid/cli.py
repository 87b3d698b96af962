"""The ``mlid`` command line.  Every failure is one line on stderr and a
non-zero exit code; a failing case does not stop the rest of a batch."""

import argparse
import os
import sys

from .errors import MlidError

JOBS = """jobs:
  run DECK      run every case of a namelist deck in order; deck jobs are
                'estimate' (output-error maximum-likelihood fit of the free
                parameters to a data file) and 'simulate' (write a record
                from a model, a standard input and seeded measurement noise)
"""


def _parser():
    p = argparse.ArgumentParser(
        prog="mlid", description="Maximum-likelihood identification of aircraft stability and "
        "control derivatives (NASA CR-2200 and beyond).", epilog=JOBS,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="job", metavar="JOB")
    run = sub.add_parser("run", help="run every case of a deck")
    run.add_argument("deck", help="namelist deck (.nml)")
    run.add_argument("--plots", metavar="DIR", help="write PNG plots of each fit into DIR")
    run.add_argument("--json", metavar="FILE", help="write every case's results as JSON")
    diag = sub.add_parser("diagnose", help="find what the model of each estimate case misses")
    diag.add_argument("deck", help="namelist deck (.nml)")
    diag.add_argument("--plots", metavar="DIR", help="residuals before and after, per case")
    diag.add_argument("--alpha", type=float, default=0.05, help="significance (default 0.05)")
    return p


def _run(args):
    import warnings

    from .deck import case_json, json_list, run_deck

    warnings.simplefilter("ignore")       # the core's warnings are printed with each case
    runs = run_deck(args.deck)
    failed, objects = 0, []
    for case, out, result, error in runs:
        print(f"\n case {case.index}: {case.title}")
        if out is not None and case.job == "simulate":
            print(f" simulated {out['samples']} samples to {out['out']}")
        if result is not None:
            print(result.report())
            if result.message.startswith("warning:"):
                print(f"mlid: {case.where()}: {result.message}", file=sys.stderr)
        if args.plots and result is not None:
            from .plots import plot_fit
            path = plot_fit(result, args.plots, f"case{case.index}")
            print(f" plot: {path}")
        objects.append(case_json(case, out, result, error))
        message = str(error) if error else (out or {}).get("message", "")
        if error or (out or {}).get("status", 0) != 0:
            failed += 1
            print(f" FAILED: {message}")
            print(f"mlid: {case.where()}: {message}", file=sys.stderr)
    if args.json:
        with open(args.json, "w") as fh:
            fh.write(json_list(objects))
    if failed:
        print(f"{failed} of {len(runs)} cases failed", file=sys.stderr)
    return 1 if failed else 0


def _diagnose(args):
    import warnings

    from .deck import read_deck, run_case
    from .diagnose import diagnose

    warnings.simplefilter("ignore")
    failed, cases = 0, read_deck(args.deck)
    for case in cases:
        print(f"\n case {case.index}: {case.title}")
        try:
            if case.job == "simulate" or case.error:
                out, _ = run_case(case)
                print(f" simulated {out['samples']} samples to {out['out']}")
                continue
            d = diagnose(case.model, case.record(), alpha=args.alpha, **case.options())
            print(d.report())
            if args.plots:
                path = d.plot(args.plots)
                target = path.with_name(f"case{case.index}_diagnosis.png")
                path.replace(target)
                print(f" plot: {target}")
        except MlidError as exc:
            failed += 1
            print(f" FAILED: {exc}")
            print(f"mlid: {case.where()}: {exc}", file=sys.stderr)
    if failed:
        print(f"{failed} of {len(cases)} cases failed", file=sys.stderr)
    return 1 if failed else 0


def main(argv=None):
    args = _parser().parse_args(argv)
    if args.job is None:
        _parser().print_help()
        return 2
    try:
        if args.job == "diagnose":
            return _diagnose(args)
        return _run(args)
    except MlidError as exc:
        print(f"mlid: {exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # never a traceback for a user; MLID_DEBUG=1 shows it
        if os.environ.get("MLID_DEBUG"):
            raise
        print(f"mlid: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 3
