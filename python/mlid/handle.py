"""A handle of the core (fortran/case/mlid_handles.f90): what the core keeps
for one caller between calls (a deck's cases, the channels last read), in
place of module state, so that two threads with two handles never see each
other's work.  Freed when the Python object goes."""

from ._core import mlid_api as _api
from .errors import check_status


class Handle:
    """One core session; ``value`` is what the flat interface takes."""

    def __init__(self):
        value, status, msg = _api.mlid_handle_new()
        check_status(status, msg)
        self.value = int(value)

    def __del__(self):
        value, self.value = getattr(self, "value", 0), 0
        if value and _api is not None:      # not at interpreter shutdown
            _api.mlid_handle_free(value)
