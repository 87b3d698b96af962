"""The C-8 Monte Carlo case (cases/c8_monte_carlo) and the parallel runner:
the same seeds give the same runs in one process, over threads and on a
Dask cluster; the truth search, Table 8.1 and §8.3 as README.md says."""

import sys

import numpy as np
import pytest

import mlid
from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "c8_monte_carlo"))
import c8_longitudinal as c8  # noqa: E402
import c8_mc  # noqa: E402

RUNS = 30       # the case script runs 50; the tolerances below are for 30


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return c8_mc.run(runs=RUNS, plots=tmp_path_factory.mktemp("plots"), workers=2)


def test_parallel_runs_do_not_depend_on_how_they_are_split():
    truth, start = c8.model(c8.DESIGN_VALUES * 1.2), c8.model()
    u = c8_mc.held(c8_mc.inputs()["optimal"])
    t = np.arange(len(u)) * c8.DT
    one = mlid.monte_carlo(truth, start, t, u, runs=12, seed=5)
    procs = mlid.monte_carlo_parallel(truth, start, t, u, runs=12, seed=5, workers=2, chunk=5)
    np.testing.assert_array_equal(one["estimates"], procs["estimates"])
    np.testing.assert_array_equal(one["information"], procs["information"])
    for key, value in one["summary"].items():       # the core's summary of the same runs
        np.testing.assert_array_equal(value, procs["summary"][key], err_msg=key)
    # Without process noise the core simulates the truth once and each run
    # adds its own noise: the record of run k is simulate()'s with seed 5 + k,
    # and the run is fit() of it (the estimates and sigma to the bit).
    for k in (0, 7):
        res = mlid.fit(start, mlid.simulate(truth, t, u, seed=5 + k)[0])
        np.testing.assert_array_equal(res.estimate, one["estimates"][k])
        np.testing.assert_array_equal(res.sigma, one["sigma"][k])
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dask = mlid.monte_carlo_parallel(truth, start, t, u, runs=12, seed=5, scheduler=client,
                                         chunk=4)
    np.testing.assert_array_equal(one["estimates"], dask["estimates"])


def test_noise_reading_and_doublet(case):
    """The reading of the noise line that keeps §8.1's q : alpha = 1 : 2 also
    scores better against Table 8.1; the doublet starts with the optimal
    input's jump of about 10 deg (§8.3) at energy 58."""
    np.testing.assert_array_equal(c8.R_SAMPLE, c8.R_READINGS["u, theta, q .125; alpha .25"])
    other = c8_mc.search_truth(c8.R_READINGS["u, theta .125; q, alpha .25"])[0][0]
    assert case["search"][0][0] < other - 0.02
    us = c8_mc.inputs()
    for u in us.values():
        assert np.sum(u**2) * c8.DT == pytest.approx(c8.ENERGY, rel=1e-9)
    assert abs(us["optimal"][0, 0]) == pytest.approx(10, abs=0.1)       # §8.3: "10 deg"
    assert abs(us["doublet"][0, 0]) == pytest.approx(abs(us["optimal"][0, 0]), rel=0.02)


def test_truth_search_and_table_8_1_bounds(case):
    """The search lands on M_q x1.5 and M_alpha, Z_alpha, M_delta x0.5 (Z_delta
    is left nearly free by the report's numbers); at that truth the report's
    eigenvalues of the information, which did not take part in the search,
    come out: four of five within 15% for the optimal input (the fifth,
    1.12, contradicts the report's own bound column) and all five within a
    factor 1.7 for the doublet (the largest, the trace's, is 0.6x: our
    doublet's halves, 15 samples, are a shade shorter than the report's)."""
    assert case["search"][0][0] < 0.16
    np.testing.assert_allclose(case["factors"][:4], [1.5, 0.5, 0.5, 0.5])
    exp = {k: case[k]["expected info eigenvalues"] for k in ("optimal", "doublet")}
    ref = {k: np.array(c8_mc.TABLE_8_1[k]["avg info eigenvalues"]) for k in exp}
    assert np.all(np.abs(exp["optimal"][:4] / ref["optimal"][:4] - 1) < 0.15)
    assert exp["optimal"][4] > 1 / np.sum(np.square(c8_mc.TABLE_8_1["optimal"]["CR sigma"]))
    assert np.all(np.abs(np.log(exp["doublet"] / ref["doublet"])) < np.log(1.7))


def test_monte_carlo_against_the_bound(case):
    """30 seeded runs per input: every sample sigma within 40% of the
    Cramer-Rao sigma at the truth (a sample sigma from 30 runs has a
    standard error of 1/sqrt(2 x 29) = 13%: 3 standard errors), means within
    4 standard errors of the truth, and the optimal input's generalised
    variance (det of the sample covariance) at least 100x below the
    doublet's (measured 4e4 with 50 runs; the report: 9e3)."""
    for name in ("optimal", "doublet"):
        s = case[name]
        assert s["failed"] == 0
        assert np.all(np.abs(s["sample sigma"] / s["CR sigma"] - 1) < 0.4), name
        z = (s["mean"] - case["truth"]) / (s["sample sigma"] / np.sqrt(s["runs"]))
        assert np.all(np.abs(z) < 4), (name, z)
        # the per-run fits redo the Monte Carlo's runs exactly
        np.testing.assert_array_equal(s["per run"]["estimates"], s["mc estimates"])
    o, d = case["optimal"], case["doublet"]
    assert o["sample cov det"] * 100 < d["sample cov det"]
    assert o["expected info trace"] > 30 * d["expected info trace"]


def test_r_errors_servo_and_plots(case):
    """R-hat against the noise's own sample variance: for theta within 5%
    in every run, as the report says (the fit absorbs about p/N = 5%/100
    of the noise; the spread is the sampling error of R-hat's fit part).
    §8.3 at the design values: the optimal two-sided input beats the
    doublet of the same rule on det and on trace; the doublet of 2 s halves
    beats it on trace (it drives the speed), which is why the doublet's
    shape matters."""
    for name in ("optimal", "doublet"):
        assert np.max(np.abs(case[name]["per run"]["R error"][:, 1])) < 0.05
    ts = case["two-sided"]["design values"]
    assert ts["optimal"]["det"] > 100 * ts["doublet"]["det"]
    assert ts["optimal"]["trace"] > 10 * ts["doublet"]["trace"]
    assert ts["doublet, 2 s halves"]["trace"] > ts["optimal"]["trace"]
    names = sorted(p.name for p in case["plots"])
    assert len(names) == 7 and "fig8_17_R_error_theta.png" in names


def test_bad_runs():
    u = c8_mc.held(c8_mc.inputs()["optimal"])
    t = np.arange(len(u)) * c8.DT
    with pytest.raises(mlid.InputError, match="runs"):
        mlid.monte_carlo_parallel(c8.model(), c8.model(), t, u, runs=0)
