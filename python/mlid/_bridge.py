"""The one module that imports the extension mlid._core (the Fortran core
through f2py, fortran/api/mlid_api_*.f90): its interface object and the helpers
that read the core's text back.  A core status code becomes an exception in
errors.py (check_status)."""

import types

from . import _core
from .errors import check_status

#: The core's flat interface, its modules (fortran/api/mlid_api_*.f90) as one:
#: every call of the core goes through it.
api = types.SimpleNamespace(**{name: getattr(module, name)
                               for module in (_core.mlid_api_deck, _core.mlid_api_models,
                                              _core.mlid_api_fit, _core.mlid_api_frequency,
                                              _core.mlid_api_design)
                               for name in dir(module) if name.startswith("mlid_")})


class Handle:
    """A handle of the core (fortran/case/mlid_handles.f90): what the core
    keeps for one caller between calls (a deck's cases, the channels last
    read), in place of module state, so that two threads with two handles
    never see each other's work.  ``value`` is what the interface takes;
    the core's session is freed when the Python object goes."""

    def __init__(self):
        value, status, msg = api.mlid_handle_new()
        check_status(status, msg)
        self.value = int(value)

    def __del__(self):
        value, self.value = getattr(self, "value", 0), 0
        if value and api is not None:      # not at interpreter shutdown
            api.mlid_handle_free(value)


def text(b):
    """A character value of the core as Python text: decoded, blanks stripped."""
    return b.decode(errors="replace").strip()


def lines(b):
    """A newline-separated list of the core as its non-empty lines."""
    return [s for s in b.decode(errors="replace").rstrip().split("\n") if s]


#: The kinds of value the core keeps by name (mlid_named), by their code.
VALUE_REAL, VALUE_INT, VALUE_TEXT = (
    lines(api.mlid_name_list("value_kinds")).index(k) + 1 for k in ("real", "integer", "text"))
