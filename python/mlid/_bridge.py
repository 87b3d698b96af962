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
def _utf8_text(routine):
    """routine with its str arguments given as UTF-8 bytes: f2py takes only
    ASCII text as str ("function takes exactly 5 arguments" for a path or
    title with an accent), and the core reads UTF-8."""
    def call(*args, **kwargs):
        args = [_bytes(a) if type(a) is str else a for a in args]
        kwargs = {k: _bytes(v) if type(v) is str else v for k, v in kwargs.items()}
        return routine(*args, **kwargs)
    call.__doc__, call.__name__ = routine.__doc__, routine.__name__
    return call


#: The routines given only the bridge's own ASCII names as text (value and
#: part names), called many times a fit: left as f2py made them.
_ASCII_ONLY = ("mlid_values_sizes", "mlid_values", "mlid_put_real", "mlid_put_int",
               "mlid_put_text")


_arm = _core.mlid_api_interrupt.mlid_interrupt_arm
_disarm = _core.mlid_api_interrupt.mlid_interrupt_disarm


def _interruptible(routine):
    """routine with Ctrl-C armed while it runs (fortran/base/mlid_interrupt.c):
    a SIGINT makes the core unwind within a few milliseconds with the status
    'interrupted', and is passed on to Python's handler, which raises
    KeyboardInterrupt as the call returns (check_status raises it too).
    The arm is inside the try: an interrupt raised as it returns still
    disarms."""
    def call(*args, **kwargs):
        try:
            _arm()
            return routine(*args, **kwargs)
        finally:
            _disarm()
    call.__doc__, call.__name__ = routine.__doc__, routine.__name__
    return call


#: The routines that only copy values in or out of a handle, and make or
#: free one: not armed for Ctrl-C (arming costs a microsecond or two, some
#: 2 % of a C-8 fit were every part of its problem armed; a progress bar's
#: thread reads the count while the call it counts runs).
_COPY_ONLY = ("mlid_values_clear", "mlid_handle_new", "mlid_handle_free", "mlid_progress_get")


def _wrapped(name, routine):
    """routine as the bridge calls it: text as UTF-8 where it takes text
    (but for the value helpers), Ctrl-C armed where it computes (all but
    the value helpers, the problem's parts and the handles)."""
    if name in _ASCII_ONLY:
        return routine
    if "input string" in (routine.__doc__ or ""):
        routine = _utf8_text(routine)
    if name in _COPY_ONLY or name.startswith("mlid_set_"):
        return routine
    return _interruptible(routine)


