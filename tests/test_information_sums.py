"""The output-error gradient and information (mlid_likelihood's
segment_information: each output over the columns that move it, or all
outputs stacked when every column moves every output) against the same sums
made in numpy from the weighted sensitivities it returns, those against
central differences of the predictions, and the exact zeros where a
parameter does not move an output.  A column that moves an output at one
sample only (an input that is zero but at one sample) must be found
wherever that sample falls in the scan."""

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import finite_difference

F = [[-3.5, 0.47], [-0.09, -0.17]]
G = [[-4.9, 0.73, -4.3], [-0.19, -0.75, 1.55]]
# outputs ay, p, r: h(1, :) and d(1, :) move ay alone, bias(k) output k alone
H = [[0.04, 2.1], [1.0, 0.0], [0.0, 1.0]]
D = [[0.74, 2.28, -5.2], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
SPARSE = ["f(1,1)", "f(1,2)", "f(2,1)", "f(2,2)", "g(1,1)", "g(2,2)", "h(1,1)", "h(1,2)",
          "d(1,1)", "d(1,2)", "bias(1)", "bias(2)", "bias(3)"]
# every one moves every output (p and r through the coupled states)
DENSE = ["f(1,1)", "f(1,2)", "f(2,1)", "f(2,2)", "g(1,1)", "g(2,1)", "g(1,3)"]
STD = [0.05, 0.01, 0.01]
NT = 203                      # not a multiple of the scan's four samples


def _record(pulse_at, seed=3, drop_ay=False):
    """Inputs: a doublet on u1, u3 a sine, u2 zero but at one sample."""
    dt = 0.04
    t = np.arange(NT) * dt
    u = np.zeros((NT, 3))
    u[:, 0] = input_signal("doublet", 0.05, 1.0, 0.5, dt, NT)
    u[:, 2] = 0.02 * np.sin(1.3 * t)
    u[pulse_at, 1] = 0.03
    n = 1 if drop_ay else 0
    truth = mlid.LinearModel(F, G, H[n:], D[n:], bias=[0.01, -0.002, 0.001][n:])
    data, _ = mlid.simulate(truth, t, u, STD[n:], seed=seed)
    return data


def _model(free, drop_ay=False):
    h, d = np.array(H), np.array(D)
    if drop_ay:
        h, d = h[1:], d[1:]
    return mlid.LinearModel(np.array(F) * 1.1, G, h, d, free=free)


def _check_sums(model, data, **opts):
    """information = sum_j dy' W dy and gradient = -sum_j dy' W nu from the
    returned W dy (dy = R-hat W dy), each entry to rounding."""
    ev = mlid.evaluate(model, data, **opts)
    ws = ev["weighted_sensitivity"]                        # (ny, nt, nf)
    dy = np.einsum("ip,pjk->ijk", ev["rhat"], ws)
    y = np.vstack([r.y for r in data]) if isinstance(data, list) else data.y
    nu = (y - ev["yhat"]).T                               # (ny, nt)
    info = np.einsum("ijk,ijl->kl", dy, ws)
    grad = -np.einsum("ijk,ij->k", ws, nu)
    d = np.sqrt(np.outer(np.diag(info), np.diag(info)))
    assert np.max(np.abs(ev["information"] - info) / d) < 1e-12
    assert np.max(np.abs(ev["gradient"] - grad) / np.sqrt(np.diag(info))) < 1e-12
    np.testing.assert_array_equal(ev["information"], ev["information"].T)
    return ev, dy


@pytest.mark.parametrize("pulse_at", [NT - 1, 101])
@pytest.mark.parametrize("noise", ["diagonal", "full"])
def test_sparse_columns(pulse_at, noise):
    data = _record(pulse_at)
    model = _model(SPARSE)
    ev, dy = _check_sums(model, data, noise=noise)
    free = model.free_indices()
    jac = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), data,
                                                     noise=noise)["yhat"],
                            model.theta, free)                   # (nf, nt, ny)
    fd = np.transpose(jac, (2, 1, 0))
    scale = np.max(np.abs(dy), axis=(0, 1))
    assert np.max(np.abs(fd - dy) / scale) < 1e-6
    names = model.free_names()
    ws = ev["weighted_sensitivity"]
    if noise == "diagonal":          # W = R^-1 diagonal: exact zeros where nothing moves
        for k, name in enumerate(names):
            if name.startswith(("h(1", "d(1")):
                assert not ws[1:, :, k].any(), name
            if name.startswith("bias"):
                out = int(name[5]) - 1
                assert not np.delete(ws[:, :, k], out, axis=0).any(), name
    # u2's one sample: d(1,2) moves ay there, g(2,2) the states from there on
    k = names.index("d(1,2)")
    assert np.flatnonzero(dy[0, :, k]).tolist() == [pulse_at]
    assert ev["information"][k, k] > 0
    k = names.index("g(2,2)")
    assert np.flatnonzero(dy[1, :, k])[0] == pulse_at


