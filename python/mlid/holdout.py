"""Held-out verdicts for the discrepancy workflow (issue 16): does an effect
found on a record still hold on data its fit did not see?

The record's last part (HOLDOUT, a third) is held out.  A model is fitted to
the rest and predicts the held-out samples; its score is its own negative
log-likelihood of them:

- output error: the simulation over the whole record from the fitted
  parameters, its residuals on the held-out samples weighted by the R the
  fit estimated (not one re-estimated from them);
- filter error: the one-step predictions and their covariance, i.e. the
  filter's cost over the whole record less its cost over the fitted part
  (the filter is causal, so the difference is the held-out samples' share).

A simulation and a filter are thus compared by what each claims about the
data, the likelihood, the one measure they share.  The filter sees the
held-out measurements one step back, the simulation never does: held-out
likelihood alone favours any filter, so deterministic effects are weighed
among themselves first (mlid.diagnose decides with ``holds_clearly``).
"""

import numpy as np

from . import core

#: the share of the record held out: its last third
HOLDOUT = 1 / 3
#: fewest samples either part may have
MIN_SAMPLES = 30


def split(data, share=HOLDOUT):
    """The number of samples fitted (the record's head); the rest is held
    out.  None when either part would be shorter than MIN_SAMPLES."""
    n = int(round(data.nt * (1 - share)))
    if n < MIN_SAMPLES or data.nt - n < MIN_SAMPLES:
        return None
    return n


def _filter_error(options):
    return options.get("method") == "filter_error"


def _evaluate_options(options):
    return {k: v for k, v in options.items() if k not in ("prior", "prior_weight", "bounds")}


def heldout_cost(model, data, n, options):
    """Fit model (from its current parameters) to the first n samples and
    score its prediction of the rest.

    Returns
    -------
    (float, FitResult, ndarray)
        The negative log-likelihood of the held-out samples, the fit to the
        head, and its outputs (simulated or predicted) over the whole record.

    Raises
    ------
    MlidError
        What the fit or the prediction raises.
    """
    head = data.head(n)
    res = core.fit(model, head, **options)
    m, ev_opts = res.model, _evaluate_options(options)
    if _filter_error(options):
        whole = core.evaluate(m, data, **ev_opts)
        part = core.evaluate(m, head, **ev_opts)["cost"]
        return float(whole["cost"] - part), res, whole["yhat"]
    yhat = core.evaluate(m, data, **ev_opts)["yhat"]
    e = data.y[n:] - yhat[n:]
    rinv = np.linalg.inv(res.rhat)
    _, logdet = np.linalg.slogdet(res.rhat)
    return float(0.5 * (np.einsum("ki,ij,kj->", e, rinv, e) + len(e) * logdet)), res, yhat
