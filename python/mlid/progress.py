"""Progress bars for long jobs: a tqdm bar on stderr when it is a terminal,
nothing otherwise.  Every function that takes ``progress=`` asks bar() or
core_bar() here, so when a bar shows is decided in one place."""

import os
import sys
import threading
import time

#: What progress=None means: None, ask whether stderr is a terminal; False,
#: never (the command line's --quiet sets this).
default = None


def _wanted(progress):
    """(show it?, the stream to write it to)."""
    if progress is None:
        progress = default
    if hasattr(progress, "write"):            # a stream: forced on, into it
        return True, progress
    if progress is None:
        stream = sys.stderr
        return bool(stream is not None and hasattr(stream, "isatty") and stream.isatty()), stream
    return bool(progress), sys.stderr


class Silent:
    """The bar when none is shown: takes every call, writes nothing."""
    total = 0
    n = 0

    def update(self, n=1):
        pass

    def set_description(self, desc=None, refresh=True):
        pass

    def set_postfix_str(self, s="", refresh=True):
        pass

    def refresh(self):
        pass

    def clear(self):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def bar(progress, total=None, desc=None, unit="it"):
    """A progress bar for a job of total steps.

    Parameters
    ----------
    progress : None, bool or a writable stream
        None (auto): shown when stderr is a terminal, unless the command
        line's ``--quiet`` turned bars off; True or False: always or never;
        a stream (anything with ``write``): shown, written to it.
    total : int, optional
        The number of steps, if known.
    desc : str, optional
        What runs, shown before the bar.
    unit : str
        What one step is ('run', 'case', 'fit').

    Returns
    -------
    A tqdm bar, or an object taking the same calls that shows nothing; use it
    as a context manager.
    """
    show, stream = _wanted(progress)
    if not show:
        return Silent()
    from tqdm import tqdm
    return tqdm(total=total, desc=desc, unit=unit, file=stream, leave=False,
                dynamic_ncols=True, mininterval=0.2)


def bump(b, total):
    """Raise the bar's total to total (jobs whose steps are learned on the way)."""
    if b.total is None or total > b.total:
        b.total = total
        b.refresh()


def shown_on(progress=None):
    """The stream a bar of ``progress`` (as bar() takes it) would show on,
    or False: decided now, for work that runs after stderr is redirected
    (a deck case's printout is captured while it runs)."""
    show, stream = _wanted(progress)
    return stream if show else False


#: How often core_bar reads the core's count, and how long work runs before
#: its bar shows: the core's own TELL_EVERY_MS and QUIET_MS
#: (fortran/base/mlid_progress.f90), which mlid-batch's line keeps to.
READ_EVERY_S = 0.1
QUIET_S = 0.5


def _quiet_s():
    """QUIET_S, or MLID_PROGRESS_QUIET_MS when it is set (as mlid-batch reads it)."""
    try:
        ms = int(os.environ["MLID_PROGRESS_QUIET_MS"])
    except (KeyError, ValueError):
        return QUIET_S
    return ms / 1000 if ms >= 0 else QUIET_S


class core_bar:
    """A bar for the core's own count of a call's long work (a Monte
    Carlo's runs, a fit's Newton iterations: fortran/base/mlid_progress.f90),
    while the block makes that call: a thread reads ``read()`` every
    READ_EVERY_S, which gives (label, done, total, exact, active, phase) as
    the core's mlid_progress_get does, and draws each piece of work that
    has run QUIET_S as a bar of its own (total the end when exact, else a
    ceiling: the bar counts without one).  The call must run without the
    GIL for the thread to read it (the core releases it around that work).
    When no bar is wanted (``progress`` as bar() takes it) no thread starts.
    ``active`` is whether a bar is being kept."""

    def __init__(self, progress, read):
        self.stream = shown_on(progress)
        self.read = read
        self.active = bool(self.stream)
        self._stop = threading.Event()
        self._thread = None

    def __enter__(self):
        if self.active:
            self._thread = threading.Thread(target=self._follow, name="mlid-progress",
                                            daemon=True)
            self._thread.start()
        return self

    def __exit__(self, *exc):
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
        return False

    def _follow(self):
        drawn, phase, since, quiet, shown = None, None, 0.0, _quiet_s(), set()
        while not self._stop.wait(READ_EVERY_S):
            label, done, total, exact, active, now = self.read()
            if now != phase or not active:        # new work, or none: the last bar goes
                if drawn is not None:
                    drawn.close()
                drawn, phase, since = None, now, time.monotonic()
            if active and drawn is None and time.monotonic() - since >= quiet:
                drawn = self._bar(label, done, total, exact)
                shown.add(now)
            elif drawn is not None and done > drawn.n:
                drawn.update(done - drawn.n)
        if drawn is not None:
            drawn.close()
        # asked for from the first step (quiet 0): work that ended between two
        # readings is drawn as it ended, so a short call shows its bar too
        label, done, total, exact, _, now = self.read()
        if quiet == 0 and now > 0 and now not in shown and done > 0:
            self._bar(label, done, total, exact).close()

    def _bar(self, label, done, total, exact):
        from tqdm import tqdm
        if exact:
            unit = "run" if label.startswith("monte carlo") else "%"     # a record's share
            return tqdm(total=total, initial=done, desc=label, unit=unit, file=self.stream,
                        leave=False, dynamic_ncols=True, mininterval=0)
        # a fit's iterations: stops when it converges, so the budget is no end
        return tqdm(initial=done, desc=f"{label} (at most {total} iterations)", unit="it",
                    file=self.stream, leave=False, dynamic_ncols=True, mininterval=0)

