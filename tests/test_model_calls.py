"""The model layer's core calls on a thread's problem (mlid_api_models: the
layout, manoeuvre map, ties, parameter units, Jacobian check): each sets the
model part it needs, so what an earlier call left in the handle (another
model's record, its results) changes nothing."""

import threading

import numpy as np

import mlid
from mlid.model import models


def _c8_like(nu):
    """A two-state model with nu inputs and fresh sizes (its layout not kept yet)."""
    F = np.array([[-1.0, 1.0], [-2.0, -0.5]])
    return mlid.LinearModel(F, np.ones((2, nu)), np.eye(2), free=["f(1,1)", "g(2,1)"],
                            ties={"f(2,1)": "-4 + 2*f(1,1)"}, r=[1e-4, 1e-4])


def test_a_model_after_another_models_fit_on_the_same_thread():
    truth = _c8_like(1)
    t = np.arange(200) * 0.05
    u = np.where((t > 1) & (t < 2), 1.0, 0.0)[:, None]
    data, _ = mlid.simulate(truth, t, u, seed=1)
    res = mlid.fit(truth, data)               # leaves a record of 1 input in the handle
    models._Layout._cache.clear()
    other = _c8_like(3)                        # a layout of 3 inputs, asked on the model alone
    assert other.tie_terms() == truth.tie_terms()
    assert len(other.param_units(["rad"] * 3, ["rad", "rad/s"])) == other.theta.size
    assert set(mlid.check_jacobians(other, np.zeros(2), np.zeros(3))) >= {"df/dx", "dh/dp"}
    assert res.converged


def test_layouts_made_in_two_threads_are_each_their_own():
    sizes = [1, 2, 3, 4] * 4
    got = {}

    def make(k, nu):
        got[k] = _c8_like(nu).element_names()

    models._Layout._cache.clear()
    threads = [threading.Thread(target=make, args=(k, nu)) for k, nu in enumerate(sizes)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for k, nu in enumerate(sizes):
        assert sum(n.startswith("g(") for n in got[k]) == 2 * nu