api = types.SimpleNamespace(**{name: _wrapped(name, getattr(module, name))
                               for module in (_core.mlid_api_deck, _core.mlid_api_problem,
                                              _core.mlid_api_values,
                                              _core.mlid_api_models,
                                              _core.mlid_api_fit, _core.mlid_api_frequency,
                                              _core.mlid_api_design, _core.mlid_api_online,
                                              _core.mlid_api_regression,
                                              _core.mlid_api_table_fit)
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
            status, msg = api.mlid_put_text(hv, name, _bytes(v))
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


def run(h, routine):
    """Run routine of the core on handle h (its problem parts and given
    values set before): what it gave, by name; an exception for a status
    that is not OK."""
    check_status(*routine(h.value))
    return results(h)


def results(h):
    """What the last call on handle h gave, by name (values of 'call')."""
    return values(h, 0, "call")


def _bytes(s):
    """Text for the core: UTF-8, and a name that is no UTF-8 (a file name's
    raw bytes, as Python's os.fsdecode gives them) as its own bytes."""
    return s.encode("utf-8", "surrogateescape")


def text(b):
    """A character value of the core as Python text: decoded (bytes that are
    no UTF-8 kept as os.fsdecode keeps them, so that they go back as they
    came), blanks stripped."""
    return b.decode("utf-8", "surrogateescape").strip()


def lines(b):
    """A newline-separated list of the core as its non-empty lines."""
    return [s for s in b.decode("utf-8", "surrogateescape").rstrip().split("\n") if s]


#: The kinds of value the core keeps by name (mlid_named), by their code.
VALUE_REAL, VALUE_INT, VALUE_TEXT = (
    lines(api.mlid_name_list("value_kinds")).index(k) + 1 for k in ("real", "integer", "text"))


def values(handle, k, which):
    """Case k of a handle by name (which 'case': the case as read; 'run':
    what its last run kept; 'call': what the last call gave): {name:
    value}, numbers as floats and ints (or arrays of them in their shape),
    texts as the core's bytes."""
    h = handle.value
    m, n, nt = api.mlid_values_sizes(h, k, which)
    kinds, shapes, numbers, codes = api.mlid_values(h, k, which, m, n, nt)
    raw = codes.astype(np.uint8).tobytes()
    split = len(raw) - sum(d for kind, d in zip(kinds.tolist(), shapes[1].tolist())
                           if kind == VALUE_TEXT)                   # names, then texts
    names, scalars, arrays, texts = _layout(kinds.tobytes() + shapes.tobytes() + raw[:split],
                                            kinds, shapes, raw, m)
    out = dict(zip(names[0], numbers[scalars].tolist())) if scalars else {}
    for name, is_int in names[1]:
        out[name] = int(out[name]) if is_int else out[name]
    for name, start, stop, shape, is_int in arrays:
        value = numbers[start:stop]
        if shape is not None:
            value = value.reshape(shape, order="F")
        out[name] = value.astype(np.int32) if is_int else value
    for name, start, stop in texts:
        out[name] = raw[split + start:split + stop]
    return out


#: Layouts of packed values by their kinds, shapes and names (a call gives
#: the same each time it is made on the same sizes); cleared when full.
_LAYOUTS = {}


def _layout(key, kinds, shapes, raw, m):
    """Where each value of a packed set is: (scalar names and which are
    integers), the scalars' places, (name, start, stop, shape or None,
    integer) of each array, (name, start, stop) of each text."""
    got = _LAYOUTS.get(key)
    if got is not None:
        return got
    names = raw.split(b"\n", m)[:m]
    scalar_names, ints, scalars, arrays, texts = [], [], [], [], []
    at = tat = 0
    for name, kind, rank, d1, d2, d3 in zip(names, kinds.tolist(), *shapes.tolist()):
        name = name.decode()
        if kind == VALUE_TEXT:
            texts.append((name, tat, tat + d1))
            tat += d1
        elif rank == 0:
            scalar_names.append(name)
            if kind == VALUE_INT:
                ints.append((name, True))
            scalars.append(at)
            at += 1
        else:
            size = d1 * d2 * d3
            arrays.append((name, at, at + size, (d1, d2, d3)[:rank] if rank > 1 else None,
                           kind == VALUE_INT))
            at += size
    if len(_LAYOUTS) >= 256:
        _LAYOUTS.clear()
    got = _LAYOUTS[key] = ((scalar_names, ints), scalars, arrays, texts)
    return got


def counted(progress):
    """A handle for the core to count a call's long work in (None when no
    bar is wanted: ``progress`` as mlid.progress.bar takes it) and the
    mlid.progress.core_bar that draws its count while the call runs; the
    call takes ``counter_id(handle)``."""
    from .progress import core_bar, shown_on
    counter = Handle() if shown_on(progress) else None
    return counter, core_bar(progress if counter else False, lambda: progress_of(counter))


def counter_id(counter):
    """The handle a call counts its progress in, 0 for none."""
    return counter.value if counter is not None else 0


def progress_of(counter):
    """What the core's count in handle counter says (mlid_progress_get):
    label, done, total, exact, active, phase."""
    label, *numbers = api.mlid_progress_get(counter.value)
    return (text(label), *map(int, numbers))
