"""The user-model template's worked example and the Jacobian checker."""

import json
import shutil
import subprocess

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import BIN, REPO, c8_truth

TRUTH = [-0.8, -0.1, -4.0, 20.0, -1.2, -6.0]        # Z_a, Z_d, M_a, M_a3, M_q, M_d


@pytest.mark.parametrize("make", [
    lambda: mlid.UserModel(TRUTH),
    lambda: c8_truth(),
    lambda: mlid.LongitudinalModel(
        {"CD": ["1", "V/V0", "alpha", "alpha^2"], "CL": ["1", "alpha", "qhat"],
         "Cm": ["1", "V/V0", "alpha", "alpha^2", "qhat", "de"]},
        {"CD": [0.1, -0.05, 0.23, 0.8], "CL": [-0.2, 3.2, 6.0], "Cm": [0.13, -0.01, -1.0, -0.4,
                                                                     -27.0, -1.4]},
        dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                        7472.0, 0.0524, 0.792, 1.215]))),
], ids=["user", "linear", "longitudinal"])
def test_jacobians_of_every_model_kind(make):
    model = make()
    x = {1: [1.0, 0.1, 0.05, 0.02], 2: [95.0, 0.12, 0.08, 0.03], 3: [0.15, -0.2]}[model.kind]
    u = {1: [0.05], 2: [-0.02, 1.2e4]}[model.nu]
    err = mlid.check_jacobians(model, x, u)
    assert max(err.values()) < 1e-7, err


def test_user_model_fit_recovers_the_cubic_term():
    truth = mlid.UserModel(TRUTH, free=[f"p({k})" for k in range(1, 7)], r=[4e-6, 2.5e-5, 4e-4])
    t = np.arange(401) * 0.02
    u = input_signal("doublet", 0.12, 1.0, 1.0, 0.02, 401)[:, None]
    data, _ = mlid.simulate(truth, t, u, seed=9)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 0.7, 1.0))
    res = mlid.fit(start, data)
    assert res.converged
    z = (res.estimate - np.array(TRUTH)) / res.sigma
    assert np.all(np.abs(z) < 3), z
    assert res.estimate[3] / res.sigma[3] > 5          # the cubic term is clearly there


def test_user_model_deck_in_both_front_ends(tmp_path):
    deck = tmp_path / "cubic.nml"
    shutil.copy(REPO / "cases" / "user_model" / "cubic_short_period.nml", deck)
    outs = []
    for cmd in ([str(BIN / "mlid"), "run", str(deck), "--json", str(tmp_path / "a.json")],
                [str(BIN / "mlid-batch"), str(deck), "--json", str(tmp_path / "b.json")]):
        out = subprocess.run(cmd, capture_output=True, text=True)
        assert out.returncode == 0, out.stderr
        outs.append(json.loads((tmp_path / ("a.json" if len(outs) == 0 else "b.json")).read_text()))
    a, b = outs[0][1], outs[1][1]
    assert a["parameters"] == b["parameters"] == ["Z_a", "Z_d", "M_a", "M_a3", "M_q", "M_d"]
    np.testing.assert_allclose(a["estimate"], b["estimate"], rtol=1e-10, atol=0)


def test_user_model_bad_input():
    with pytest.raises(mlid.InputError, match="6 parameters p, got 2"):
        mlid.UserModel([1.0, 2.0])
    with pytest.raises(mlid.InputError, match="takes no constants"):
        mlid.UserModel(TRUTH, rconst=[1.0])
