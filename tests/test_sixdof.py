"""The six-degree-of-freedom model (kind 'sixdof', mlid.SixDofModel,
fortran/models/mlid_sixdof.f90): exact Jacobians of the full coupled model, the
longitudinal decoupled form against the built-in longitudinal model (a second
implementation of the same physics in other axes), a lateral fit recovering
its truth within the Cramer-Rao bound in both front ends, and bad input."""

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import both_front_ends_json

# HFB-320-like constants of the built-in longitudinal model's test scenario
LONG = dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                       7472.0, 0.0524, 0.792, 1.215]))
MASS = LONG["m"]
S, CBAR = LONG["S/m"] * MASS, 2 * LONG["cbar/2"]
IY = S * CBAR / LONG["S cbar/Iy"]
CONSTANTS = dict(m=MASS, Ix=0.4 * IY, Iy=IY, Iz=1.3 * IY, Ixz=0.05 * IY, S=S, cbar=CBAR, b=10.5,
                 g=LONG["g"])
VALS = {"CD": [0.117758, -0.0517459, 0.234846], "CL": [-0.204711, 0.363549, 3.21232],
        "Cm": [0.134413, -0.0139045, -1.00241, -27.0570, -1.43707]}
LONG_DEFS = {"V0": "104.67", "c2": "1.215", "rho": "0.792", "T": "F", "sigT": "0.0524",
             "lT": repr(LONG["lT/Iy"] * IY),
             "CD": "CD0 + CDV*V/V0 + CDa*alpha", "CL": "CL0 + CLV*V/V0 + CLa*alpha",
             "Cm": "Cm0 + CmV*V/V0 + Cma*alpha + Cmq*q*c2/V0 + Cmde*de"}
LONG_PARAMS = dict(zip(["CD0", "CDV", "CDa", "CL0", "CLV", "CLa", "Cm0", "CmV", "Cma", "Cmq",
                        "Cmde"], VALS["CD"] + VALS["CL"] + VALS["Cm"]))


def longitudinal_sixdof(**kw):
    return mlid.SixDofModel(CONSTANTS, ["u", "w", "q", "theta"],
                            {"V": "V", "alpha": "alpha", "theta": "theta", "q": "q",
                             "qdot": "qdot", "ax": "ax", "az": "az"},
                            inputs=["de", "F", "v", "p", "r", "phi"], params=LONG_PARAMS,
                            definitions=LONG_DEFS, **kw)


def test_longitudinal_form_is_the_builtin_longitudinal_model():
    """The body-axis equations (u, w, q, theta; v, p, r, phi held at zero as
    inputs) give the wind-axis built-in model's outputs V, alpha, theta, q,
    qdot, a_x, a_z along a 60 s manoeuvre: the same physics written twice.
    Both integrate with RK4 (4 substeps of 0.025 s), so they differ by the
    integration error only: 1e-6 of each output's range."""
    regs = {"CD": ["1", "V/V0", "alpha"], "CL": ["1", "V/V0", "alpha"],
            "Cm": ["1", "V/V0", "alpha", "qhat", "de"]}
    V0, a0, th0, q0 = 106.0, 0.11, 0.105, -0.003
    builtin = mlid.LongitudinalModel(regs, VALS, LONG, x0=[V0, a0, th0, q0], substeps=4)
    six = longitudinal_sixdof(x0=[V0 * np.cos(a0), V0 * np.sin(a0), q0, th0], substeps=4)
    t = np.arange(601) * 0.1
    de = -0.008 + input_signal("3211", 0.03, 2.0, 1.5, 0.1, 601)
    thrust = np.full(601, 11600.0)
    a, _ = mlid.simulate(builtin, t, np.column_stack([de, thrust]))
    b, _ = mlid.simulate(six, t, np.column_stack([de, thrust, np.zeros((601, 4))]))
    span = np.ptp(a.y, axis=0)
    assert np.all(np.abs(a.y - b.y).max(axis=0) < 1e-6 * span), np.abs(a.y - b.y).max(axis=0) / span


def full_model(**kw):
    defs = {"rho": "1.0", "T": "F",
            "CX": "CX0 + CXa*alpha + CXq*qhat", "CZ": "CZ0 + CZa*alpha + CZde*de",
            "Cm": "Cm0 + Cma*alpha + Cmq*qhat + Cmde*de",
            "CY": "CYb*beta + CYr*rhat + CYdr*dr",
            "Cl": "Clb*beta + Clp*phat + Clr*rhat + Clda*da + Clbb*abs(beta)*beta",
            "Cn": "Cnb*beta + Cnp*phat + Cnr*rhat + Cndr*dr + Cna*max(alpha - 0.1, 0)"}
    params = dict(CX0=-0.03, CXa=0.2, CXq=0.1, CZ0=-0.3, CZa=-5.0, CZde=-0.4, Cm0=0.02,
                  Cma=-0.8, Cmq=-15.0, Cmde=-1.2, CYb=-0.8, CYr=0.3, CYdr=0.15, Clb=-0.1,
                  Clp=-0.5, Clr=0.15, Clda=-0.12, Clbb=0.05, Cnb=0.12, Cnp=-0.05, Cnr=-0.2,
                  Cndr=-0.08, Cna=0.3)
    return mlid.SixDofModel(CONSTANTS, ["u", "v", "w", "p", "q", "r", "phi", "theta", "psi", "h"],
                            {"V": "V", "alpha": "alpha", "beta": "beta", "ay": "ay",
                             "pdot": "pdot", "rdot": "rdot", "az_s": "az - (p^2 + q^2)*0.5"},
                            inputs=["de", "da", "dr", "F"], params=params, definitions=defs,
                            **kw)


