"""Monte Carlo identifications spread over processes or a Dask cluster.

Run k of a Monte Carlo always uses seed + k - 1, so the results do not
depend on how the runs are split: chunks of runs go to worker processes
(spawned, not forked: the core's OpenMP runtime does not survive a fork) or,
given a scheduler address, to a Dask cluster.
"""

import os
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

import numpy as np

from . import core
from .checks import whole
from .errors import InputError, guarded


def _chunk(args):
    from .core import monte_carlo
    truth, start, t, u, runs, seed, options = args
    return monte_carlo(truth, start, t, u, runs=runs, seed=seed, **options)


@guarded
def monte_carlo_parallel(truth, start, t, u, runs=100, seed=1, workers=None, scheduler=None,
                         chunk=None, **options):
    """As mlid.monte_carlo, with the runs in chunks over workers processes
    (default: the machine's cores) or over the Dask cluster at scheduler
    (an address such as 'tcp://127.0.0.1:8786', or a distributed.Client)."""
    core._check_model(truth, "truth")
    core._check_model(start, "start")
    runs = whole("runs", runs, 1, 10**7)
    seed = whole("seed", seed, 0, 2**31 - runs)
    t, u = core._time_and_inputs(start, t, u)
    if scheduler is not None and not isinstance(scheduler, str) and \
            not hasattr(scheduler, "gather"):
        raise InputError("scheduler must be an address such as 'tcp://127.0.0.1:8786' or a "
                         f"distributed.Client, got {type(scheduler).__name__}")
    workers = (os.cpu_count() or 1) if workers is None else whole("workers", workers, 1, 4096)
    chunk = chunk or max(1, int(np.ceil(runs / (4 * workers))))
    jobs = [(truth, start, t, u, min(chunk, runs - k), seed + k, options)
            for k in range(0, runs, chunk)]
    if scheduler is not None:
        from distributed import Client
        client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
        try:
            parts = client.gather(client.map(_chunk, jobs, pure=False))
        finally:
            if client is not scheduler:
                client.close()
    elif workers == 1:
        parts = [_chunk(j) for j in jobs]
    else:
        with ProcessPoolExecutor(workers, mp_context=get_context("spawn")) as pool:
            parts = list(pool.map(_chunk, jobs))
    out = dict(parts[0])
    for key in ("estimates", "sigma", "information", "iterations", "status"):
        out[key] = np.concatenate([p[key] for p in parts])
    return out
