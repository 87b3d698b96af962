"""Validation: how well an identified model predicts manoeuvres it was not
fitted to.  Each held-out manoeuvre gets its own initial state and output
biases (those the identification fitted, fitted afresh there by output
error); every other parameter is held at its estimate and the model has no
noise, as a prediction has none.  Ties are not carried into the prediction:
an initial state or bias tied to another is held at its fitted value, and
the free ones are fitted on their own.  Per output: Theil's inequality
coefficient, the rms prediction error and its ratio to the identification's
residual sigma (the core's mlid_validate; mlid-batch's validate job does the
same through fortran/case/mlid_deck.f90's holdout_case)."""

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..data.flight_data import FlightData
from ..design.simulate import simulate
from ..errors import InputError, check_status, guarded
from ..estimate.fit import fit
from ..estimate.named import NamedArray
from ..estimate.result import FitResult
from ..estimate.views import TableView
from ..model.calls import _manoeuvres
from ..model.maneuvers import join
from . import plots

#: The blocks of theta each manoeuvre has of its own (fitted on held-out data).
OWN_BLOCKS = ("x0", "bias")
#: The options of the prediction: output error, no start-up pass, full rank.
PREDICTION_OPTIONS = {"method": "output_error", "startup": "none", "rank_min": 0, "rank_max": 0}


class Validation(TableView):
    """A validation: ``theil``, ``rms`` (core units) and ``rms_over_sigma``
    (one per output, NamedArrays by output name), ``holdout`` (the numbers of the held-out manoeuvres,
    as the deck counts its files; 1, 2, ... for ``mlid.validate``),
    ``prediction`` (a FitResult-like object whose ``data`` are the held-out
    records joined and ``yhat`` the model's prediction, for the plots),
    ``identification`` (the FitResult validated), ``output_names`` and
    ``output_display`` (per output the unit it is shown in, and the scale
    and offset: core = scale*shown + offset).  ``to_frame()``: a row per
    output; ``report()`` the printed lines, rms errors in the shown unit.

    Parameters
    ----------
    **fields
        The attributes above, by name (``validate`` sets them).
    """

    output_display = None

    def __init__(self, **fields):
        self.__dict__.update(fields)
        if self.output_display is None:
            self.output_display = [("", 1.0, 0.0)] * len(self.output_names)
        for name in ("theil", "rms", "rms_over_sigma"):     # by output name too
            self.__dict__[name] = NamedArray(np.asarray(fields[name], dtype=float),
                                             self.output_names)

    @property
    def rms_shown(self):
        """The rms errors in the unit each output is shown in (an error is a
        difference: the scale only, no offset)."""
        return np.asarray(self.rms) / np.array([s for _, s, _ in self.output_display])

    @property
    def shown_units(self):
        """The unit each output is shown in ('' none declared)."""
        return [u for u, _, _ in self.output_display]

    def _texts(self):
        h = _call_handle()
        _put(h, names="\n".join(self.output_names) + "\n",
             units="\n".join(self.shown_units) + "\n",
             scale=np.array([s for _, s, _ in self.output_display], dtype=float),
             holdout=np.asarray(self.holdout, dtype=np.int32), theil=self.theil, rms=self.rms,
             ratio=self.rms_over_sigma)
        out = _run(h, _api.mlid_report_validation)
        return out["report"].decode(errors="replace"), out["json"].decode(errors="replace")

    def _table(self):
        return "output", list(self.output_names), {
            "theil": list(self.theil), "rms": list(self.rms_shown), "unit": self.shown_units,
            "rms_over_sigma": list(self.rms_over_sigma)}

    def _heading(self):
        files = ", ".join(map(str, self.holdout))
        return (f"prediction of held-out manoeuvre{'s' if len(self.holdout) > 1 else ''} "
                f"{files}: Theil U, rms error in the unit shown, rms over the "
                "identification's residual sigma")

    def report(self):
        """The printed lines (the same as mlid-batch prints).

        Returns
        -------
        str
        """
        return self._texts()[0].rstrip("\n")

    def json_member(self):
        """The ``"validation": {...}`` member of the case's JSON object.

        Returns
        -------
        str
            The core's JSON text.
        """
        return self._texts()[1]

    def as_dict(self):
        """Plain types for JSON.

        Returns
        -------
        dict
            ``holdout``, ``outputs``, and per output ``theil``, ``rms`` and
            ``rms_over_sigma``.
        """
        return {"holdout": list(map(int, self.holdout)), "outputs": list(self.output_names),
                "theil": self.theil.tolist(), "rms": self.rms.tolist(),
                "rms_over_sigma": self.rms_over_sigma.tolist()}

    def plot(self, path=None):
        """Measured and predicted held-out outputs (``mlid.report.plots.validation``).

        Parameters
        ----------
        path : str or Path, optional
            Also write the figure there.

        Returns
        -------
        matplotlib.figure.Figure
        """
        return plots.validation(self, path)


