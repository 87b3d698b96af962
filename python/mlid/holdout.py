"""Held-out verdicts for the discrepancy workflow (issue 16): does an effect
found on a record still hold on data its fit did not see?

The held-out part is the last manoeuvre of several, else the last third
(HOLDOUT) of the one record.  A model is fitted to the rest and predicts
the held-out samples; its score is its own negative log-likelihood of them:

- output error: the simulation from the fitted parameters, its residuals on
  the held-out samples weighted by the R the fit estimated (not one
  re-estimated from them);
- filter error: the one-step predictions and their covariance, i.e. the
  filter's cost over the whole data less its cost over the fitted part (the
  filter is causal and restarts with each manoeuvre, so the difference is
  the held-out samples' share).

A simulation and a filter are thus compared by what each claims about the
data, the likelihood, the one measure they share.  The filter sees the
held-out measurements one step back, the simulation never does: held-out
likelihood alone favours any filter, so mlid.diagnose weighs deterministic
effects against turbulence by the share of the held-out residual each
explains as well.
"""

import numpy as np

from . import core

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


def _evaluate_options(options):
    return {k: v for k, v in options.items() if k not in ("prior", "prior_weight", "bounds")}


def heldout_cost(model, data, split, options):
    """Fit model (from its current parameters) to the split's head and score
    its prediction of the held-out samples.

    Returns
    -------
    (float, FitResult, ndarray)
        The negative log-likelihood of the held-out samples, the fit to the
        head, and its outputs (simulated or predicted) over the whole data,
        the records joined.

    Raises
    ------
    MlidError
        What the fit or the prediction raises.
    """
    head = split.head(data)
    res = core.fit(model, head, **options)
    m, ev_opts = res.model, _evaluate_options(options)
    whole = core.evaluate(m, data, **ev_opts)
    if options.get("method") == "filter_error":
        part = core.evaluate(m, head, **ev_opts)["cost"]
        return float(whole["cost"] - part), res, whole["yhat"]
    y = np.vstack([r.y for r in records(data)])
    e = split.held(y - whole["yhat"])
    rinv = np.linalg.inv(res.rhat)
    _, logdet = np.linalg.slogdet(res.rhat)
    return float(0.5 * (np.einsum("ki,ij,kj->", e, rinv, e) + len(e) * logdet)), res, \
        whole["yhat"]
