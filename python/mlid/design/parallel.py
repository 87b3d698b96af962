"""Monte Carlo identifications spread over threads or a Dask cluster.

Run k of a Monte Carlo always uses seed + k - 1, so the results do not
depend on how the runs are split: chunks of runs go to worker threads (the
core's wrappers release the GIL, and a fit touches no module variable of the
core, so threads run fits side by side; no process is started, so a plain
script needs no ``if __name__ == "__main__":`` guard) or, given a scheduler
address, to a Dask cluster.
"""

import os
from concurrent.futures import ThreadPoolExecutor, as_completed

import numpy as np

from ..checks import whole
from ..errors import InputError, guarded
from ..openmp import team_size
from ..progress import bar as progress_bar, shown_on
from .monte_carlo import _mc_chunks, _mc_result, _mc_runs, _mc_setup


@guarded
def monte_carlo_parallel(truth, start, t, u, runs=100, seed=1, workers=None, scheduler=None,
                         chunk=None, noise_std=None, progress=None, **options):
    """As ``mlid.monte_carlo``, with the runs in chunks over threads or a
    Dask cluster; the same numbers whichever way they are split.

    Parameters
    ----------
    truth, start, t, u, noise_std, runs, seed, **options
        As for ``mlid.monte_carlo``.
    workers : int, optional
        Threads running chunks side by side (default: the machine's cores).
    scheduler : str or distributed.Client, optional
        A Dask scheduler address such as 'tcp://127.0.0.1:8786', or a
        client: the chunks run on that cluster instead.
    chunk : int, optional
        Runs per chunk (default: about four chunks per worker).
    progress : None, bool or stream
        A bar over the runs as chunks end (None: when stderr is a terminal).

    Returns
    -------
    MonteCarloResult
        As ``mlid.monte_carlo``.

    Raises
    ------
    InputError
        Bad models, sizes, options, workers or scheduler.

    Warns
    -----
    ConvergenceWarning
        When runs fail: how many of how many, and what ``summary`` leaves out.
    """
    call, runs, seed, names, truth_free = _mc_setup(truth, start, t, u, noise_std, runs, seed,
                                                    options)
    if scheduler is not None and not isinstance(scheduler, str) and \
            not hasattr(scheduler, "gather"):
        raise InputError("scheduler must be an address such as 'tcp://127.0.0.1:8786' or a "
                         f"distributed.Client, got {type(scheduler).__name__}")
    workers = (os.cpu_count() or 1) if workers is None else whole("workers", workers, 1, 4096)
    # a bar moves as chunks end: some 100 chunks when one shows
    parts_of = max(100, 4 * workers) if shown_on(progress) else 4 * workers
    chunk = whole("chunk", chunk or max(1, int(np.ceil(runs / parts_of))), 1, 10**7)
    jobs = _mc_chunks(runs, seed, chunk)
    parts = [None] * len(jobs)
    with progress_bar(progress, runs, "Monte Carlo", "run") as b:
        if scheduler is not None:
            from distributed import Client, as_completed as dask_completed
            client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
            try:
                futures = [client.submit(_mc_runs, call, s, n, pure=False) for s, n in jobs]
                index = {f.key: k for k, f in enumerate(futures)}
                for f in dask_completed(futures):
                    parts[index[f.key]] = f.result()
                    b.update(jobs[index[f.key]][1])
            finally:
                if client is not scheduler:
                    client.close()
        else:
            n = min(workers, len(jobs))
            omp = max(1, (os.cpu_count() or 1) // n)
            with ThreadPoolExecutor(n, initializer=team_size, initargs=(omp,)) as pool:
                futures = {pool.submit(_mc_runs, call, s, n): k
                           for k, (s, n) in enumerate(jobs)}
                for f in as_completed(futures):
                    parts[futures[f]] = f.result()
                    b.update(jobs[futures[f]][1])
    return _mc_result(parts, names, truth_free)
