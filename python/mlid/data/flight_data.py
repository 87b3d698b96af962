"""Flight records: time, inputs and outputs; text records are read by the
core's one reader (fortran/case/mlid_record.f90), the one mlid-batch uses."""

import warnings
from pathlib import Path

import numpy as np

from .._bridge import Handle, api as _api, put, results
from ..checks import real_array
from ..errors import InputError, MlidWarning, check_status, guarded_class
from ..files import atomic_open


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


def _lines(entries, what):
    """Channel names or numbers, or 'NAME = text' entries from a dict, one per
    line (the core's form)."""
    if entries is None:
        return "\n"
    if isinstance(entries, dict):
        entries = [f"{k} = {v}" for k, v in entries.items()]
    if isinstance(entries, (str, int, np.integer)):
        entries = [entries]
    out = []
    for e in entries:
        if not isinstance(e, (str, int, np.integer)) or "\n" in str(e) or isinstance(e, bool):
            raise InputError(f"{what}: {e!r} is neither a channel number nor a name")
        out.append(str(e).strip())
    return "\n".join(out) + "\n"


def _window(t_start, t_end, dt):
    """The window and time step as the core takes them (0: the record's time)."""
    if dt is not None and not float(dt) > 0:
        raise InputError(f"dt must be > 0 (a uniform time step replacing the record's time), "
                         f"got {dt}")
    return {"t_start": -np.inf if t_start is None else float(t_start),
            "t_end": np.inf if t_end is None else float(t_end),
            "dt": 0.0 if dt is None else float(dt)}


def _spec(time_col, input_cols, output_cols, columns, units, derived, show):
    """The channel spec as the core's flat interface takes it, by name."""
    return {"time": _lines(time_col, "time_col"), "inputs": _lines(input_cols, "input_cols"),
            "outputs": _lines(output_cols, "output_cols"), "columns": _lines(columns, "columns"),
            "units": _lines(units, "units"), "derived": _lines(derived, "derived"),
            "show": _lines(show, "show")}


def _dataset_frame(frame, time_col):
    """An xarray Dataset as the DataFrame from_frame takes: its variables
    along its one dimension as columns, named 'NAME[unit]' from a variable's
    ``units`` attribute, the time coordinate as the index (time_col its
    name); anything else is returned as it is."""
    if not (hasattr(frame, "data_vars") and hasattr(frame, "coords")):
        return frame
    dims = list(frame.dims)
    if len(dims) != 1:
        raise InputError(f"from_frame takes a Dataset of one dimension (time), this one has "
                         f"{len(dims)}: {', '.join(map(str, dims))}")
    table = frame.to_dataframe()
    units = {str(k): str(v.attrs.get("units", "")).strip() for k, v in frame.variables.items()}
    table.columns = [f"{c}[{units[str(c)]}]" if units.get(str(c)) else str(c)
                     for c in table.columns]
    if str(time_col) != str(table.index.name) and str(time_col) != "index":
        table = table.reset_index()     # time is a variable, not the coordinate
    return table


def _time_in_seconds(frame, time_col):
    """frame with its time as a column of seconds: the index when time_col
    is "index" or the index's name (and no column's), dates and durations
    (datetime64, timedelta64, with or without a time zone) as seconds from
    the first sample.  Any other column of dates or durations is refused:
    as numbers they are nanoseconds, never what a channel means."""
    if not hasattr(frame, "dtypes") or not hasattr(frame, "index"):
        return frame
    import pandas as pd

    columns = [str(c) for c in frame.columns]
    index_name = frame.index.name
    by_index = isinstance(time_col, str) and (time_col == "index" or (
        index_name is not None and time_col == str(index_name)))
    if by_index and time_col in columns:
        raise InputError(f"time_col '{time_col}' names both a column and the index: rename one")
    if by_index:
        name = time_col if time_col != "index" else "index"
        frame = frame.reset_index(drop=False)
        frame.columns = [name] + columns
        columns = [name] + columns
    for c, dtype in zip(columns, frame.dtypes):
        if not (pd.api.types.is_datetime64_any_dtype(dtype)
                or pd.api.types.is_timedelta64_dtype(dtype)):
            continue
        if c != str(time_col):
            raise InputError(f"column {c} holds {'dates' if 'datetime' in str(dtype) else 'durations'}"
                             f" ({dtype}); only the time column may (time_col = {time_col!r})")
    if isinstance(time_col, str) and time_col in columns:
        k = columns.index(time_col)
        col = frame.iloc[:, k]
        if pd.api.types.is_datetime64_any_dtype(col.dtype) or \
                pd.api.types.is_timedelta64_dtype(col.dtype):
            if col.isna().any():
                raise InputError(f"time column {time_col} has a missing value (NaT) at row "
                                 f"{int(np.flatnonzero(col.isna().to_numpy())[0])}")
            seconds = (col - col.iloc[0]).dt.total_seconds() if len(col) else col.astype(float)
            frame = frame.copy()
            frame.isetitem(k, seconds.to_numpy(dtype=float))
    return frame


