"""The ``mlid`` command line.  Every failure is one line on stderr and a
non-zero exit code; a failing case does not stop the rest of a batch."""

import argparse
import contextlib
import os
import sys

from .. import progress
from .._version import installed_version
from ..discrepancy.diagnose import FAMILIES, diagnose
from ..errors import InputError, InternalError, MlidError
from ..estimate.table import WRITERS, ResultsTable, results_table
from ..files import atomic_write_text, check_writable, same_file
from ..frequency.responses import fit_transfer_function, record_response
from ..report import plots
from ..report.html_report import load_template, write_report
from ..report.plots import fit_writers, plot_online_history, plot_validation, use_file_backend
from . import campaign
from .campaign import FORMATS, decks as named_decks
from .deck import FIT_JOBS, case_json, json_list, read_deck, run_case, run_cases

JOBS = """jobs:
  run DECK       run every case of a namelist deck in order.  Deck jobs:
                 'estimate'  maximum-likelihood fit of the free parameters to one
                             data file or several (manoeuvres fitted together);
                             output error, or filter error with process noise
                             (&estimate method), equation-error start-up,
                             a priori weighting, bounds, rank-deficient steps
                 'validate'  an estimate fit on the files not listed in &data
                             holdout, then a prediction of those that are:
                             Theil's U and rms/sigma per output
                 'simulate'  write a record from a model, a standard input (or
                             a record's, input_file) and seeded measurement noise
                 'design'    the optimal input for the unknowns (report ch. 7),
                             written as a record; its information summary
                 'monte_carlo'  seeded runs: simulate from the truth, fit,
                             repeat; the statistics of Table 8.1
  diagnose DECK  what the model of each estimate case misses
  bode DECK      fit one estimate case of a linear model and draw its Bode plot
                 (Cramer-Rao bands) against the record's measured frequency
                 response and coherence, optionally with a transfer-function fit
"""


class _Version(argparse.Action):
    """--version, its number looked up only when asked."""

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"mlid {installed_version()}")
        parser.exit()


def _parser():
    p = argparse.ArgumentParser(
        prog="mlid", description="Maximum-likelihood identification of aircraft stability and "
        "control derivatives (NASA CR-2200 and beyond).", epilog=JOBS,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--version", action=_Version, nargs=0,
                   help="show program's version number and exit")
    p.add_argument("-q", "--quiet", action="store_true",
                   help="no progress bars (they show only when stderr is a terminal)")
    quiet = argparse.ArgumentParser(add_help=False)     # also after the job's name
    quiet.add_argument("-q", "--quiet", action="store_true", default=argparse.SUPPRESS,
                       help="no progress bars")
    sub = p.add_subparsers(dest="job", metavar="JOB")
    run = sub.add_parser("run", help="run every case of a deck", parents=[quiet])
    run.add_argument("deck", nargs="+", help="namelist decks (.nml), or folders of them: a "
                     "campaign, its cases run side by side")
    run.add_argument("--workers", type=int, metavar="N", help="local processes running cases "
                     "side by side (default: 1 for one deck, the cores for several); the "
                     "output is a serial run's")
    run.add_argument("--scheduler", metavar="ADDRESS", help="run the cases on a Dask cluster "
                     "(dask.distributed), e.g. tcp://127.0.0.1:8786")
    run.add_argument("--campaign", metavar="FILE", help="the campaign table: one row per case "
                     "with its flight condition (&case mach, altitude, alpha_trim, config, "
                     "tags) and the estimates with sigma; .csv or .json")
    run.add_argument("--campaign-plots", metavar="DIR", help="each estimate against the flight "
                     "condition --against, with sigma bars, one PNG each")
    run.add_argument("--against", default="mach", metavar="CONDITION",
                     help="the condition of --campaign-plots (default mach)")
    run.add_argument("--plots", metavar="DIR", help="write PNG plots of each fit into DIR")
    run.add_argument("--json", metavar="FILE", help="write every case's results as JSON")
    run.add_argument("--table", metavar="FILE",
                     help="write the results table of every fitted case into one FILE, a "
                     "'case' column numbering the deck's cases; format from the suffix: "
                     ".csv, .tex (LaTeX booktabs) or .json")
    run.add_argument("--report", metavar="DIR", help="write one self-contained HTML page of "
                     "the deck, DIR/<deck name>.html, with every case's tables and figures")
    run.add_argument("--report-template", metavar="FILE", help="a jinja2 template of the "
                     "--report page in place of mlid's own (its variables: "
                     "mlid.report.html_report)")
    diag = sub.add_parser("diagnose", help="find what the model of each estimate case misses",
                          parents=[quiet])
    diag.add_argument("deck", help="namelist deck (.nml)")
    diag.add_argument("--plots", metavar="DIR", help="residuals before and after, per case")
    diag.add_argument("--alpha", type=float, default=0.05, help="significance (default 0.05)")
    diag.add_argument("--json", metavar="FILE", help="write every case's diagnosis as JSON")
    diag.add_argument("--families", metavar="LIST",
                      help="the candidate families tried, comma-separated (default: all of "
                           "bias, derivative, nonlinear, delay, scale, lag, noise, feedback)")
    diag.add_argument("--max-effects", type=int, default=3, metavar="N",
                      help="effects accepted at most, one per round (default 3)")
    bode = sub.add_parser("bode", help="Bode plot of a case's identified linear model against "
                          "its record's frequency response", parents=[quiet])
    bode.add_argument("deck", help="namelist deck (.nml)")
    bode.add_argument("--case", type=int, default=1, metavar="K",
                      help="the estimate case, from 1 (default 1)")
    bode.add_argument("--input", default="0", metavar="NAME", help="input channel (default the first)")
    bode.add_argument("--output", default="0", metavar="NAME",
                      help="output channel (default the first)")
    bode.add_argument("--out", required=True, metavar="FILE", help="the figure (.png)")
    bode.add_argument("--segment", type=int, metavar="N",
                      help="samples per averaged segment (default: a power of two, a quarter "
                      "of the record or less)")
    bode.add_argument("--loes", metavar="M,N", help="also fit and draw a transfer function of "
                      "numerator order M, denominator order N with a time delay")
    bode.add_argument("--band", metavar="FMIN,FMAX", help="the LOES fit's range in Hz")
    return p


