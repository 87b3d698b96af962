"""Flight records: time, inputs and outputs, loaded from text files."""

from pathlib import Path

import numpy as np

from .errors import InputError


class FlightData:
    """A record: t (nt,), u (nt, nu), y (nt, ny), with channel names."""

    def __init__(self, t, u, y, input_names=None, output_names=None, source=""):
        self.t = np.ascontiguousarray(t, dtype=float).ravel()
        nt = self.t.size
        self.u = np.asarray(u, dtype=float).reshape(nt, -1) if nt else np.zeros((0, 0))
        self.y = np.asarray(y, dtype=float).reshape(nt, -1) if nt else np.zeros((0, 0))
        self.input_names = list(input_names or [f"u{i + 1}" for i in range(self.u.shape[1])])
        self.output_names = list(output_names or [f"y{i + 1}" for i in range(self.y.shape[1])])
        self.source = str(source)
        if len(self.input_names) != self.u.shape[1] or len(self.output_names) != self.y.shape[1]:
            raise InputError("channel names do not match the number of input/output columns")

    @property
    def nt(self):
        return self.t.size

    @classmethod
    def load(cls, path, time_col=1, input_cols=(), output_cols=(), skip_rows=0,
             input_names=None, output_names=None):
        """Read whitespace- or comma-separated columns; '#' starts a comment.

        Columns are numbered from 1, as in a deck, or named when the file
        has a header row (give ``skip_rows=1`` and names instead of numbers).
        """
        path = Path(path)
        if not path.is_file():
            raise InputError(f"file not found: {path}")
        header = None
        with open(path) as fh:
            lines = fh.readlines()
        if skip_rows:
            header = lines[skip_rows - 1].replace(",", " ").split()
        delimiter = "," if any("," in ln for ln in lines[skip_rows:skip_rows + 5]) else None
        try:
            table = np.loadtxt(lines[skip_rows:], delimiter=delimiter, ndmin=2)
        except ValueError as exc:
            raise InputError(f"data file {path}: malformed numbers ({exc})") from None
        if table.size == 0:
            raise InputError(f"data file {path}: no data rows")

        def col(c):
            if isinstance(c, str) and not c.isdigit():
                if header is None or c not in header:
                    raise InputError(f"data file {path}: no column named {c!r}")
                return header.index(c)
            k = int(c)
            if not 1 <= k <= table.shape[1]:
                raise InputError(f"data file {path}: column {k} requested, the file has "
                                 f"{table.shape[1]} columns")
            return k - 1

        t = table[:, col(time_col)]
        u = table[:, [col(c) for c in input_cols]]
        y = table[:, [col(c) for c in output_cols]]
        return cls(t, u, y, input_names, output_names, source=path)

    def save(self, path):
        """Write t, u, y as columns with a '#' header (17 digits, exact)."""
        names = ["t"] + self.input_names + self.output_names
        np.savetxt(path, np.column_stack([self.t, self.u, self.y]), fmt="%.16e",
                   header=" ".join(names))

    def __repr__(self):
        return (f"FlightData(nt={self.nt}, inputs={self.input_names}, "
                f"outputs={self.output_names})")
