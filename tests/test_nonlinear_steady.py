"""The steady-state gain for nonlinear models (issue 15), as the textbook's
filter error for nonlinear systems (ml_fem): the states follow the nonlinear
model, K and B are the steady state of the model linearised about x0 and the
first input sample.  The cost against a second implementation (numpy, scipy's
Riccati solver), the gradient against finite differences of the cost, an
error that says where it comes from, and both front ends on a deck.  The same
filter on a linear problem stated as a nonlinear model is checked against the
linear filter in tests/fortran/test_filter_nonlinear.f90 (no nonlinear model
kind with process noise states a linear problem: equations models have none)."""

import numpy as np
import pytest
import scipy.linalg

import mlid
from conftest import both_front_ends_json, finite_difference
from test_hfb320 import COEFFS, REF, _hfb_like, _inputs

# the constants of _hfb_like, by name
CONST = dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                        7472.0, 0.0524, 0.792, 1.215]))


def _turbulent(free=COEFFS + ["q(2)", "q(4)", "r(1)", "r(2)", "r(4)"]):
    model = _hfb_like(free)
    model.q = np.array([2e-3, 1e-5, 0.0, 1e-4])
    return model


def _record(model, n=300, seed=2):
    t, u = _inputs()
    return mlid.simulate(model, t[:n], u[:n], seed=seed)[0]


def _f(p, c, x, u, w):
    """The longitudinal model's state equations (fortran/models/mlid_aero_long.f90,
    the HFB-320 regressors) written out again; complex-safe."""
    V, al, th, q = x
    de, ft = u
    cd = p[0] + p[1] * V / c["V0"] + p[2] * al
    cl = p[3] + p[4] * V / c["V0"] + p[5] * al
    cm = p[6] + p[7] * V / c["V0"] + p[8] * al + p[9] * q * c["cbar/2"] / c["V0"] + p[10] * de
    qbar = 0.5 * c["rho"] * V**2
    m, s, g = c["m"], c["sigma_T"], c["g"]
    return np.array([
        -c["S/m"] * qbar * cd + ft * np.cos(al + s) / m + g * np.sin(al - th),
        -c["S/m"] * qbar / V * cl - ft * np.sin(al + s) / (m * V) + q + g * np.cos(al - th) / V,
        q,
        c["S cbar/Iy"] * qbar * cm + c["lT/Iy"] * ft]) + w


def _h(p, c, x, u):
    V, al = x[0], x[1]
    cd = p[0] + p[1] * V / c["V0"] + p[2] * al
    cl = p[3] + p[4] * V / c["V0"] + p[5] * al
    qs = 0.5 * c["rho"] * V**2 * c["S/m"]
    return np.array([*x, _f(p, c, x, u, 0.0)[3],
                     qs * (cl * np.sin(al) - cd * np.cos(al)) + u[1] * np.cos(c["sigma_T"]) / c["m"],
                     qs * (-cl * np.cos(al) - cd * np.sin(al)) - u[1] * np.sin(c["sigma_T"]) / c["m"]])


def _rk4(p, c, x, u0, u1, w, h):
    um = 0.5 * (u0 + u1)
    k1 = _f(p, c, x, u0, w)
    k2 = _f(p, c, x + 0.5 * h * k1, um, w)
    k3 = _f(p, c, x + 0.5 * h * k2, um, w)
    k4 = _f(p, c, x + h * k3, u1, w)
    return x + h / 6 * (k1 + 2 * (k2 + k3) + k4)


def second_filter(model, data):
    """The cost of the nonlinear filter with the steady-state gain, written
    out: Phi, W and C by complex steps about (x0, u(0)), P from scipy's
    solve_discrete_are, then the nonlinear states with that K at every
    sample."""
    p, c, x0 = model.theta[:11], CONST, np.asarray(model.x0, float)
    h = data.t[1] - data.t[0]
    u0, u1, w0 = data.u[0], data.u[1], np.zeros(4)
    eps = 1e-30
    phi = np.column_stack([_rk4(p, c, x0 + 1j * eps * e, u0, u1, w0, h).imag / eps
                           for e in np.eye(4)])
    W = np.column_stack([_rk4(p, c, x0, u0, u1, 1j * eps * e, h).imag / eps for e in np.eye(4)])
    C = np.column_stack([_h(p, c, x0 + 1j * eps * e, u0).imag / eps for e in np.eye(4)])
    Q, R = np.diag(model.q), np.diag(model.r)
    P = scipy.linalg.solve_discrete_are(phi.T, C.T, W @ Q @ W.T, R)
    B = C @ P @ C.T + R
    Bi = np.linalg.inv(B)
    K = P @ C.T @ Bi
    x, cost = x0.copy(), 0.0
    for j in range(data.nt):
        if j:
            x = _rk4(p, c, x, data.u[j - 1], data.u[j], w0, h)
        v = data.y[j] - _h(p, c, x, data.u[j])
        cost += 0.5 * (v @ Bi @ v + np.log(np.linalg.det(B)))
        x = x + K @ v
    return cost


