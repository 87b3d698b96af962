"""Held-out verdicts for the discrepancy workflow (issue 16): does an effect
found on a record still hold on data its fit did not see?

The held-out part is the last manoeuvre of several, else the last third
(HOLDOUT) of the one record.  A model is fitted to the rest and predicts
the held-out samples: output error by its simulation from the fitted
parameters, filter error by its one-step predictions.  Its score is the
prediction-error criterion of the held-out samples, the output-error cost
with R concentrated out:

    J = N/2 sum_i log s_i^2,   s_i^2 the mean square held-out error of output i,

so two models compare by the log ratio of their held-out error variances,
output by output.  The models' own R are not used: an R fitted to the held-
in part rewards a model that is wrong in a large noise and punishes a right
one whose small errors grow over a long held-out stretch (measured on the
scenarios: a missing Y_p that closes 2dJ = 2222 would fail).

A simulation and a filter are compared by their errors on the same unseen
samples.  The filter sees the held-out measurements one step back, the
simulation never does, so any filter predicts better: mlid.diagnose weighs
deterministic effects against turbulence by the residual each leaves.
"""

import numpy as np

from ..estimate.evaluate import evaluate
from ..estimate.fit import fit
from ..estimate.options import evaluate_options

#: the share of a single record held out: its last third
HOLDOUT = 1 / 3
#: fewest samples either part of a single record may have
MIN_SAMPLES = 30


def records(data):
    """A record or a list of records, as a list."""
    return list(data) if isinstance(data, (list, tuple)) else [data]


class Split:
    """Which part of the data is fitted (the first ``n`` records of several,
    or samples of one) and which held out (the last ``rows`` samples of the
    records joined); ``what`` names the held-out part.  ``Split.of`` makes
    one; it applies to any data of the same layout (a candidate's record
    with an input added or shifted)."""

    def __init__(self, n, rows, what, several):
        self.n, self.rows, self.what, self.several = n, rows, what, several

    def head(self, data):
        """The fitted part of data."""
        return records(data)[:self.n] if self.several else records(data)[0].head(self.n)

    @classmethod
    def of(cls, data, share=HOLDOUT):
        """The split of data: its last manoeuvre when it has several, else
        the last share of the record; None when a part would be shorter
        than MIN_SAMPLES."""
        recs = records(data)
        if len(recs) > 1:
            return cls(len(recs) - 1, recs[-1].nt, "the last manoeuvre", True)
        rec = recs[0]
        n = int(round(rec.nt * (1 - share)))
        if n < MIN_SAMPLES or rec.nt - n < MIN_SAMPLES:
            return None
        return cls(n, rec.nt - n, f"the last {share:.0%} of the record"
                   if share != 1 / 3 else "the last third of the record", False)

    def held(self, array):
        """The held-out rows of an array over the records joined."""
        return array[-self.rows:]


def heldout_cost(model, data, split, options):
    """Fit model (from its current parameters) to the split's head and score
    its prediction of the held-out samples (the module's J).

    Returns
    -------
    (float, FitResult, ndarray)
        J of the held-out samples, the fit to the head, and its outputs
        (simulated or predicted) over the whole data, the records joined.

    Raises
    ------
    MlidError
        What the fit or the prediction raises.
    """
    res = fit(model, split.head(data), **options)
    yhat = evaluate(res.model, data, **evaluate_options(options))["yhat"]
    y = np.vstack([r.y for r in records(data)])
    return criterion(split.held(y - yhat)), res, yhat


def criterion(errors):
    """N/2 sum_i log s_i^2 of prediction errors (N, ny)."""
    return float(0.5 * len(errors) * np.sum(np.log(np.mean(errors**2, axis=0))))
