"""A second implementation of the core's reader of binary records
(fortran/case/mlid_tablefile.f90), for the tests to hold it against: MATLAB
.mat (v5 through scipy.io, v7.3 through h5py) and HDF5 (.h5, .hdf5), each as
a raw table, x (nrow, ncol) with the columns' names and units where the file
has them.  (It was the Python front end's reader before the core had one.)

What a file may hold:
- one 2-D numeric matrix, a row per sample (a MATLAB matrix as MATLAB shows
  it; v7.3 files store it transposed, which is undone here); its columns
  are named by ``columns=`` or a deck's ``columns``, or by an HDF5
  attribute ``columns`` (names, 'ALCG[deg]' with a unit);
- or 1-D vectors of one length, a channel each, named by their variable
  (HDF5: dataset) names; an HDF5 dataset's ``units`` attribute is its unit.
With several matrices, ``variable=`` names the one to take.
"""

from pathlib import Path

import numpy as np

from mlid.errors import InputError

SUFFIXES = (".mat", ".h5", ".hdf5")


def is_binary(path):
    """Whether path is a file this module reads (by its suffix)."""
    return Path(str(path)).suffix.lower() in SUFFIXES


def read_table(path, variable=None):
    """x (nrow, ncol) float64, names (ncol,), units (ncol,) of a .mat or
    HDF5 record ('' where the file names none).

    Raises
    ------
    InputError
        The file is missing, unreadable, or holds no table of numbers (or
        several, and ``variable`` does not pick one).
    """
    path = Path(str(path))
    if not path.is_file():
        raise InputError(f"data file {path}: no such file")
    if _is_hdf5(path):
        return _hdf5_table(path, variable)
    if path.suffix.lower() != ".mat":
        raise InputError(f"data file {path}: not an HDF5 file")
    import scipy.io
    try:
        content = scipy.io.loadmat(str(path))
    except NotImplementedError:          # v7.3 not recognised by its header
        return _hdf5_table(path, variable)
    except Exception as exc:
        raise InputError(f"data file {path}: not a MATLAB file scipy can read ({exc})") from None
    arrays = {k: v for k, v in content.items() if not k.startswith("__")}
    return _table(path, arrays, {}, variable, transpose=False)


def _is_hdf5(path):
    with open(path, "rb") as fh:
        head = fh.read(8)
        fh.seek(512)
        mat73 = fh.read(8)
    return head == b"\x89HDF\r\n\x1a\n" or mat73 == b"\x89HDF\r\n\x1a\n"


def _hdf5_table(path, variable):
    try:
        import h5py
    except ImportError:
        raise InputError(f"data file {path}: reading HDF5 needs h5py (pip install h5py)") \
            from None
    arrays, attrs = {}, {}
    try:
        with h5py.File(path, "r") as f:
            def visit(name, obj):
                if isinstance(obj, h5py.Dataset) and not name.startswith("#"):
                    arrays[name] = obj[()]
                    attrs[name] = {k: obj.attrs[k] for k in ("units", "unit", "columns")
                                   if k in obj.attrs}
            f.visititems(visit)
    except OSError as exc:
        raise InputError(f"data file {path}: cannot be read as HDF5 ({exc})") from None
    return _table(path, arrays, attrs, variable, transpose=path.suffix.lower() == ".mat")


def _table(path, arrays, attrs, variable, transpose):
    """The matrix, or the vectors side by side, of what a file holds."""
    numeric = {k: np.asarray(v) for k, v in arrays.items()
               if isinstance(v, np.ndarray) and v.dtype.kind in "fiu" and v.size > 0}
    if variable is not None:
        if variable not in numeric:
            raise InputError(f"data file {path}: no numeric variable {variable!r} (it has: "
                             f"{', '.join(sorted(numeric)) or 'none'})")
        numeric = {variable: numeric[variable]}
    matrices = {k: v for k, v in numeric.items() if v.ndim == 2 and min(v.shape) > 1}
    if len(matrices) == 1:
        name, x = next(iter(matrices.items()))
        x = x.T if transpose else x
        names, units = _column_names(attrs.get(name, {}), x.shape[1], path)
        return np.ascontiguousarray(x, dtype=float), names, units
    if len(matrices) > 1:
        raise InputError(f"data file {path}: several matrices ({', '.join(sorted(matrices))}); "
                         f"name one with variable=")
    vectors = {k: v.ravel() for k, v in numeric.items() if v.ndim <= 2 and v.size > 1}
    lengths = {v.size for v in vectors.values()}
    if not vectors or len(lengths) != 1:
        raise InputError(f"data file {path}: no matrix and no channel vectors of one length")
    names = list(vectors)
    units = [_text(attrs.get(k, {}).get("units", attrs.get(k, {}).get("unit", ""))) for k in names]
    return np.column_stack([vectors[k] for k in names]).astype(float), names, units


def _column_names(attrs, ncol, path):
    if "columns" not in attrs:
        return [""] * ncol, [""] * ncol
    cols = [_text(c) for c in np.ravel(attrs["columns"])]
    if len(cols) != ncol:
        raise InputError(f"data file {path}: {len(cols)} column names for {ncol} columns")
    names = [c.split("[")[0].strip() for c in cols]
    units = [c.split("[", 1)[1].rstrip("]").strip() if "[" in c else "" for c in cols]
    return names, units


def _text(v):
    return v.decode() if isinstance(v, bytes) else str(v)
