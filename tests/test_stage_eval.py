"""One evaluation of a model per point (model_t%eval): the kinds' Jacobians
from the all-at-once evaluation against central differences where the
other tests do not reach (a linear model with state feedback, process noise
and trim biases; the longitudinal model with process noise), and the
output-error sensitivities, which take the first Runge-Kutta stage of each
step from the outputs' evaluation at the sample, against central
differences of whole predictions (one and two substeps, linear and held
inputs)."""

import numpy as np
import pytest

import mlid
from conftest import REPO, finite_difference

DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"


def test_linear_model_with_feedback_noise_and_trim_biases():
    F = [[-0.8, 1.0, 0.0], [-4.0, -1.2, 0.3], [0.0, 1.0, 0.0]]
    G = [[-0.1, 0.02], [-6.0, 0.5], [0.0, 0.0]]
    H = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, -0.2, 0.1], [0.0, 0.0, 1.0]]
    D = [[0.0, 0.0], [0.0, 0.0], [0.7, -0.1], [0.0, 0.05]]
    K = [[0.2, -0.3, 0.05], [0.0, 0.1, -0.4]]            # inputs += K x
    m = mlid.LinearModel(F, G, H, D, Gamma=[[1.0, 0.0], [0.0, 2.0], [0.5, 0.0]], K=K,
                         bx=[0.01, -0.02, 0.0], q=[0.1, 0.1])
    err = mlid.check_jacobians(m, [0.1, -0.3, 0.05], [0.04, -0.2], w=[0.3, -0.7])
    assert max(err.values()) < 1e-7, err


def test_longitudinal_model_with_process_noise():
    m = mlid.LongitudinalModel(
        {"CD": ["1", "V/V0", "alpha", "alpha^2"], "CL": ["1", "alpha", "qhat", "de"],
         "Cm": ["1", "V/V0", "alpha", "alpha^2", "qhat", "de"]},
        {"CD": [0.1, -0.05, 0.23, 0.8], "CL": [-0.2, 3.2, 6.0, 0.3],
         "Cm": [0.13, -0.01, -1.0, -0.4, -27.0, -1.4]},
        dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                        7472.0, 0.0524, 0.792, 1.215])),
        q=[0.01, 1e-4, 0.0, 1e-4])
    err = mlid.check_jacobians(m, [98.0, 0.11, 0.07, -0.02], [-0.03, 1.1e4],
                               w=[0.4, -0.01, 0.0, 0.02])
    assert max(err.values()) < 1e-7, err


@pytest.mark.skipif(not DATA.is_file(), reason="real flight data not found")
@pytest.mark.parametrize("substeps, hold", [(1, "linear"), (2, "linear"), (2, "zoh")])
def test_output_error_sensitivities_match_central_differences(substeps, hold):
    """HFB-320 case 1 at its start values: W(j) d yhat/d theta against central
    differences of yhat, relative to each parameter's largest entry."""
    case = mlid.read_deck(DECK)[0]
    data = case.record()
    model = case.model
    model.substeps = substeps
    model.input_hold = hold
    opts = case.options()
    ev = mlid.evaluate(model, data, **opts)
    free = model.free_indices()
    jac = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), data, **opts)["yhat"],
                            model.theta, free)                   # (nf, nt, ny)
    fd = np.einsum("ij,ktj->itk", np.linalg.inv(ev["rhat"]), np.asarray(jac))
    an = ev["weighted_sensitivity"]
    scale = np.max(np.abs(an), axis=(0, 1))
    assert np.max(np.abs(fd - an) / scale) < 1e-6       # measured 6e-9 to 9e-9