def _pair_list(text, what, kind):
    try:
        a, b = (kind(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"{what} must be two numbers 'a,b', got {text!r}") from None
    return a, b


def _channel_arg(text):
    """A channel given on the command line: an index when it is a number."""
    return int(text) if text.isdigit() else text


def _bode(args):
    """Fit one case, draw its Bode plot against the record's response."""

    check_writable(args.out, "--out")
    loes = _pair_list(args.loes, "--loes", int) if args.loes else None
    if args.band and not args.loes:
        raise InputError("--band is the LOES fit's frequency range: give --loes M,N with it")
    band = _pair_list(args.band, "--band", float) if args.band else (None, None)
    cases = read_deck(args.deck)
    if not 1 <= args.case <= len(cases):
        raise InputError(f"{args.deck}: --case {args.case}: the deck has {len(cases)} cases")
    case = cases[args.case - 1]
    if case.job != "estimate":
        raise InputError(f"{args.deck}: case {args.case} is a '{case.job}' case, not 'estimate'")
    _, result = run_case(case)
    manoeuvres = result.evaluate_args[0]         # the records as given: no segment spans two
    measured = record_response(manoeuvres, _channel_arg(args.input), _channel_arg(args.output),
                               segment=args.segment)
    print(f"case {args.case}: {case.title}: {measured.output_name}/{measured.input_name}, "
          f"{measured.averages} averages of {measured.segment} samples")
    fit = None
    if loes:
        fit = fit_transfer_function(measured, *loes, f_min=band[0], f_max=band[1])
        print(fit.report())
    plots.use_file_backend()
    fig = plots.bode_measured(result, measured.input_name, measured.output_name, measured,
                              loes=fit, path=args.out)
    plots.close(fig)
    print(f"wrote {args.out}")
    return 0


def _not_an_input(path, option, decks):
    """An output file may be no file a case reads or writes (the core's
    case_uses, as mlid-batch checks --json): the decks are read once for
    that before any case runs (an unreadable one is reported in its turn),
    and kept for the run (campaign.opened)."""
    from .._bridge import api

    for deck in decks:
        try:
            cases = campaign.opened(deck)
        except MlidError:
            continue
        for case in cases:
            if api.mlid_case_uses(case._handle.value, case.index, str(path)):
                raise InputError(f"cannot write {option} {path} (a file this run reads or "
                                 f"writes: {deck} case {case.index})")


def _outputs_writable(args):
    """--json, --table, --campaign, --plots and --report destinations tried
    before any case runs: each a file of its own that no case reads or
    writes."""
    from pathlib import Path

    decks = named_decks(args.deck if isinstance(args.deck, list) else [args.deck])
    suffixes = {"--campaign": (FORMATS, "must be .csv or .json"),
                "--table": (WRITERS, "must be one of " + ", ".join("." + s for s in WRITERS))}
    files = {}
    for option in ("--json", "--table", "--campaign"):
        path = getattr(args, option[2:], None)
        if not path:
            continue
        if option in suffixes and Path(path).suffix.lower().lstrip(".") not in suffixes[option][0]:
            raise InputError(f"{option} {path}: the suffix {suffixes[option][1]}")
        check_writable(path, option, decks)
        _not_an_input(path, option, decks)
        for other, its in files.items():
            if same_file(its, path):
                raise InputError(f"{other} and {option} name one file, {path}: each output "
                                 "goes to a file of its own")
        files[option] = path
    template = getattr(args, "report_template", None)
    if template and not args.report:
        raise InputError("--report-template needs --report DIR")
    if template:
        load_template(template)
    for option in ("plots", "report", "campaign_plots"):
        folder = getattr(args, option, None)
        if not folder:
            continue
        try:
            Path(folder).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"cannot make --{option.replace('_', '-')} folder {folder}: "
                             f"{exc.strerror}") from None
        check_writable(Path(folder) / "plot.png", f"--{option.replace('_', '-')} into")


