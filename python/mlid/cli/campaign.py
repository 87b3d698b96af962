"""Flight-test campaigns (issue 18): the cases of many decks run side by
side, in local processes or on a Dask cluster, and the campaign table.

Each case is one task (a deck with a case that writes a record a later case
may read, a simulate or design job, is one task, its cases in order): a
worker reads its deck (the core holds one deck at a time, so each process
keeps the last it read) and runs the case as a serial run would, its
printout captured.  The parent prints the captured text and
collects the JSON objects and table rows in submission order, so the output
is a serial run's whatever the workers and the order they finish in.

The campaign table has one row per case: deck, case, title, the flight
condition of its &case group (mach, altitude, alpha_trim, config, tags),
whether the fit ended well, and each free parameter's estimate and
Cramer-Rao sigma (columns NAME and NAME_sigma).
"""

import csv
import io
import json
import math
import os
from pathlib import Path

from ..errors import InputError
from ..files import atomic_savefig, atomic_write_text
from ..openmp import team_size
from ..report.plots import use_file_backend
from .deck import read_deck

#: what a deck file is called
DECK_SUFFIX = ".nml"
#: the campaign table's formats, by suffix
FORMATS = ("csv", "json")


def decks(paths):
    """The decks named, a folder with *.nml files standing for them in name
    order.  Anything else is passed on as a deck, for the core's reader to
    say what is wrong with it (as mlid-batch says it)."""
    out = []
    for p in map(Path, paths):
        found = sorted(p.glob("*" + DECK_SUFFIX)) if p.is_dir() else []
        out += found or [p]
    return out


_OPENED = {"deck": None, "cases": None}


def opened(deck):
    """The cases of deck, read once per process (a worker runs a deck's
    cases one task at a time)."""
    if _OPENED["deck"] != str(deck):
        _OPENED.update(deck=None, cases=read_deck(deck))
        _OPENED["deck"] = str(deck)
    return _OPENED["cases"]


def row(case, result):
    """The campaign table's row of a case."""
    r = {"deck": str(case.deck), "case": case.index, "title": case.title, "job": case.job}
    cond = case.condition
    r.update({k: v for k, v in cond.items() if k != "tags"})
    if "tags" in cond:
        r["tags"] = "; ".join(cond["tags"])
    fitted = result is not None and not result.failed
    r["status"] = "failed" if not fitted else ("converged" if result.status == 0
                                                else "not converged")
    if fitted:
        units = getattr(result, "param_units", None) or [""] * len(result.names)
        for n, est, sd, unit in zip(result.names, result.estimate, result.sigma, units):
            r[n], r[n + "_sigma"], r[n + "_unit"] = float(est), float(sd), unit or ""
    return r


class Campaign:
    """The campaign table: one row (a dict) per case, in submission order.

    Parameters
    ----------
    rows : list of dict
        From ``row``.
    """

    def __init__(self, rows):
        self.rows = list(rows)

    @property
    def columns(self):
        """Every column, in the order first seen."""
        return list(dict.fromkeys(k for r in self.rows for k in r))

    def frame(self):
        """The table as a pandas DataFrame (pandas must be installed)."""
        import pandas as pd
        return pd.DataFrame(self.rows, columns=self.columns)

    def text(self, fmt):
        """The table as CSV or JSON text."""
        if fmt == "json":     # strict JSON: null for a number that is not finite, as the core's
            rows = [{k: None if isinstance(v, float) and not math.isfinite(v) else v
                     for k, v in r.items()} for r in self.rows]
            return json.dumps(rows, indent=1, allow_nan=False) + "\n"
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=self.columns, lineterminator="\n")
        w.writeheader()
        w.writerows(self.rows)
        return buf.getvalue()

    def write(self, path):
        """Write the table, whole or not at all; the format from the suffix
        (.csv or .json)."""
        fmt = Path(path).suffix.lower().lstrip(".")
        if fmt not in FORMATS:
            raise InputError(f"--campaign {path}: the suffix must be .csv or .json")
        atomic_write_text(path, self.text(fmt))
        return Path(path)

    def plot(self, parameter, condition, path):
        """One derivative against a flight condition, with its Cramer-Rao
        sigma as error bars (1 sigma, said in the legend), its unit on the
        axis, over the cases that have both.

        Returns
        -------
        Path
            The figure written (PNG).

        Raises
        ------
        InputError
            No case has both the parameter and the condition.
        """
        use_file_backend()
        import matplotlib.pyplot as plt
        rows = [r for r in self.rows
                if condition in r and parameter in r and math.isfinite(r[parameter])]
        if not rows:
            raise InputError(f"no case has both {parameter} and {condition}")
        x, y, s = zip(*sorted((r[condition], r[parameter], r[parameter + "_sigma"])
                              for r in rows))
        unit = next((r.get(parameter + "_unit") for r in rows if r.get(parameter + "_unit")), "")
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.errorbar(x, y, yerr=s, fmt="o", capsize=3, label="estimate ± 1σ (Cramér-Rao)")
        ax.set_xlabel(condition)
        ax.set_ylabel(f"{parameter} [{unit}]" if unit else parameter)
        ax.set_title(f"{parameter} against {condition}, {len(rows)} cases", fontsize=10)
        ax.legend(loc="best", fontsize=8)
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        atomic_savefig(fig, path, dpi=100)
        plt.close(fig)
        return Path(path)


def _worker_init(threads):
    """A worker process: the core's OpenMP teams sized to its share of the
    cores, the core's warnings printed with each case (as a serial run)."""
    import warnings
    warnings.simplefilter("ignore")
    team_size(threads)


def outcomes(task, jobs, workers=1, scheduler=None):
    """task(*job) for each job, yielded in submission order: in this
    process (workers 1), over local processes, or on a Dask cluster (a
    scheduler address or a distributed.Client)."""
    if scheduler is not None:
        from distributed import Client
        client = scheduler if hasattr(scheduler, "gather") else Client(scheduler)
        try:
            # one OpenMP thread a fit: the cluster's workers are its parallelism
            client.run(_worker_init, 1)
            futures = [client.submit(task, *j, pure=False) for j in jobs]
            for f in futures:
                yield f.result()
        finally:
            if client is not scheduler:
                client.close()
    elif workers == 1:
        for j in jobs:
            yield task(*j)
    else:
        from concurrent.futures import ProcessPoolExecutor
        threads = max(1, (os.cpu_count() or 1) // workers)
        with ProcessPoolExecutor(workers, initializer=_worker_init,
                                 initargs=(threads,)) as pool:
            futures = [pool.submit(task, *j) for j in jobs]
            for f in futures:
                yield f.result()


def check_scheduler(scheduler):
    """A scheduler address must look like one: one line otherwise."""
    if scheduler is not None and "://" not in str(scheduler):
        raise InputError(f"--scheduler {scheduler}: give an address such as "
                         "'tcp://127.0.0.1:8786'")
    return scheduler

