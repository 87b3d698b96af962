"""Filter error as the textbook computes it (noise_criterion = 'textbook',
FVSysID's ml_fem2; issue 44 item 2) on synthetic records: its gradient
against finite differences of its cost where R is the innovations' mean
square (the criterion's fixed point, where its Gauss-Newton gradient is the
cost's), for a linear and a nonlinear model; what it refuses; both front
ends.  The real HFB-320 case against FVSysID: tests/test_hfb320_fem.py."""

import json
import os
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, finite_difference
from test_filter_error import gust_model, record

OPTS = {"method": "filter_error", "steady_state": True, "process_noise": "continuous_sd",
        "noise_criterion": "textbook"}


def settled(model, data, opts):
    """The model with r at the innovations' mean square of its own gain
    (R-hat = R, iterated at fixed theta to 1e-12)."""
    names = model.element_names()
    ir = [i for i, n in enumerate(names) if n.startswith("r(")]
    th = model.theta.copy()
    for _ in range(200):
        rh = np.diag(mlid.evaluate(model.with_theta(th), data, **opts)["rhat"])
        change = np.max(np.abs(rh / th[ir] - 1))
        th[ir] = rh
        if change < 1e-12:
            return model.with_theta(th)
    raise AssertionError(f"R did not settle: last change {change}")


def check_gradient(model, data, opts, tol):
    model = settled(model, data, opts)
    ev = mlid.evaluate(model, data, **opts)
    fd = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), data, **opts)["cost"],
                           model.theta, model.free_indices(), rel=1e-4, floor=1e-3,
                           five_point=True)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1.0)
    assert np.max(rel) < tol, dict(zip(model.free_names(), rel))


def test_gradient_linear_model():
    """Every kind of partial of the gain: F, G, H entries (dA, dC through the
    model's df/dp and dh/dp), the noise's reach f(3,3), q (dV), x0 and a bias
    (no gain partial).  The linear model's dA and dC are exact (central
    differences of a linear df/dp): measured at most 1.2e-7 relative (x0(1)),
    1.4e-9 for the others."""
    model = gust_model(["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "f(3,3)", "h(2,2)", "q(1)",
                        "x0(1)", "bias(2)"], q=0.05)
    check_gradient(model, record(gust_model(q=0.05)), dict(OPTS), 1e-6)


def test_textbook_fit_on_a_linear_model_converges():
    data = record(gust_model(q=0.05), seed=7)
    start = gust_model(["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "f(3,3)", "q(1)"], q=0.02)
    out = mlid.fit(start, data, **OPTS)
    assert out.converged
    # the criterion's R is the innovations' mean square at the end (tol_cost 1e-8 on det R)
    np.testing.assert_allclose(out.r_innovations, np.diag(out.rhat), rtol=1e-3)


@pytest.mark.parametrize("opts, message", [
    ({"steady_state": False}, "steady_state = true"),
    ({"process_noise": "held"}, "continuous process noise"),
    ({"noise": "full"}, "diagonal R"),
    ({"method": "output_error", "steady_state": False, "process_noise": "held"},
     "is for filter error"),
])
def test_textbook_refusals(opts, message):
    model = gust_model(["f(1,1)", "q(1)"])
    with pytest.raises(mlid.InputError, match=message):
        mlid.fit(model, record(model), **{**OPTS, **opts})


def test_textbook_refuses_free_r():
    model = gust_model(["f(1,1)", "q(1)", "r(1)"])
    with pytest.raises(mlid.InputError, match="leave them fixed"):
        mlid.fit(model, record(model), **OPTS)


DECK = """&case title = 'gust: simulate', job = 'simulate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.0, -3.0, -3.0,  0.4, -0.8, -0.8,  0.0, 0.0, -1.5,
    g = 2.0, 0.5, 0.0,
    h = 1, 0, 0,  0, 1, 1,
    gamma = 0, 0, 1, q = 0.05, r = 1e-3, 2e-3 /
&simulate out = 'gust.dat', t_end = 15.0, dt = 0.05, seed = 5,
    input_shape = '3211', amplitude = 1.0, t_start = 0.5, pulse_width = 0.3 /

&case title = 'gust: textbook filter error', job = 'estimate' /
&model kind = 'linear', nx = 3, nu = 1, ny = 2, nw = 1,
    f = -1.2, -2.4, -2.4,  0.4, -0.6, -0.6,  0.0, 0.0, -2.0,
    g = 1.6, 0.5, 0.0,
    h = 1, 0, 0,  0, 1, 1,
    gamma = 0, 0, 1, q = 0.02, r = 1e-2, 1e-2,
    free = 'f(1,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'f(3,3)', 'q(1)',
    tie = 'f(1,3) = f(1,2)', 'f(2,3) = f(2,2)' /
&data file = 'gust.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
&estimate method = 'filter_error', steady_state = .true., process_noise = 'continuous_sd',
    noise_criterion = 'textbook' /
"""


@pytest.mark.parametrize("threads", ["1", "2"])
def test_both_front_ends_run_the_textbook_criterion(tmp_path, threads):
    """The same deck through `mlid run` and `mlid-batch`, 1 and 2 threads:
    the same report and JSON bytes."""
    deck = tmp_path / "tb.nml"
    deck.write_text(DECK)
    env = {**os.environ, "OMP_NUM_THREADS": threads}
    runs = [subprocess.run([str(BIN / exe), *pre, str(deck), "--json", str(tmp_path / f"{exe}.json")],
                           capture_output=True, text=True, cwd=tmp_path, env=env)
            for exe, pre in (("mlid", ["run"]), ("mlid-batch", []))]
    py, fo = runs
    assert py.returncode == fo.returncode == 0, (py.stderr, fo.stderr)
    assert py.stdout == fo.stdout
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    assert "diag(KC) of the textbook gain" in py.stdout
    fitted = json.loads((tmp_path / "mlid.json").read_text())[1]
    assert fitted["converged"], fitted["reason"]