def read_status(status, msg):
    """The core channel reader's status: raise for an error; a warning it
    left (values that look wrong for their declared unit) becomes an
    MlidWarning, and its text is returned ('' when there is none)."""
    check_status(status, msg)
    text = msg.decode(errors="replace").strip() if isinstance(msg, bytes) else str(msg).strip()
    if not text.startswith("warning:"):
        return ""
    text = text[len("warning:"):].strip()
    warnings.warn(text, MlidWarning, stacklevel=3)
    return text


def _counts(spec):
    """Inputs and outputs of a spec."""
    return tuple(len([s for s in spec[k].split("\n") if s]) for k in ("inputs", "outputs"))


def _text_lines(text, n):
    return text.decode(errors="replace").split("\n")[:n]


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

    Time, inputs and outputs may hold NaN here: a fit refuses them with the
    sample named, so that a record can be cleaned first.  ``load`` and
    ``from_frame`` read records from files and DataFrames.

    Parameters
    ----------
    t : array_like (nt,)
        Sample times [s].
    u : array_like (nt, nu)
        Inputs, one row per sample (a vector for one input).
    y : array_like (nt, ny)
        Outputs, one row per sample (a vector for one output).
    input_names, output_names : list of str, optional
        Channel names (default u1, u2, ... and y1, y2, ...).
    source : str
        Where the record came from (a path), for messages.
    input_units, output_units : list of str, optional
        The core's unit of each channel ('' unknown).
    input_display, output_display : list of (str, float, float), optional
        (unit, scale, offset) per channel (default: the core's unit, 1, 0).

    Raises
    ------
    InputError
        t not a vector, u or y not one row per sample (given transposed, the
        message says so), or names, units or display not one per channel.

    Examples
    --------
    >>> import mlid
    >>> data = mlid.FlightData([0.0, 0.1, 0.2], [1.0, 0.0, -1.0],
    ...                        [[0.0, 1.0], [0.1, 0.9], [0.3, 0.7]],
    ...                        input_names=["de"], output_names=["alpha", "q"])
    >>> data
    FlightData(nt=3, inputs=['de'], outputs=['alpha', 'q'])
    >>> data.y.shape
    (3, 2)
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
        """A channel in the unit the record declared.

        Parameters
        ----------
        which : {'u', 'y'}
            Inputs or outputs.
        i : int
            The channel, from 0.

        Returns
        -------
        values : ndarray (nt,)
            (core value - offset) / scale; the core's values where the
            record declared no unit.
        unit : str
        """
        x, display = (self.u, self.input_display) if which == "u" else (self.y, self.output_display)
        unit, scale, offset = display[i]
        values = x[:, i]
        return (values - offset) / scale, unit

    @property
    def nt(self):
        """Number of samples."""
        return self.t.size

    def head(self, n):
        """The record's first n samples (the held-out verdicts fit to a
        record's head).

        Parameters
        ----------
        n : int
            Samples kept.

        Returns
        -------
        FlightData
            The first n samples, the channels' names, units and display as
            they are.
        """
        return FlightData(self.t[:n], self.u[:n], self.y[:n], self.input_names,
                          self.output_names, self.source, self.input_units, self.output_units,
                          self.input_display, self.output_display)

    @classmethod
    def load(cls, path, time_col=1, input_cols=(), output_cols=(), skip_rows=0,
             input_names=None, output_names=None, columns=None, units=None, derived=None,
             t_start=None, t_end=None, variable=None, show=None, dt=None):
        """Read a flight record with the core's reader (the one mlid-batch
        uses): a text file, or a MATLAB .mat (v5, compressed or not; v7.3) or
        HDF5 file (one matrix a row per sample, or vectors a channel each,
        named by their variable; fortran/case/mlid_tablefile.f90).

        Text files: columns separated by blanks, tabs or commas; '#'
        comments; header lines (the last one with a name per column names
        them; 'ALCG[deg]' gives a unit); D exponents; a BOM; CR-LF.  Repeat
        counts, missing or extra columns, NaN/Inf, time that does not
        increase and jumps in time are errors naming the file and line.
        A channel declared in rad whose values go beyond 2 pi most likely
        holds degrees: an MlidWarning names it.

        Parameters
        ----------
        path : str or Path
        time_col, input_cols, output_cols : int or str
            Channels by column number (from 1) or name (a column's, or a
            derived channel's); names match exactly, else case-insensitively.
        skip_rows : int
            Lines skipped first (text files; the last one may name the columns).
        input_names, output_names : list of str, optional
            Names for the channels taken (default: their names in the file).
        columns : list of str, optional
            Names of the file's columns in order, each perhaps with a unit
            ('ALCG[deg]'); for files that name none, or to rename them.
        units : dict or list of str, optional
            Units of columns, {'ALCG': 'deg'} or ['ALCG = deg']; converted to
            the core's (SI, rad) on reading.
        derived : dict or list of str, optional
            Channels computed from others, in order: {'da': '(DAIL_R -
            DAIL_L)/2'} or ['da = (DAIL_R - DAIL_L)/2'] (mlid_expr's small
            language: + - * / ^, functions, no user code run).
        t_start, t_end : float, optional
            The time window taken, in the file's time.
        dt : float, optional
            A uniform time step replacing the record's time from the
            window's first sample (a recording gap is then integrated
            across, as the textbook software does); default the record's.
        variable : str, optional
            The matrix to take of a .mat or HDF5 file holding several.
        show : dict or list of str, optional
            Units channels are shown in (plots, tables, ``shown``) instead
            of the declared ones, {'ALFCG': 'deg'} or ['ALFCG = deg']; a
            column or a derived channel, whose unit must convert to the same
            core unit.  Display only: the values fitted do not change.

        Returns
        -------
        FlightData

        Raises
        ------
        InputError
            One line naming the file, line (or row) and problem.

        Warns
        -----
        MlidWarning
            A channel declared in rad goes beyond 2 pi (most likely degrees).
        """
        spec = _spec(time_col, input_cols, output_cols, columns, units, derived, show)
        window = _window(t_start, t_end, dt)
        path = str(path)
        handle = Handle()
        put(handle, path=path, variable=variable or "", skip_rows=int(skip_rows), **spec,
            **window)
        nt, status, msg = _api.mlid_channels_read(handle.value)
        read_status(status, msg)
        return cls._taken(handle, *_counts(spec), nt, path, input_names, output_names)

    @classmethod
    def from_frame(cls, frame, time_col, input_cols=(), output_cols=(), units=None,
                   derived=None, t_start=None, t_end=None, input_names=None,
                   output_names=None, source="DataFrame", show=None, dt=None):
        """A record from a pandas DataFrame (or anything with ``columns`` and
        ``to_numpy``): channels by column name, as in ``load``; a column
        named 'ALCG[deg]' carries its unit.

        Parameters
        ----------
        frame : pandas.DataFrame or xarray.Dataset
            The table, a column per channel, numbers only; or a Dataset of
            one-dimensional variables along its time coordinate, each
            variable's ``units`` attribute its unit.
        time_col, input_cols, output_cols : str or list of str
            Channels by column name (or a derived channel's), as in ``load``.
            Time may be the frame's index (``time_col`` its name, or
            ``"index"``), and may be seconds, ``datetime64`` or
            ``timedelta64`` (a ``DatetimeIndex``, a ``TimedeltaIndex``):
            dates and durations become seconds from the first sample.
        units, derived, t_start, t_end, input_names, output_names, show, dt
            As in ``load``.
        source : str
            What messages call the table.

        Returns
        -------
        FlightData

        Raises
        ------
        InputError
            A name not among the columns, a value not finite, a unit unknown.

        Warns
        -----
        MlidWarning
            A channel declared in rad goes beyond 2 pi (most likely degrees).

        Examples
        --------
        A column's unit in brackets: degrees become radians on reading, and
        ``shown`` gives them back in the unit declared.

        >>> import pandas as pd
        >>> import mlid
        >>> frame = pd.DataFrame({"t": [0.0, 0.1, 0.2], "de": [0.0, 0.5, 1.0],
        ...                       "ALCG[deg]": [1.0, 2.0, 3.0]})
        >>> data = mlid.FlightData.from_frame(frame, "t", ["de"], ["ALCG"])
        >>> data.output_units
        ['rad']
        >>> data.y[:, 0].round(5)
        array([0.01745, 0.03491, 0.05236])
        >>> data.shown("y", 0)
        (array([1., 2., 3.]), 'deg')
        """
        frame = _time_in_seconds(_dataset_frame(frame, time_col), time_col)
        try:
            names = [str(c) for c in frame.columns]
            x = np.asarray(frame.to_numpy(dtype=float), dtype=float)
        except (AttributeError, TypeError, ValueError) as exc:
            raise InputError(f"from_frame needs a DataFrame of numbers ({exc})") from None
        split = [n.split("[", 1) for n in names]
        col_units = [s[1].rstrip("]").strip() if len(s) == 2 and n.endswith("]") else ""
                     for s, n in zip(split, names)]
        names = [s[0].strip() if u else n for s, n, u in zip(split, names, col_units)]
        spec = _spec(time_col, input_cols, output_cols, None, units, derived, show)
        window = _window(t_start, t_end, dt)
        handle = Handle()
        put(handle, source=str(source), names="\n".join(names) + "\n",
            col_units="\n".join(col_units) + "\n", **spec, **window)
        nt, status, msg = _api.mlid_channels_table(handle.value, np.asfortranarray(x))
        read_status(status, msg)
        return cls._taken(handle, *_counts(spec), nt, source, input_names, output_names)

    @classmethod
    def _taken(cls, handle, nu, ny, nt, source, input_names=None, output_names=None):
        """The channels the core took last into handle (mlid_channels_get)."""
        t, u, y, _, status, msg = _api.mlid_channels_get(handle.value, nu, ny, nt)
        check_status(status, msg)
        labels = results(handle)
        names, units, shown = (_text_lines(labels[k], nu + ny) for k in ("names", "units", "shown"))
        scale, offset = labels["scale"], labels["offset"]
        names = [n or (f"u{i + 1}" if i < nu else f"y{i - nu + 1}") for i, n in enumerate(names)]
        display = list(zip(shown, scale, offset))
        return cls(t, u.T, y.T, input_names or names[:nu], output_names or names[nu:],
                   source=source, input_units=units[:nu], output_units=units[nu:],
                   input_display=display[:nu], output_display=display[nu:])

    def save(self, path):
        """Write t, u, y as columns with a '#' header (17 digits, exact), whole
        or not at all: to a temporary name beside path, renamed when complete.

        Parameters
        ----------
        path : str or Path
            The text file; ``load(path, 1, [2, ...], [...])`` reads it back.
        """
        names = ["t"] + self.input_names + self.output_names
        with atomic_open(path) as fh:
            np.savetxt(fh, np.column_stack([self.t, self.u, self.y]), fmt="%.16e",
                       header=" ".join(names))

    def __repr__(self):
        return (f"FlightData(nt={self.nt}, inputs={self.input_names}, "
                f"outputs={self.output_names})")