def test_cost_agrees_with_a_second_implementation():
    model = _turbulent()
    data = _record(model)
    start = model.with_theta(model.theta * np.where(model.free_mask == 1, 1.03, 1.0))
    for m in (model, start):
        ev = mlid.evaluate(m, data, method="filter_error", steady_state=True)
        assert ev["cost"] == pytest.approx(second_filter(m, data), rel=1e-9)
    # and it is a different filter from the EKF (its gain varies along the record)
    ekf = mlid.evaluate(model, data, method="filter_error")
    assert abs(ekf["cost"] - ev["cost"]) > 1e-6 * abs(ev["cost"])


@pytest.mark.parametrize("process_noise", ["held", "continuous"])
def test_gradient_matches_finite_differences(process_noise):
    """With gain partials (forward differences of whole runs, the
    linearisation redone in each) the gradient is that of the cost."""
    model = _turbulent()
    data = _record(model)
    start = model.with_theta(model.theta * np.where(model.free_mask == 1, 1.03, 1.0))
    opts = dict(method="filter_error", steady_state=True, process_noise=process_noise)
    ev = mlid.evaluate(start, data, **opts)
    idx = start.free_indices()
    fd = finite_difference(lambda th: mlid.evaluate(start.with_theta(th), data, **opts)["cost"],
                           start.theta, idx, rel=1e-5, floor=1e-12)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1e-3 * np.max(np.abs(fd)))
    assert np.max(rel) < 1e-4, dict(zip(start.free_names(), rel))   # measured 1.4e-5, 6e-6


def test_a_linearisation_that_fails_says_so():
    """df/dx not finite at x0 (d sqrt(x^2)/dx at 0): one line that names the
    steady-state gain's linearisation, no NaN carried on."""
    model = mlid.EquationModel({"y": "x"}, states={"x": "u - x + 0.1*sqrt(x*x)"}, inputs=["u"],
                               x0=[0.0], r=[1e-4])
    t = np.arange(100) * 0.05
    data = mlid.simulate(model, t, np.sin(t)[:, None], seed=1)[0]
    assert np.isfinite(mlid.evaluate(model, data)["cost"])       # the model itself is fine
    with pytest.raises(mlid.MlidError) as err:
        mlid.evaluate(model, data, method="filter_error", steady_state=True)
    text = str(err.value)
    assert text.startswith("the linearisation is not finite") and "steady-state gain" in text
    assert "\n" not in text.strip()


def test_both_front_ends_agree_on_a_deck(tmp_path):
    truth = _turbulent()
    data = _record(truth, n=400, seed=7)
    np.savetxt(tmp_path / "rec.asc", np.column_stack([data.t, data.u, data.y]))
    (tmp_path / "deck.nml").write_text(f"""
&case title = 'longitudinal, filter error, steady-state gain', job = 'estimate' /
&model kind = 'longitudinal',
    cd_regressors = '1', 'V/V0', 'alpha',
    cl_regressors = '1', 'V/V0', 'alpha',
    cm_regressors = '1', 'V/V0', 'alpha', 'qhat', 'de',
    cd = {', '.join(f'{v:.10g}' for v in 1.05 * REF[:3])},
    cl = {', '.join(f'{v:.10g}' for v in 1.05 * REF[3:6])},
    cm = {', '.join(f'{v:.10g}' for v in 1.05 * REF[6:])},
    constants = {', '.join(f'{v:.10g}' for v in CONST.values())},
    x0 = 106.0, 0.11, 0.105, -0.003,
    q = 1.0e-3, 0.0, 0.0, 1.0e-4,
    r = {', '.join(f'{v:.10g}' for v in truth.r)},
    free = 'cd(1)', 'cd(2)', 'cd(3)', 'cl(1)', 'cl(2)', 'cl(3)',
           'cm(1)', 'cm(2)', 'cm(3)', 'cm(4)', 'cm(5)', 'q(1)', 'q(4)', 'r(1)', 'r(2)' /
&data file = 'rec.asc',
    columns = 'T', 'DE', 'FT', 'V', 'AL', 'TH', 'Q', 'QD', 'AX', 'AZ',
    time_col = 'T', input_cols = 'DE', 'FT', output_cols = 'V', 'AL', 'TH', 'Q', 'QD', 'AX', 'AZ' /
&estimate method = 'filter_error', steady_state = .true., max_iter = 30,
    lower(12:13) = 0.0, 0.0 /
""")
    fit = both_front_ends_json(tmp_path / "deck.nml", tmp_path)
    assert fit["converged"], fit
    est = dict(zip(fit["parameters"], fit["estimate"]))
    sig = dict(zip(fit["parameters"], fit["sigma"]))
    for k, name in enumerate(["C_D0", "C_DV", "C_Dalpha", "C_L0", "C_LV", "C_Lalpha", "C_m0",
                              "C_mV", "C_malpha", "C_mq", "C_mde"]):
        assert abs(est[name] - REF[k]) < 4 * sig[name], name
