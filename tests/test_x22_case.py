"""The X-22 model of report Appendix A and its case (cases/x22_vtol): the
extended Kalman filter with gusts carried by the accelerometers."""

import sys

import numpy as np
import pytest

import mlid
from conftest import REPO, finite_difference

sys.path.insert(0, str(REPO / "cases" / "x22_vtol"))
import x22  # noqa: E402


def test_x22_jacobians_with_gusts():
    m = x22.model(x22.TRUTH, "low")
    err = mlid.check_jacobians(m, [128.0, 3.0, 0.06, 0.04], [0.05], w=[1.5, -2.0, 0.004])
    assert max(err.values()) < 1e-7, err


def test_x22_trims_where_the_case_says():
    """Noise-free from the trim of CASES.md §2 with the trim elevator: the
    states stay put, a check that the coefficients' signs are read right."""
    m = x22.model(x22.TRUTH, "low")
    m.q[:] = 0.0
    t = np.arange(201) * 0.05
    data, states = mlid.simulate(m, t, np.full((201, 1), x22.DELTA0))
    drift = np.abs(states - states[0]).max(axis=0)
    assert np.all(drift < [1e-3, 1e-3, 1e-5, 1e-5]), drift


def test_x22_ekf_gradient_matches_finite_differences():
    """The gusts enter the outputs (effective R and S depend on x and p): the
    filter-error gradient with partials is still that of its cost."""
    data, _ = x22.record("multistep", "moderate")
    short = mlid.FlightData(data.t[:80], data.u[:80], data.y[:80])
    m = x22.model(x22.TRUTH * 1.002, "moderate")
    ev = mlid.evaluate(m, short, method="filter_error")
    idx = np.flatnonzero(m.free_mask)
    fd = finite_difference(
        lambda th: mlid.evaluate(m.with_theta(th), short, method="filter_error")["cost"],
        m.theta, idx, rel=1e-6, floor=1e-9)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1e-3 * np.max(np.abs(fd)))
    assert np.max(rel) < 1e-3, dict(zip(m.free_names(), rel))


def test_x22_multistep_beats_a_single_step():
    """Report §5.1.4: from the equation-error start-up the multistep record
    is identified within 3 sigma of the truth; at the maximum near the truth
    every derivative at trim speed has a smaller sigma than with a single
    step."""
    fits = {}
    for kind in ("step", "multistep"):
        data, _ = x22.record(kind, "moderate")
        fits[kind] = x22.identify(data, "moderate", startup="none")
    data, _ = x22.record("multistep", "moderate")
    ee = x22.identify(data, "moderate")
    assert ee.converged
    assert np.all(np.abs(ee.estimate - x22.TRUTH) < 3 * ee.sigma)
    step = x22.derivative_at(fits["step"], x22.U0)
    multi = x22.derivative_at(fits["multistep"], x22.U0)
    assert all(multi[n][1] < step[n][1] for n in multi), (multi, step)
    assert max(step[n][1] / multi[n][1] for n in multi) > 10       # M_de: measured 38


def test_noise_timing():
    data_f, _ = x22.record("multistep", "low", timing="forward")
    data_b, _ = x22.record("multistep", "low", timing="backward")
    assert not np.allclose(data_f.y[:, 4:], data_b.y[:, 4:])    # qdot, n_x, n_z differ
    with pytest.raises(mlid.InputError, match="timing"):
        x22.record("step", "low", timing="sideways")