def _attempt(what, fn, *args):
    """fn(*args), or the error it raised as an MlidError naming what failed."""
    try:
        return fn(*args), None
    except MlidError as exc:
        return None, exc
    except Exception as exc:  # a plot or a write: one line, the batch goes on
        if os.environ.get("MLID_DEBUG"):
            raise
        return None, InternalError(f"{what}: {type(exc).__name__}: {exc}")


def _failed(case, error):
    """Say that a case failed, as the core's runner says it."""
    print(f" FAILED: {error}")
    print(f"mlid: {case.where()}: {error}", file=sys.stderr)


def _online_estimate(out):
    """An online job's history from its JSON object, for its figure."""
    import numpy as np
    from ..online import OnlineEstimate
    return OnlineEstimate(np.asarray(out["t"], float), out["parameters"],
                          np.asarray(out["estimates"], float), np.asarray(out["sigma"], float))


def _show_case(args, case, out, result, error, tables):
    """Print a case's report and write its table rows and plots; returns
    whether it failed and the error still to say (one the core's run did
    not: a table's or a plot's, or the case's when it did not run).  The
    report and notes are the core's (mlid-batch prints the same); a failed
    fit has its report (last values) and no table or plot; an estimate that
    did not converge is a result with a warning, not a failure."""
    print(_heading(case), end="")
    if out is not None:
        print(out.report, end="")
        for note in out.notes:
            print(f"mlid: {case.where()}: {note}", file=sys.stderr)
    failed = error is not None
    unsaid = error if out is None else None
    fitted = result is not None and not result.failed
    if args.table and fitted:
        table, table_error = _attempt("table", results_table, result, case.index)
        if table is not None:
            tables.append(table)
        unsaid = unsaid or table_error
    checked = getattr(result, "validation", None)
    if args.plots and out is not None and error is None and case.job == "online" and "t" in out:
        path, plot_error = _attempt("plot", plot_online_history, _online_estimate(out),
                                    args.plots, f"case{case.index}")
        if path is not None:
            print(f" plot: {path}")
        unsaid = unsaid or plot_error
    if args.plots and fitted:
        title = f"{case.deck} case {case.index}: {case.title}"
        plots = [(lambda r, f, s, w=write: w(r, f, s, title), result)
                 for write in fit_writers(result)] + (
            [(plot_validation, checked)] if checked else [])
        for fn, what in plots:
            path, plot_error = _attempt("plot", fn, what, args.plots, f"case{case.index}")
            if path is not None:
                print(f" plot: {path}")
            unsaid = unsaid or plot_error
    return failed or unsaid is not None, unsaid


