"""Progress bars for long jobs: a tqdm bar on stderr when it is a terminal,
nothing otherwise.  Every function that takes ``progress=`` asks bar() here,
so when a bar shows is decided in one place."""

import sys

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
