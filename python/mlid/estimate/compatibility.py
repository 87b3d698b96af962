"""Data compatibility after a flight-path reconstruction: which sensor
corrections a fit finds significant, and the record with them applied, for
the next step (the aerodynamic model).

A correction is significant when it stands ``threshold`` (3) sigmas from its
neutral value (1 for a scale factor ``f_*``, else 0), the sigma corrected
for coloured residuals: a reconstruction's residuals drift, and its
Cramer-Rao sigma is optimistic several times over.

The corrected record undoes each estimated correction of the model
(mlid.FlightPathModel, or a deck of kind 'flight_path'): accelerometers and
gyros a = (a_m - b)/f; air data V = (V_m - b_V)/f_V, alpha and beta alike;
each output's bias(i) (per manoeuvre) removed and its delay(i) taken back
(y(t) = y_m(t + tau), interpolated within the manoeuvre), each input's
udelay(j) likewise (u(t) = u_m(t - tau)).  The rule is the
core's (fortran/models/mlid_flightpath.f90, flightpath_corrected), which a deck's
``&estimate corrected`` also uses, in both front ends.
"""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..data.flight_data import FlightData
from ..errors import InputError
from ..model.calls import _set_model, _set_record



def neutral(name):
    """A correction's neutral value: 1 for a scale factor (f_*), else 0."""
    return 1.0 if name.split("#")[0].startswith("f_") else 0.0


def significance(result, threshold=3.0):
    """Each free parameter other than the initial states, its distance from
    its neutral value (by the parameter's own name, whatever its label) in
    Cramer-Rao and in corrected sigmas, and whether it is significant.

    Parameters
    ----------
    result : FitResult
    threshold : float
        Corrected sigmas a significant correction stands out by.

    Returns
    -------
    dict
        ``rows`` (name, estimate, neutral, in CR sigmas, in corrected
        sigmas, significant) and ``lines`` (the printed table).
    """
    rows = []
    for name, own, v, s, sc in zip(result.names, _own_names(result.model, result.names),
                                   result.estimate, result.sigma, result.sigma_corrected):
        if own.startswith("x0"):
            continue
        d = abs(v - neutral(own))
        rows.append((name, float(v), neutral(own), d / s, d / sc, bool(d > threshold * sc)))
    lines = [f"{'correction':<12}{'estimate':>14}{'neutral':>9}{'/sigma':>9}{'/sigma col.':>13}"
             f"  significant (>{threshold:g} corrected sigma)"]
    lines += [f"{n:<12}{v:14.6e}{z:9.0f}{a:9.1f}{b:13.1f}  {'yes' if y else 'no'}"
              for n, v, z, a, b, y in rows]
    return {"rows": rows, "lines": lines}


def corrected_record(result):
    """The fitted record with the estimated corrections undone.

    Parameters
    ----------
    result : FitResult
        A fit of a flight-path model (its inputs FLIGHTPATH_INPUTS).

    Returns
    -------
    FlightData or list of FlightData
        As the record was given: one, or one per manoeuvre; ``save`` writes
        each whole or not at all.

    Raises
    ------
    InputError
        If the fit is not of a flight-path model (its inputs
        FLIGHTPATH_INPUTS in that order, its parameters and outputs the
        kind's).
    """
    data = result.evaluate_args[0]
    records = list(data) if isinstance(data, (list, tuple)) else [data]
    out = [_corrected(model, rec) for model, rec in zip(result.manoeuvres, records)]
    return out if isinstance(data, (list, tuple)) else out[0]


def write_corrected(result, paths, written=None):
    """Write each manoeuvre's corrected record to its path, whole or not at
    all, as mlid-batch writes it (the core's text: a '# t[s] name[unit] ...'
    header, 17 digits).  ``written``, a list if given, receives each path
    as it is written (a later one may fail)."""
    data = result.evaluate_args[0]
    records = list(data) if isinstance(data, (list, tuple)) else [data]
    written = [] if written is None else written
    for model, rec, path in zip(result.manoeuvres, records, paths):
        _corrected(model, rec, str(path))
        written.append(str(path))
    return written


def _corrected(model, rec, path=""):
    if not hasattr(model, "iconst") or not hasattr(model, "text"):
        raise InputError("corrected_record: the fit is not of a flight-path model "
                         "(mlid.FlightPathModel, or a deck of kind 'flight_path')")
    names = "".join(f"{n}\n" for n in rec.input_names + rec.output_names)
    units = "".join(f"{u or ''}\n" for u in list(rec.input_units) + list(rec.output_units))
    h = _call_handle()
    _set_model(h, model)
    _set_record(h, (np.ascontiguousarray(rec.t, dtype=float),
                    np.ascontiguousarray(rec.u, dtype=float).T,
                    np.ascontiguousarray(rec.y, dtype=float).T), np.array([1], dtype=np.int32))
    _put(h, p=np.asarray(model.p, dtype=float), bias=np.asarray(model.bias, dtype=float),
         delay=np.asarray(model.delay, dtype=float), udelay=np.asarray(model.udelay, dtype=float),
         names=names, units=units, path=path)
    out = _run(h, _api.mlid_flightpath_corrected)
    return FlightData(rec.t, out["uc"].T, out["yc"].T, input_names=rec.input_names,
                      output_names=rec.output_names, input_units=rec.input_units,
                      output_units=rec.output_units)


def _own_names(model, labels):
    """Each label's parameter by its own name (the label given by names=
    taken back): a renamed scale factor is still a scale factor."""
    element = {v: k for k, v in model.names.items()}
    own = dict(zip(model.element_names(), model.element_labels()))
    bases = [label.split("#")[0] for label in labels]
    return [own.get(element.get(b, b), b) for b in bases]