def _case_task(deck, ks, plots, table, keep, live=False):
    """Run cases ks of deck in order as a serial run would, each one's
    printout captured: per case (stdout, stderr, JSON object, table rows,
    failed, campaign row, and with keep what --report needs, else None: the
    fit stays in the worker).  A worker's task (mlid.cli.campaign.outcomes).
    live (the cases run in this process, one at a time): a case's long work
    shows a bar when stderr is a terminal, the one stderr is before it is
    captured."""
    import io
    from contextlib import redirect_stderr, redirect_stdout
    from types import SimpleNamespace

    if plots:
        use_file_backend()
    done = []
    bar_on = progress.shown_on() if live else False
    for k in ks:
        case = campaign.opened(deck)[k - 1]
        out_text, err_text, tables = io.StringIO(), io.StringIO(), []
        with redirect_stdout(out_text), redirect_stderr(err_text):
            try:
                case, out, result, error = next(run_cases([case], bar_on))
            except KeyboardInterrupt as exc:    # what mlid-batch has printed by then
                exc.finished = done, _heading(case)
                raise
            obj = case_json(case, out, error)
            bad, unsaid = _show_case(SimpleNamespace(plots=plots, table=table), case, out, result,
                                     error, tables)
            if unsaid:
                _failed(case, unsaid)
        done.append((out_text.getvalue(), err_text.getvalue(), obj, tables, bad,
                     campaign.row(case, result), (case, out, result, error) if keep else None))
    return done


#: jobs whose cases write a record a later case of the deck may read: such a
#: deck runs as one task, its cases in order
WRITING_JOBS = ("simulate", "design")


def _jobs(args):
    """The tasks: (deck, its case numbers, ...) with one case each, or all of
    a deck's cases when one writes a record (WRITING_JOBS); the number of
    decks that cannot be read (said on stderr) and of decks named (a
    folder's counted)."""
    jobs, unread = [], 0
    decks = campaign.decks(args.deck)
    folders = _plot_folders(decks, args.plots)
    for deck in decks:
        try:
            cases = campaign.opened(deck)
        except MlidError as exc:
            if len(decks) == 1:
                raise
            print(f"mlid: {exc}", file=sys.stderr)
            unread += 1
            continue
        ks = list(range(1, len(cases) + 1))
        groups = [ks] if any(c.job in WRITING_JOBS for c in cases) else [[k] for k in ks]
        jobs += [(str(deck), g, folders.get(deck), bool(args.table), bool(args.report))
                 for g in groups]
    return jobs, unread, len(decks)


def _plot_folders(decks, plots):
    """Each deck's folder of plots: --plots itself for one deck, a folder
    of its own in it, named after the deck, for several (each deck's
    case1_fit.png replaced the last one's); decks of one name in two
    folders are told apart by their folders."""
    if not plots:
        return {}
    if len(decks) == 1:
        return {decks[0]: plots}
    from pathlib import Path

    stems = [Path(d).stem for d in decks]
    names = [s if stems.count(s) == 1 else str(Path(d).with_suffix("")).strip("/").replace(
        "/", "_") for s, d in zip(stems, decks)]
    names = [n if names.count(n) == 1 else f"{n}_{k + 1}" for k, n in enumerate(names)]
    return {d: str(Path(plots) / n) for d, n in zip(decks, names)}


def _heading(case):
    """A case's heading in the report, as mlid-batch prints it."""
    return f"\n case {case.index}: {case.title}\n"


def _up_to_an_interrupt(outcomes):
    """The cases' outcomes; on Ctrl-C, the reports of the cases its task had
    finished and the heading of the case it stopped, as mlid-batch prints
    them, before the interrupt goes on."""
    try:
        yield from outcomes
    except KeyboardInterrupt as exc:
        finished, heading = getattr(exc, "finished", ([], ""))
        for text, err, *_ in finished:
            sys.stdout.write(text)
            sys.stderr.write(err)
        sys.stdout.write(heading)
        sys.stdout.flush()
        raise


