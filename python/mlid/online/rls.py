"""Recursive least squares of a linear regression, sample by sample (the
core's mlid_rls), and the estimate history it gives."""

import numpy as np

from .._bridge import api as _api
from ..checks import real_array
from ..errors import InputError, check_status, guarded


class OnlineEstimate:
    """The history of a recursive estimator.

    Attributes
    ----------
    t : ndarray (n,)
        The sample times.
    names : list of str
        The parameters.
    estimates, sigma : ndarray (n, np)
        The estimate and its sigma at each point of the history (each
        sample, or each solve); NaN where there is none yet (rls: sigma 0
        until there are more samples, weighted, than parameters).
    states, states_sigma : ndarray (n, nx) or None
        A filter's state estimates and their sigma after each sample (None
        for a regression).
    noise : ndarray (n, ny) or None
        An adaptive filter's measurement-noise variances after each sample
        (None when they were given).
    """

    def __init__(self, t, names, estimates, sigma, states=None, states_sigma=None, noise=None):
        self.t, self.names = t, list(names)
        self.estimates, self.sigma = estimates, sigma
        self.states, self.states_sigma, self.noise = states, states_sigma, noise

    @property
    def final(self):
        """The last estimate, by name."""
        return dict(zip(self.names, self.estimates[-1].tolist()))

    def convergence_time(self, width=2.0):
        """For each parameter, the first time after which its estimate stays
        within width times its final sigma of its final value (NaN when the
        final sigma is 0; the core's rule, the one the deck's report uses)."""
        tc = _api.mlid_convergence_times(np.asfortranarray(self.t, dtype=float),
                                         np.asfortranarray(self.estimates.T),
                                         np.asfortranarray(self.sigma.T), float(width))
        return dict(zip(self.names, tc.tolist()))

    def to_frame(self):
        """The history as a pandas DataFrame indexed by t: each parameter's
        estimate, then its sigma ('sigma_<name>')."""
        import pandas as pd
        data = {n: self.estimates[:, j] for j, n in enumerate(self.names)}
        data.update({f"sigma_{n}": self.sigma[:, j] for j, n in enumerate(self.names)})
        return pd.DataFrame(data, index=pd.Index(self.t, name="t"))

    def __repr__(self):
        rows = "\n".join(f"  {n:12s} {v: .6g}  sigma {s:.3g}"
                         for n, v, s in zip(self.names, self.estimates[-1], self.sigma[-1]))
        return f"OnlineEstimate: {len(self.t)} points of history, final\n{rows}"


@guarded
def rls(X, y, names=None, t=None, forgetting=1.0, p0=1e6, theta0=None, p_max=0.0):
    """Recursive least squares of y on the columns of X, sample by sample
    (fortran/estimation/online/mlid_rls.f90):

        K = P x / (lambda + x' P x),  theta += K (y - x' theta),
        P = (P - K x' P) / lambda

    Parameters
    ----------
    X : array_like (n, np) or pandas.DataFrame
        The regressors, a row per sample (a DataFrame's columns name the
        parameters).
    y : array_like (n,)
        The measurements.
    names : list of str, optional
        The parameters' names (default: the DataFrame's columns, else
        theta1, theta2, ...).
    t : array_like (n,), optional
        The sample times (default: 0, 1, ...).
    forgetting : float
        lambda in (0, 1]; 1: none.
    p0 : float
        The start covariance P0 = p0 I (large: a vague start).
    theta0 : array_like (np,), optional
        The start (default: 0).
    p_max : float
        With forgetting, a bound on trace(P)/np (0: none): where dividing
        by lambda would pass it, P is not divided, so P does not wind up
        when the excitation stops.

    Returns
    -------
    OnlineEstimate
        Estimates and sigma per sample.  sigma is sqrt(s2 diag P), s2 the
        weighted variance of the residuals so far: under forgetting it is
        the sigma of the weighted (recent) data, not of the record.

    Examples
    --------
    >>> import numpy as np, mlid
    >>> rng = np.random.default_rng(1)
    >>> X = np.column_stack([np.ones(500), rng.standard_normal(500)])
    >>> y = X @ [0.5, -2.0] + 0.01 * rng.standard_normal(500)
    >>> est = mlid.online.rls(X, y, names=["a", "b"])
    >>> {k: round(v, 2) for k, v in est.final.items()}
    {'a': 0.5, 'b': -2.0}
    """
    if names is None:
        names = list(X.columns) if hasattr(X, "columns") else None
    X = real_array("X", np.asarray(X, dtype=float))
    y = real_array("y", y)
    if X.ndim != 2 or y.ndim != 1 or X.shape[0] != y.shape[0]:
        raise InputError(f"X must be (n, np) and y (n,) of one length n (shapes {X.shape} and "
                         f"{y.shape})")
    npar = X.shape[1]
    names = [f"theta{j + 1}" for j in range(npar)] if names is None else list(names)
    if len(names) != npar:
        raise InputError(f"{len(names)} names for {npar} regressors")
    t = np.arange(X.shape[0], dtype=float) if t is None else real_array("t", t)
    if t.shape != y.shape:
        raise InputError(f"t must have one time per sample ({y.size}), got shape {t.shape}")
    theta0 = np.zeros(npar) if theta0 is None else real_array("theta0", theta0)
    if theta0.shape != (npar,):
        raise InputError(f"theta0 must hold one start value per regressor ({npar}), got shape "
                         f"{theta0.shape}")
    theta, sigma, status, msg = _api.mlid_rls(np.asfortranarray(X.T), y, theta0,
                                              float(forgetting), float(p0), float(p_max))
    check_status(status, msg)
    return OnlineEstimate(t, names, theta.T.copy(), sigma.T.copy())
