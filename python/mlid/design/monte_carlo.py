"""Seeded Monte Carlo of fits in the core: simulate from the truth, fit from
the start, repeat.  Run k's noise is seed k's, so the runs may be split over
calls (mlid.monte_carlo_parallel) without changing the results."""

import warnings

import numpy as np

from .._bridge import api as _api, call_handle as _call_handle, put as _put, run as _run
from ..checks import real_array, whole
from ..errors import ConvergenceWarning, InputError, guarded, status_text
from ..estimate.options import _flat_options
from ..model.calls import _check_model, _set_simulation, _time_and_inputs
from ..progress import Silent, bar as progress_bar
from .monte_carlo_result import MonteCarloResult


def _mc_setup(truth, start, t, u, noise_std, runs, seed, options):
    """Checked arguments of Monte Carlo runs: what a call of the core takes but
    the seed and run count (plain values, to go to a thread or a process), and
    the names and true values of the free parameters."""
    _check_model(truth, "truth")
    _check_model(start, "start")
    runs = whole("runs", runs, 1, 10**7)
    seed = whole("seed", seed, 0, 2**31 - runs)     # seeds seed .. seed + runs - 1
    if truth.theta.size != start.theta.size or list(truth.free) != list(start.free):
        raise InputError("truth and start models must have the same structure and free set")
    if noise_std is not None:
        truth = truth.with_theta(truth.theta)
        truth.r = real_array("noise_std", noise_std).ravel() ** 2
    iopt, ropt, _ = _flat_options(start, options)
    t, u = _time_and_inputs(start, t, u)
    call = dict(start=start, tu=(t, u.T), iopt=iopt, ropt=ropt, theta_true=truth.theta)
    return call, runs, seed, start.free_names(), truth.theta[start.free_indices()]


def _mc_runs(call, seed, runs):
    """Runs seed .. seed + runs - 1 (run k's noise is seed k's whichever
    call makes it: the results do not depend on how runs are split)."""
    h = _call_handle()
    _set_simulation(h, call["start"], call["tu"], call["iopt"], call["ropt"])
    _put(h, theta_true=call["theta_true"], seed0=int(seed), nrun=int(runs))
    out = _run(h, _api.mlid_monte_carlo)
    return {"estimates": out["estimates"].T.copy(), "sigma": out["sigma"].T.copy(),
            "information": np.moveaxis(out["information"], 2, 0).copy(),
            "iterations": out["iterations"], "status": out["run_status"]}


def _mc_chunks(runs, seed, chunk):
    """(seed, runs) of each call: runs in order, chunk at a time."""
    return [(seed + k, min(chunk, runs - k)) for k in range(0, runs, chunk)]


#: What the summary of a Monte Carlo holds, over the runs with status 0 (the
#: core's statistics, those of the deck job 'monte_carlo' too): their number,
#: the mean estimate, sample sigma and mean Cramer-Rao sigma of each free
#: parameter, trace and det of the sample covariance and of the mean
#: information.
SUMMARY = ("runs", "mean", "sample_sigma", "mean_cr_sigma", "sample_cov_trace", "sample_cov_det",
           "mean_info_trace", "mean_info_det")


def _mc_result(parts, names, truth, stacklevel=4):
    """The runs of parts joined in order, the summary over the runs that
    succeeded (the core's), and a ConvergenceWarning naming how many did not."""
    out = MonteCarloResult({key: np.concatenate([p[key] for p in parts])
                            for key in ("estimates", "sigma", "information", "iterations",
                                        "status")})
    out["names"], out["truth"] = names, truth
    h = _call_handle()
    _put(h, est=out["estimates"].T, sig=out["sigma"].T,
         info=np.moveaxis(out["information"], 0, 2), run_status=out["status"])
    summary = _run(h, _api.mlid_monte_carlo_summary)
    out["summary"] = {key: summary[key] for key in SUMMARY}
    ok = out["status"] == 0
    bad = out["status"][~ok]
    if bad.size:
        kinds = ", ".join(f"{int((bad == s).sum())} {status_text(s)}"
                          for s in np.unique(bad))
        warnings.warn(
            f"{bad.size} of {ok.size} Monte Carlo runs failed ({kinds}): result['summary'] "
            f"is over the {int(ok.sum())} that converged; the per-run arrays hold every run, "
            "failed ones marked by result['status'] != 0 (estimates of a run that ran out of "
            "iterations are its last iterate, of a run with no result zeros)",
            ConvergenceWarning, stacklevel=stacklevel)
    return out


@guarded
def monte_carlo(truth, start, t, u, noise_std=None, runs=100, seed=1, progress=None,
                **options):
    """Seeded Monte Carlo of fits: simulate, fit, repeat.

    Run k (k = 0, 1, ...) simulates a record from ``truth`` with noise seed
    ``seed + k`` and fits it from ``start``; the results do not depend on how
    the runs are split (see ``monte_carlo_parallel``).

    Parameters
    ----------
    truth, start : Model
        The model the data come from (its process and measurement noise) and
        the one fitted, from its parameter values; same structure and free set.
    t : array_like, (nt,)
        Sample times.
    u : array_like, (nt, nu)
        Inputs.
    noise_std : array_like, (ny,), optional
        Measurement-noise standard deviations replacing the truth's.
    runs : int
        Number of runs, 1 to 10**7.
    seed : int
        Seed of the first run.
    progress : None, bool or stream
        A progress bar over the runs: None shows one when stderr is a
        terminal, True or False always or never, a stream writes it there.
    **options
        Fit options, as for ``fit``.

    Returns
    -------
    MonteCarloResult
        A dict: ``estimates`` and ``sigma`` (Cramer-Rao standard deviations), (runs,
        nf); ``information`` (runs, nf, nf); ``iterations`` and ``status``
        (runs,), status 0 for a converged run, else the core's status code
        (4 not converged, 2 singular information, 3 diverged); ``names`` and
        ``truth`` of the free parameters; ``summary``: over the runs with
        status 0, their number ``runs``, ``mean`` estimate, ``sample_sigma``,
        ``mean_cr_sigma``, and ``sample_cov_trace``, ``sample_cov_det``,
        ``mean_info_trace``, ``mean_info_det`` (the core's statistics, the
        same numbers as the deck job 'monte_carlo' reports).  Also by name
        (``mc.mean['M_q']``), and as DataFrames: ``to_frame()`` a row per
        parameter (truth and summary), ``runs_frame()`` a row per run.

    Raises
    ------
    InputError
        Models of different structure, bad times, inputs, options or sizes.

    Warns
    -----
    ConvergenceWarning
        When runs fail: how many of how many, and what ``summary`` leaves out.
    """
    call, runs, seed, names, truth_free = _mc_setup(truth, start, t, u, noise_std, runs, seed,
                                                    options)
    bar = progress_bar(progress, runs, "Monte Carlo", "run")
    chunk = runs if isinstance(bar, Silent) else max(1, runs // 100)
    parts = []
    with bar:
        for s, n in _mc_chunks(runs, seed, chunk):
            parts.append(_mc_runs(call, s, n))
            bar.update(n)
    return _mc_result(parts, names, truth_free)