def _run(args):
    import warnings


    _outputs_writable(args)
    campaign.check_scheduler(args.scheduler)
    if args.plots or args.report or args.campaign_plots:
        use_file_backend()
    warnings.simplefilter("ignore")       # the core's warnings are printed with each case
    jobs, unread, ndecks = _jobs(args)
    failed = 0
    workers = args.workers
    if workers is None:
        workers = 1 if len(args.deck) == 1 else (os.cpu_count() or 1)
    if workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    if args.report and (workers > 1 or args.scheduler):
        raise InputError("--report needs the cases in this process: --workers 1, no "
                         "--scheduler")
    objects, tables, ran, rows = [], [], [], []
    n = sum(len(j[1]) for j in jobs)
    cases = progress.bar(None if n > 1 else False, n, "mlid run", "case")
    workers = min(workers, max(len(jobs), 1))
    live = workers == 1 and args.scheduler is None       # a bar of a case's own work too
    outcomes = (c for task in campaign.outcomes(_case_task, [(*j, live) for j in jobs], workers,
                                                args.scheduler) for c in task)
    for text, err, obj, rows_of, bad, crow, done in _up_to_an_interrupt(outcomes):
        cases.update()
        cases.clear()                     # the case's lines go above the bar
        sys.stdout.write(text)
        sys.stdout.flush()
        sys.stderr.write(err)
        objects.append(obj)
        tables += rows_of
        rows.append(crow)
        if args.report:
            ran.append(done)
        failed += bad
        cases.refresh()
    cases.close()
    _say_failures(failed, len(objects), unread, ndecks)
    writes = []
    if args.json:
        writes.append((f"--json {args.json}", atomic_write_text, args.json, json_list(objects)))
    if args.table:
        writes.append((f"--table {args.table}", ResultsTable.concat(tables).write, args.table))
    if args.campaign:
        writes.append((f"--campaign {args.campaign}", campaign.Campaign(rows).write,
                       args.campaign))
    if args.report:
        writes.append((f"--report {args.report}", write_report, args.report, args.deck[0], ran,
                       args.report_template))
    for what, fn, *fn_args in writes:
        path, error = _attempt(what, fn, *fn_args)
        if error:
            print(f"mlid: {error}", file=sys.stderr)
            return 1
        if what.startswith("--report"):
            print(f" report: {path}")
    if args.campaign_plots:
        failed += _campaign_plots(campaign.Campaign(rows), args)
    return 1 if failed or unread else 0


def _say_failures(failed, ncases, unread, ndecks):
    """The closing lines of a run that did not all go well (mlid-batch's)."""
    if failed:
        print(f"{failed} of {ncases} cases failed", file=sys.stderr)
    if unread:
        print(f"{unread} of {ndecks} decks could not be read", file=sys.stderr)


def _campaign_plots(table, args):
    """Each estimate against --against, one PNG each; 1 if one failed."""
    from pathlib import Path
    params = [c[:-len("_sigma")] for c in table.columns if c.endswith("_sigma")]
    bad = 0
    for p in params:
        path, error = _attempt("--campaign-plots", table.plot, p, args.against,
                               Path(args.campaign_plots) / f"{p}_vs_{args.against}.png")
        if error:
            print(f"mlid: {error}", file=sys.stderr)
            bad = 1
        else:
            print(f" plot: {path}")
    return bad


def _diagnose(args):
    import json
    import warnings


    _outputs_writable(args)
    families = FAMILIES
    if args.families is not None:
        families = tuple(f.strip() for f in args.families.split(",") if f.strip())
        unknown = [f for f in families if f not in FAMILIES]
        if unknown or not families:
            print(f"mlid: --families: unknown {', '.join(unknown) or '(none given)'}; known: "
                  f"{', '.join(FAMILIES)}", file=sys.stderr)
            return 1
    if args.max_effects < 0:
        print(f"mlid: --max-effects must be >= 0, got {args.max_effects}", file=sys.stderr)
        return 1
    warnings.simplefilter("ignore")
    failed, cases, objects = 0, read_deck(args.deck), []
    for case in cases:
        print(_heading(case), end="")
        d = None
        if case.job not in FIT_JOBS or case.error:
            out, error = _attempt("run", run_case, case)
            if out:
                print(out[0].report, end="")
        else:
            d, error = _attempt("diagnose", lambda: diagnose(
                case.model, case.record(), families=families, alpha=args.alpha,
                max_effects=args.max_effects, **case.options()))
            for text in case.warnings:
                print(f"mlid: {case.where()}: warning: {text}", file=sys.stderr)
            if d is not None:
                print(d.report())
                if args.plots:
                    path, error = _attempt("plot", d.plot, args.plots)
                    if path is not None:
                        target = path.with_name(f"case{case.index}_diagnosis.png")
                        path.replace(target)
                        print(f" plot: {target}")
        objects.append({"case": case.index, "title": case.title, "job": case.job,
                        "diagnosis": None if d is None else d.as_dict(),
                        "error": str(error) if error else None})
        if error:
            failed += 1
            _failed(case, error)
    if failed:
        print(f"{failed} of {len(cases)} cases failed", file=sys.stderr)
    if args.json:
        _, error = _attempt(f"--json {args.json}", atomic_write_text, args.json,
                            json.dumps(objects, indent=1, allow_nan=False) + "\n")
        if error:
            print(f"mlid: {error}", file=sys.stderr)
            return 1
    return 1 if failed else 0


