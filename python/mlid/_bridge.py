"""The one module that imports the extension mlid._core (the Fortran core
through f2py, fortran/api/mlid_api_*.f90): its interface object and the helpers
that read the core's text back.  A core status code becomes an exception in
errors.py (check_status)."""

import threading
import types

import numpy as np

from . import _core
from .errors import check_status

#: The core's flat interface, its modules (fortran/api/mlid_api_*.f90) as one:
#: every call of the core goes through it.
api = types.SimpleNamespace(**{name: getattr(module, name)
                               for module in (_core.mlid_api_deck, _core.mlid_api_problem,
                                              _core.mlid_api_values,
                                              _core.mlid_api_models,
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


_local = threading.local()


def call_handle():
    """This thread's handle for calls on a problem (mlid_api_problem's
    parts, then a call such as mlid_fit, then ``values(h, 0, "call")``):
    one a thread, so that calls from two threads never share a problem."""
    h = getattr(_local, "handle", None)
    if h is None:
        h = _local.handle = Handle()
    return h


#: A scalar's shape as mlid_put_real and mlid_put_int take it.
_SCALAR = (1, 1, 1)


def put(h, **given):
    """Values by name for the next call on handle h (mlid_api_values), the
    values given before forgotten: numbers and arrays as integers (bool and
    integer types) or reals, in their shape; str as UTF-8 text."""
    hv = h.value
    check_status(*api.mlid_values_clear(hv))
    for name, v in given.items():
        kind = type(v)
        if kind is float:                   # the plain cases first: most values are
            status, msg = api.mlid_put_real(hv, name, v, 0, _SCALAR)
        elif kind is int or kind is bool:
            status, msg = api.mlid_put_int(hv, name, v, 0, _SCALAR)
        elif kind is str:
            status, msg = api.mlid_put_text(hv, name, v.encode())
        else:
            a = np.asarray(v)
            dims = (*a.shape, 1, 1, 1)[:3]
            if a.dtype.kind in "biu":
                status, msg = api.mlid_put_int(hv, name, a.astype(np.int32).ravel(order="F"),
                                               a.ndim, dims)
            else:
                status, msg = api.mlid_put_real(hv, name, a.astype(float, copy=False)
                                                .ravel(order="F"), a.ndim, dims)
        if status:
            check_status(status, msg)


def results(h):
    """What the last call on handle h gave, by name (values of 'call')."""
    return values(h, 0, "call")


def text(b):
    """A character value of the core as Python text: decoded, blanks stripped."""
    return b.decode(errors="replace").strip()


def lines(b):
    """A newline-separated list of the core as its non-empty lines."""
    return [s for s in b.decode(errors="replace").rstrip().split("\n") if s]


#: The kinds of value the core keeps by name (mlid_named), by their code.
VALUE_REAL, VALUE_INT, VALUE_TEXT = (
    lines(api.mlid_name_list("value_kinds")).index(k) + 1 for k in ("real", "integer", "text"))


def values(handle, k, which):
    """Case k of a handle by name (which 'case': the case as read; 'run':
    what its last run kept): {name: value}, numbers as floats and ints (or
    arrays of them in their shape), texts as the core's bytes."""
    h = handle.value
    m, n, nt = api.mlid_values_sizes(h, k, which)
    kinds, shapes, numbers, codes = api.mlid_values(h, k, which, m, n, nt)
    *names, texts = codes.astype(np.uint8).tobytes().split(b"\n", m)
    out, at, tat = {}, 0, 0
    for name, kind, rank, d1, d2, d3 in zip(names, kinds.tolist(), *shapes.tolist()):
        if kind == VALUE_TEXT:
            value = texts[tat:tat + d1]
            tat += d1
        elif rank == 0:
            value = numbers[at].item()
            if kind == VALUE_INT:
                value = int(value)
            at += 1
        else:
            size = d1 * d2 * d3
            value = numbers[at:at + size]
            if rank > 1:
                value = value.reshape((d1, d2, d3)[:rank], order="F")
            if kind == VALUE_INT:
                value = value.astype(np.int32)
            at += size
        out[name.decode()] = value
    return out
