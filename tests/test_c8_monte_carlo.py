"""The C-8 Monte Carlo case (cases/c8_monte_carlo) and the parallel runner:
the same seeds give the same runs in one process, over worker processes and
on a Dask cluster."""

import sys

import numpy as np
import pytest

import mlid
from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "c8_monte_carlo"))
import c8_mc  # noqa: E402


def test_parallel_runs_do_not_depend_on_how_they_are_split():
    truth, start = c8_mc.models()
    t, us, _ = c8_mc.inputs()
    u = us["optimal"]
    one = mlid.monte_carlo(truth, start, t, u, runs=12, seed=5)
    procs = mlid.monte_carlo_parallel(truth, start, t, u, runs=12, seed=5, workers=2, chunk=5)
    np.testing.assert_array_equal(one["estimates"], procs["estimates"])
    np.testing.assert_array_equal(one["information"], procs["information"])
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dask = mlid.monte_carlo_parallel(truth, start, t, u, runs=12, seed=5, scheduler=client,
                                         chunk=4)
    np.testing.assert_array_equal(one["estimates"], dask["estimates"])


def test_c8_monte_carlo_case(tmp_path):
    """Table 8.1's story with 100 runs (seeded): the sample sigma of every
    estimate within 30% of the Cramer-Rao sigma (3 standard errors of a
    sample sigma from 100 runs are 21%, plus the bound's own first-order
    error), and the optimal input beats the doublet of equal energy."""
    out = c8_mc.run(runs=100, plots=tmp_path, workers=2)
    for name in ("optimal", "doublet"):
        s = out[name]
        assert s["failed"] == 0
        ratio = s["sample sigma"] / s["CR sigma"]
        assert np.all(np.abs(ratio - 1) < 0.3), (name, ratio)
        z = (s["mean"] - out["truth"]) / (s["sample sigma"] / np.sqrt(s["runs"]))
        assert np.all(np.abs(z) < 4), (name, z)
    o, d = out["optimal"], out["doublet"]
    assert o["expected info trace"] > 3 * d["expected info trace"]
    assert o["sample cov det"] < d["sample cov det"]
    assert len(list(tmp_path.glob("fig8_1*.png"))) == 5
    ts = out["two-sided"]                       # §8.3: through the servo, det favours optimal
    assert ts["optimal"]["det"] > 2 * ts["doublet"]["det"]


def test_bad_runs():
    truth, start = c8_mc.models()
    t, us, _ = c8_mc.inputs()
    with pytest.raises(mlid.InputError, match="runs"):
        mlid.monte_carlo_parallel(truth, start, t, us["optimal"], runs=0)