def _utf8_streams():
    """stdout and stderr in UTF-8, as mlid-batch writes the core's text,
    whatever the locale or PYTHONIOENCODING says (an ASCII terminal got an
    internal error for a CJK title); bytes of the core's text that are no
    UTF-8 (a deck's Latin-1, a file name's raw bytes) go out as they came,
    as mlid-batch writes them."""
    for stream in (sys.stdout, sys.stderr):
        if hasattr(stream, "reconfigure"):
            try:
                stream.reconfigure(encoding="utf-8", errors="surrogateescape")
            except (ValueError, OSError):      # closed, or already read from
                pass


def _matplotlib_folder():
    """A folder for matplotlib's settings and font cache where its own
    (~/.config/matplotlib) cannot be made: one of mlid's in the temporary
    folder, kept between runs (with an unwritable HOME matplotlib made a new
    one on every run and said so on stderr).  Nothing when MPLCONFIGDIR is
    set already."""
    if os.environ.get("MPLCONFIGDIR"):
        return
    home = os.environ.get("XDG_CONFIG_HOME") or os.path.join(os.path.expanduser("~"), ".config")
    own = os.path.join(home, "matplotlib")
    try:
        os.makedirs(own, exist_ok=True)
        if os.access(own, os.W_OK):
            return
    except OSError:
        pass
    import tempfile
    ours = os.path.join(tempfile.gettempdir(), f"mlid-matplotlib-{os.getuid()}")
    try:
        os.makedirs(ours, mode=0o700, exist_ok=True)
    except OSError:
        return
    os.environ["MPLCONFIGDIR"] = ours


def main(argv=None):
    _utf8_streams()
    _matplotlib_folder()
    args = _parser().parse_args(argv)
    was, progress.default = progress.default, (False if args.quiet else progress.default)
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = out, err = _Checked(sys.stdout), _Checked(sys.stderr)
    try:
        code = _main(args)
        out.flush()
    finally:
        progress.default = was
        sys.stdout, sys.stderr = streams
    if out.lost:            # as mlid-batch says it, after the rest, and fails
        print(f"mlid: {STDOUT_LOST}", file=err)
        return code or 1
    return code


#: What both front ends say when the report could not go to stdout.
STDOUT_LOST = "the report could not be written to stdout (closed or full)"


class _Checked:
    """A standard stream as the run writes to it: a write or flush that
    fails (the stream closed, so None here; a full disk) is noted in
    ``lost``, not raised, so that the rest of the run and its files go on.
    A broken pipe is still raised: the reader went away (mlid run | head)."""

    def __init__(self, stream):
        self.stream, self.lost = stream, False

    def write(self, text):
        try:
            return self.stream.write(text)
        except BrokenPipeError:
            raise
        except (OSError, AttributeError, ValueError):
            self._lose()
            return len(text)

    def flush(self):
        try:
            self.stream.flush()
        except BrokenPipeError:
            raise
        except (OSError, AttributeError, ValueError):
            self._lose()

    def _lose(self):
        """Noted; what is still buffered goes to /dev/null, so that the
        interpreter's own flush at its end fails no more."""
        self.lost = True
        with contextlib.suppress(OSError, AttributeError, ValueError):
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self.stream.fileno())

    def __getattr__(self, name):
        return getattr(self.stream, name)


def _main(args):
    if args.job is None:
        _parser().print_help()
        return 2
    try:
        if args.job == "diagnose":
            return _diagnose(args)
        if args.job == "bode":
            return _bode(args)
        return _run(args)
    except BrokenPipeError:
        # the reader went away (mlid run deck | head): end quietly, as a
        # program killed by SIGPIPE would
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 141
    except KeyboardInterrupt:
        # Ctrl-C: the core's call unwound within milliseconds (mlid_interrupt);
        # one line, as mlid-batch says it, no --json, and 130 as a shell
        # reports a SIGINT
        print("mlid: interrupted", file=sys.stderr)
        return 130
    except MlidError as exc:
        print(f"mlid: {exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # never a traceback for a user; MLID_DEBUG=1 shows it
        if os.environ.get("MLID_DEBUG"):
            raise
        print(f"mlid: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 3