@pytest.mark.parametrize("x", [[100.0, 3.0, 9.0, 0.1, -0.05, 0.08, 0.2, 0.1, 0.5, 3000.0],
                               [80.0, -5.0, 12.0, -0.3, 0.2, -0.1, -0.4, 0.3, 2.0, 1000.0]])
def test_full_model_jacobians_are_exact(x):
    m = full_model(free=["Cma", "Clp", "Cnr", "Cna", "Clbb"])
    errs = mlid.check_jacobians(m, x, [0.02, -0.01, 0.03, 20000.0])
    assert max(errs.values()) < 1e-7, errs


LATERAL_DECK = """&case title = 'lateral, six degrees of freedom', job = 'estimate' /
&model kind = 'sixdof', constants = {consts},
    state_names = 'v', 'p', 'r', 'phi',
    input_names = 'da', 'dr', 'u', 'w', 'q', 'theta',
    output_names = 'beta', 'p', 'r', 'phi', 'ay',
    params = 'CYb = -0.6', 'Clb = -0.07', 'Clp = -0.4', 'Clr = 0.1', 'Clda = -0.1',
             'Cnb = 0.09', 'Cnr = -0.15', 'Cndr = -0.06',
    definitions = 'rho = 1.0', 'CY = CYb*beta', 'Cl = Clb*beta + Clp*phat + Clr*rhat + Clda*da',
                  'Cn = Cnb*beta + Cnr*rhat + Cndr*dr',
    outputs = 'beta', 'p', 'r', 'phi', 'ay',
    free = 'CYb', 'Clb', 'Clp', 'Clr', 'Clda', 'Cnb', 'Cnr', 'Cndr' /
&data file = 'lat.dat', time_col = 1, input_cols = 2, 3, 4, 5, 6, 7, output_cols = 8, 9, 10, 11, 12 /
&estimate max_iter = 30 /
"""
LAT_TRUTH = dict(CYb=-0.8, Clb=-0.1, Clp=-0.5, Clr=0.15, Clda=-0.12, Cnb=0.12, Cnr=-0.2,
                 Cndr=-0.08)


def lateral_record(path):
    m = mlid.SixDofModel(CONSTANTS, ["v", "p", "r", "phi"],
                         {"beta": "beta", "p": "p", "r": "r", "phi": "phi", "ay": "ay"},
                         inputs=["da", "dr", "u", "w", "q", "theta"], params=LAT_TRUTH,
                         definitions={"rho": "1.0", "CY": "CYb*beta",
                                      "Cl": "Clb*beta + Clp*phat + Clr*rhat + Clda*da",
                                      "Cn": "Cnb*beta + Cnr*rhat + Cndr*dr"})
    t = np.arange(801) * 0.05
    da = input_signal("doublet", 0.05, 1.0, 1.0, 0.05, 801)
    dr = input_signal("doublet", 0.05, 12.0, 1.5, 0.05, 801)
    u = np.column_stack([da, dr, np.full(801, 99.0), np.full(801, 8.0), np.zeros(801),
                         np.full(801, 0.08)])
    d, _ = mlid.simulate(m, t, u, noise_std=[2e-3, 2e-3, 2e-3, 2e-3, 0.05], seed=5)
    np.savetxt(path, np.column_stack([d.t, d.u, d.y]))


def test_lateral_decoupled_deck_recovers_the_truth_in_both_front_ends(tmp_path):
    """States v, p, r, phi, the longitudinal quantities measured inputs: the
    eight derivatives within 4 Cramer-Rao sigma of the truth (seeded)."""
    lateral_record(tmp_path / "lat.dat")
    consts = ", ".join(repr(CONSTANTS[k]) for k in mlid.model.models.SIXDOF_CONSTANTS)
    deck = tmp_path / "lat.nml"
    deck.write_text(LATERAL_DECK.format(consts=consts))
    fit = both_front_ends_json(deck, tmp_path)
    assert fit["converged"]
    for name, value, sigma in zip(fit["parameters"], fit["estimate"], fit["sigma"]):
        assert abs(value - LAT_TRUTH[name]) < 4 * sigma, (name, value, sigma)


@pytest.mark.parametrize("change, message", [
    ({"constants": dict(CONSTANTS, Ixz=0.8 * IY)}, "inertia matrix is not positive definite"),
    ({"constants": dict(CONSTANTS, m=0.0)}, "must be > 0"),
    ({"states": ["u", "w", "q", "theta", "alpha"]}, "state 'alpha' is not one of"),
    ({"inputs": ["de", "F", "v", "p", "r"]}, "'phi' is neither a state nor an input"),
    ({"definitions": {k: v for k, v in LONG_DEFS.items() if k != "Cm"}},
     "state q needs Cm among the definitions"),
    ({"definitions": {k: v for k, v in LONG_DEFS.items() if k != "rho"}}, "define rho"),
])
def test_bad_six_dof_models_are_one_line(change, message):
    kw = dict(constants=CONSTANTS, states=["u", "w", "q", "theta"],
              outputs={"V": "V"}, inputs=["de", "F", "v", "p", "r", "phi"],
              params=LONG_PARAMS, definitions=LONG_DEFS)
    kw.update(change)
    with pytest.raises(mlid.InputError, match=message):
        mlid.SixDofModel(**kw)