def _prediction_model(result):
    """The identified model with only its own blocks free (those the
    identification fitted), no ties and no noise."""
    start = result.start_model
    free = [n for n in start.free if n.split("(")[0] in OWN_BLOCKS]
    model = result.model.with_free(free)
    model.ties = {}
    for block in ("q", "r", "S"):
        setattr(model, block, np.zeros_like(getattr(model, block)))
    return model


def _predict(model, records, x0=(None, None)):
    """Outputs of a model with nothing free on each record, without noise
    (x0 = (x0_from, x0_samples): each from its own measured states' x0)."""
    parts = []
    for r in records:
        m = model
        if x0 != (None, None):
            m = model.with_theta(_manoeuvres(model, r, None, None, *x0)[0].theta)
        parts.append(simulate(m, r.t, r.u)[0].y)
    return np.vstack(parts)


@guarded
def validate(result, data, holdout=None, x0_from=None, x0_samples=None):
    """Predict held-out manoeuvres with an identified model.

    Parameters
    ----------
    result : FitResult
        The identification (``mlid.fit`` on other manoeuvres).
    data : FlightData or list of FlightData
        The held-out manoeuvre(s), with the channels of the identification.
    holdout : list of int, optional
        How the report numbers the held-out manoeuvres (a deck's file
        numbers); default 1, 2, ...
    x0_from, x0_samples : optional
        As for ``fit``: each held-out manoeuvre's measured states start at
        its own first samples (as a deck's validate case with x0_from).

    Returns
    -------
    Validation
        Theil's U, rms error and rms/sigma per output, the prediction.

    Raises
    ------
    InputError
        If result is not a FitResult, or data does not match its channels.
    MlidError
        If the fit of the held-out initial states and biases fails.
    """
    if not isinstance(result, FitResult):
        raise InputError(f"validate needs a FitResult, got {type(result).__name__}")
    records = list(data) if isinstance(data, (list, tuple)) else [data]
    if not records or not all(isinstance(r, FlightData) for r in records):
        raise InputError("validate needs a FlightData or a list of them")
    if holdout is None:
        holdout = list(range(1, len(records) + 1))
    if len(holdout) != len(records):
        raise InputError(f"holdout numbers {len(holdout)} manoeuvres, data has {len(records)}")
    model = _prediction_model(result)
    joined = join(records)[0] if len(records) > 1 else records[0]
    if model.free:
        opts = {**result.options, **PREDICTION_OPTIONS}
        prediction = fit(model, records if len(records) > 1 else records[0], x0_from=x0_from,
                         x0_samples=x0_samples, **opts)
        check_status(prediction.status, prediction.message)    # not converged: no prediction
        yhat = prediction.yhat
    else:
        yhat = _predict(model, records, (x0_from, x0_samples))
        prediction = FitResult(data=joined, yhat=yhat, model=model,
                               evaluate_args=(records if len(records) > 1 else records[0],
                                              None, None))
    theil, rms, ratio = _api.mlid_prediction_stats(y=np.asfortranarray(joined.y.T),
                                                   yhat=np.asfortranarray(yhat.T),
                                                   rhat=result.rhat)
    return _validation(result, joined, holdout, theil, rms, ratio, prediction)


def validation_of(result, records, holdout, theil, rms, ratio, yhat):
    """The Validation of a prediction the core made (a deck's validate case,
    fortran/case/mlid_run.f90): its statistics and predicted outputs yhat
    (nt, ny) on the held-out records."""
    joined = join(records)[0] if len(records) > 1 else records[0]
    prediction = FitResult(data=joined, yhat=yhat, model=_prediction_model(result),
                           evaluate_args=(records if len(records) > 1 else records[0],
                                          None, None))
    return _validation(result, joined, holdout, theil, rms, ratio, prediction)


def _validation(result, joined, holdout, theil, rms, ratio, prediction):
    ny = joined.y.shape[1]
    return Validation(theil=theil, rms=rms, rms_over_sigma=ratio, holdout=list(holdout),
                      prediction=prediction, identification=result,
                      output_names=list(joined.output_names[:ny]),
                      output_display=list(joined.output_display[:ny]))