def test_sparse_columns_gradient_is_the_costs():
    """At R-hat the gradient is the concentrated cost's (R re-estimated)."""
    data = _record(NT - 1)
    model = _model(SPARSE)
    ev = mlid.evaluate(model, data)
    free = model.free_indices()
    fd = finite_difference(lambda th: mlid.evaluate(model.with_theta(th), data)["cost"],
                           model.theta, free, five_point=True)
    assert np.max(np.abs(fd - ev["gradient"]) / np.sqrt(np.diag(ev["information"]))) < 1e-5


def test_sparse_columns_over_two_manoeuvres():
    """Each manoeuvre's biases move its own samples' outputs only."""
    data = [_record(NT - 1, seed=3), _record(50, seed=4)]
    model = _model(SPARSE)
    ev, _ = _check_sums(model, data, biases=[np.zeros(3), np.zeros(3)])
    ws = ev["weighted_sensitivity"]
    assert ws.shape[2] == len(SPARSE) - 3 + 6
    for k in range(ws.shape[2] - 6, ws.shape[2]):        # bias(1)#1 .. bias(3)#2
        out, man = (k - ws.shape[2] + 6) % 3, (k - ws.shape[2] + 6) // 3
        moved = np.zeros(ws.shape[:2], bool)
        moved[out, man * NT:(man + 1) * NT] = True
        assert not ws[:, :, k][~moved].any()
        assert ws[:, :, k][moved].all()


@pytest.mark.parametrize("noise", ["diagonal", "full"])
def test_every_column_moves_every_output(noise):
    data = _record(80, drop_ay=True)
    model = _model(DENSE, drop_ay=True)
    _check_sums(model, data, noise=noise)


@pytest.mark.parametrize("noise", ["diagonal", "full"])
def test_information_does_not_depend_on_an_outputs_units(noise):
    """An output in units 1e7 times larger (its noise too: residual variance
    1e14 times the other's) moves nothing: the information and gradient are
    the same.  A weight factor cut off against the largest entry of R^-1
    used to drop that output from both without a word."""
    f = [[-3.5, 0.47], [-0.09, -0.17]]
    g = [[-4.9], [-0.19]]
    nt, dt = 200, 0.04
    t = np.arange(nt) * dt
    u = input_signal("doublet", 0.05, 1.0, 0.5, dt, nt).reshape(-1, 1)
    got = []
    for scale in (1.0, 1.0e7):
        h = [[scale, 0.0], [0.0, 1.0]]
        data, _ = mlid.simulate(mlid.LinearModel(f, g, h), t, u, [1e-3 * scale, 1e-3], seed=1)
        m = mlid.LinearModel(np.array(f) * 1.1, g, h, free=["f(1,1)", "f(1,2)", "g(1,1)"])
        got.append(mlid.evaluate(m, data, noise=noise))
    a, b = got
    assert np.allclose(b["information"], a["information"], rtol=1e-6, atol=0)
    assert np.allclose(b["gradient"], a["gradient"], rtol=1e-6, atol=1e-9 * np.abs(a["gradient"]).max())
