"""The one module that imports the extension mlid._core (the Fortran core
through f2py, fortran/mlid_api.f90): its interface object and the helpers
that read the core's text back.  A core status code becomes an exception in
errors.py (check_status)."""

from . import _core

#: The core's flat interface: every call of the core goes through it.
api = _core.mlid_api


def text(b):
    """A character value of the core as Python text: decoded, blanks stripped."""
    return b.decode(errors="replace").strip()


def lines(b):
    """A newline-separated list of the core as its non-empty lines."""
    return [s for s in b.decode(errors="replace").rstrip().split("\n") if s]
