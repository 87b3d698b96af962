"""A model's tables as a plain table set: JSON (each table's variables,
breakpoints, values and sigma as nested lists, and every scalar parameter)
or CSV (one row a table value), in the model's units."""

import csv
import io
import json
import math

import numpy as np

from ..errors import InputError
from ..files import atomic_write_text
from .source import Source


def tables(model_or_result, path, format=None):
    """Write a model's tables (and, in JSON, its other parameters).

    Parameters
    ----------
    model_or_result : EquationModel, SixDofModel or FitResult
        The model (its values) or a fit of it (the estimates and each free
        value's sigma; a value that is not free has none).
    path : str or Path
        The file, written whole or not at all.
    format : {'json', 'csv'}, optional
        Default: path's suffix.

    Returns
    -------
    str
        The text written.

    Raises
    ------
    InputError
        A model with no table for CSV, an unknown format, a file that
        cannot be written.

    Notes
    -----
    JSON: ``{"fitted": bool, "tables": [{"name", "variables",
    "breakpoints", "values", "sigma"}], "parameters": {name: {"value",
    "sigma"}}}``, values[i][j][k] at (breakpoints[0][i], breakpoints[1][j],
    ...); sigma that of a free or tied value (FitResult.covariance_of), null
    for a value held or one no sample reaches.  CSV: a header, then
    ``table, i, j, k, var1, x1, var2, x2, var3, x3, value, sigma`` a row,
    in the order of the parameters 'NAME[i,j,k]' (the first index fastest;
    1-based indices, empty where a table has fewer variables or a value
    no sigma).
    """
    fmt = (format or str(path).rsplit(".", 1)[-1]).lower()
    if fmt not in ("json", "csv"):
        raise InputError(f"table set: format {fmt!r} is not json or csv")
    src = Source(model_or_result)
    text = _json(src) if fmt == "json" else _csv(src)
    atomic_write_text(path, text)
    return text


def _sigma(s):
    return None if not math.isfinite(s) else float(s)


def _json(src):
    out = {"fitted": src.fitted, "tables": [], "parameters": {}}
    for t in src.tables:
        out["tables"].append({
            "name": t.name, "variables": list(t.variables),
            "breakpoints": [b.tolist() for b in t.breakpoints], "values": t.values.tolist(),
            "sigma": np.vectorize(_sigma, otypes=[object])(t.sigma).tolist()})
    for n in src.params:
        s = src.sigma.get(n)
        out["parameters"][n] = {"value": src.value(n), "sigma": None if s is None else _sigma(s)}
    return json.dumps(out, indent=1) + "\n"


def _csv(src):
    if not src.tables:
        raise InputError("table set: the model has no table (CSV holds tables only)")
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["table", "i", "j", "k", "var1", "x1", "var2", "x2", "var3", "x3", "value",
                "sigma"])
    for t in src.tables:
        for rev in np.ndindex(*t.values.shape[::-1]):     # the first index fastest, as p
            idx = rev[::-1]
            ijk = [i + 1 for i in idx] + [""] * (3 - len(idx))
            at = []
            for k in range(3):
                at += ([t.variables[k], repr(float(t.breakpoints[k][idx[k]]))]
                       if k < len(idx) else ["", ""])
            s = t.sigma[idx]
            w.writerow([t.name, *ijk, *at, repr(float(t.values[idx])),
                        repr(float(s)) if np.isfinite(s) else ""])
    return buf.getvalue()
