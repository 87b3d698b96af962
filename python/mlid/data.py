"""Flight records: time, inputs and outputs; text records are read by the
core's one reader (fortran/mlid_record.f90), the one mlid-batch uses."""

from pathlib import Path

import numpy as np

from ._core import mlid_api as _api
from .checks import real_array
from .errors import InputError, check_status, guarded_class
from .files import atomic_open


def _channels(a, nt, what, name):
    """a as (nt, n) float64: one row per sample; (n, nt) given the wrong way
    round, other shapes, None or text are refused (NaN is the fit's to refuse,
    with the sample named, so that a record can be cleaned first)."""
    if a is None or isinstance(a, (str, bytes, Path)):
        raise InputError(f"{name} must be an array of {what} (one row per sample), got "
                         f"{type(a).__name__}")
    a = real_array(name, a, finite=False)
    if a.ndim == 1 and a.size == nt:
        a = a.reshape(nt, 1)
    if a.ndim != 2 or a.shape[0] != nt:
        hint = f" (given n{name} x nt: transpose it)" if a.ndim == 2 and a.shape[1] == nt else ""
        raise InputError(f"{name} has shape {a.shape}; expected (nt, n{name}) = ({nt}, n), one row "
                         f"per sample{hint}")
    return np.ascontiguousarray(a)


def _units(units, n, name):
    units = ["" if u is None else str(u) for u in (units or [""] * n)]
    if len(units) != n:
        raise InputError(f"{name} has {len(units)} entries for {n} channels")
    return units


def _display(display, units, name):
    if display is None:
        return [(u, 1.0, 0.0) for u in units]
    display = [(str(u), float(s), float(o)) for u, s, o in display]
    if len(display) != len(units) or any(s == 0 for _, s, _ in display):
        raise InputError(f"{name} needs one (unit, scale, offset) per channel, scale not 0")
    return display


@guarded_class
class FlightData:
    """A record: t (nt,), u (nt, nu), y (nt, ny) in the core's units (SI,
    angles in rad), with channel names and units.

    ``input_units``/``output_units`` are the core's units of the channels
    ('' where none was declared); ``input_display``/``output_display`` are
    (unit, scale, offset) per channel, the unit the record declared and how
    to get back to it: declared = (core - offset) / scale (see ``shown``).
    """

    def __init__(self, t, u, y, input_names=None, output_names=None, source="",
                 input_units=None, output_units=None, input_display=None,
                 output_display=None):
        if t is None or isinstance(t, (str, bytes, Path)):
            raise InputError(f"t must be an array of times, got {type(t).__name__}")
        t = real_array("t", t, finite=False)
        if t.ndim != 1 and not (t.ndim == 2 and 1 in t.shape):
            raise InputError(f"t has shape {t.shape}; expected (nt,)")
        self.t = np.ascontiguousarray(t.ravel())
        nt = self.t.size
        self.u = _channels(u, nt, "inputs", "u") if nt else np.zeros((0, 0))
        self.y = _channels(y, nt, "outputs", "y") if nt else np.zeros((0, 0))
        self.input_names = list(input_names or [f"u{i + 1}" for i in range(self.u.shape[1])])
        self.output_names = list(output_names or [f"y{i + 1}" for i in range(self.y.shape[1])])
        self.source = str(source)
        if len(self.input_names) != self.u.shape[1] or len(self.output_names) != self.y.shape[1]:
            raise InputError("channel names do not match the number of input/output columns")
        self.input_units = _units(input_units, self.u.shape[1], "input_units")
        self.output_units = _units(output_units, self.y.shape[1], "output_units")
        self.input_display = _display(input_display, self.input_units, "input_display")
        self.output_display = _display(output_display, self.output_units, "output_display")

    def shown(self, which, i):
        """Channel i of the inputs ('u') or outputs ('y') in the unit the
        record declared: (values (nt,), unit); the core's values and unit
        where none was declared."""
        x, display = (self.u, self.input_display) if which == "u" else (self.y, self.output_display)
        unit, scale, offset = display[i]
        values = x[:, i]
        return (values - offset) / scale, unit

    @property
    def nt(self):
        return self.t.size

    @classmethod
    def load(cls, path, time_col=1, input_cols=(), output_cols=(), skip_rows=0,
             input_names=None, output_names=None):
        """Read a text record with the core's reader: columns separated by
        blanks, tabs or commas; '#' comments; header lines (the last one with
        a name per column names them); D exponents; a BOM; CR-LF.  Repeat
        counts, missing or extra columns, NaN/Inf, time that does not
        increase and jumps in time are errors naming the file and line.

        Columns are numbered from 1, as in a deck, or named by the header.
        Channel names default to the header's names of the columns taken.
        """
        path = str(path)
        cols = [time_col, *input_cols, *output_cols]
        names = None
        if any(isinstance(c, str) and not c.isdigit() for c in cols):
            names = cls._header(path, skip_rows)
        num = [cls._column(c, names, path) for c in cols]
        nu, ny = len(input_cols), len(output_cols)
        nt, _, header, status, msg = _api.mlid_record_open(
            path, num[0], np.array(num[1:1 + nu], dtype=np.int32),
            np.array(num[1 + nu:], dtype=np.int32), int(skip_rows), 0)
        check_status(status, msg)
        t, u, y = _api.mlid_record_get(nu, ny, nt)
        header = header.decode(errors="replace").split("\n")

        def named(given, idx):
            found = [header[k - 1] if k <= len(header) else "" for k in idx]
            return given or (found if all(found) else None)

        return cls(t, u.T, y.T, named(input_names, num[1:1 + nu]),
                   named(output_names, num[1 + nu:]), source=path)

    @staticmethod
    def _header(path, skip_rows):
        _, ncol, header, status, msg = _api.mlid_record_open(
            path, 1, np.zeros(0, np.int32), np.zeros(0, np.int32), int(skip_rows), 1)
        check_status(status, msg)
        return header.decode(errors="replace").split("\n")[:ncol]

    @staticmethod
    def _column(c, names, path):
        if isinstance(c, str) and not c.isdigit():
            if not names or c not in names:
                raise InputError(f"data file {path}: no column named {c!r}")
            return names.index(c) + 1
        try:
            k = int(c)
        except (TypeError, ValueError):
            raise InputError(f"data file {path}: column {c!r} is neither a number nor a name") \
                from None
        if not 1 <= k <= 100000:
            raise InputError(f"data file {path}: column {k} does not exist (columns count from 1)")
        return k

    def save(self, path):
        """Write t, u, y as columns with a '#' header (17 digits, exact), whole
        or not at all: to a temporary name beside path, renamed when complete."""
        names = ["t"] + self.input_names + self.output_names
        with atomic_open(path) as fh:
            np.savetxt(fh, np.column_stack([self.t, self.u, self.y]), fmt="%.16e",
                       header=" ".join(names))

    def __repr__(self):
        return (f"FlightData(nt={self.nt}, inputs={self.input_names}, "
                f"outputs={self.output_names})")
