"""Several manoeuvres fitted together: shared aerodynamics, each manoeuvre's
own initial state and output biases (python/mlid/model/maneuvers.py, layout_t)."""

import numpy as np
import pytest

import mlid
from conftest import REPO, both_front_ends_json, finite_difference, refused_by_both
from test_hfb320 import COEFFS, _hfb_like, _inputs


def _two_manoeuvres(q=None):
    """Two records of the HFB-like model from different trims, the second
    with an alpha-vane bias."""
    truth = _hfb_like(COEFFS)
    if q is not None:
        truth.q = np.asarray(q, dtype=float)
    t, u = _inputs()
    first, _ = mlid.simulate(truth, t[:300], u[:300], seed=11)
    other = truth.with_theta(truth.theta)
    other.x0 = np.array([98.0, 0.13, 0.12, 0.0])
    other.bias = np.array([0.0, 0.01, 0.0, 0.0, 0.0, 0.0, 0.0])
    u2 = u[:250].copy()
    u2[:, 0] = u2[:, 0] - 0.004
    second, _ = mlid.simulate(other, t[:250], u2, seed=12)
    return truth, other, [first, second]


def test_joint_fit_recovers_the_shared_and_the_own_parameters():
    truth, other, records = _two_manoeuvres()
    free = COEFFS + ["x0(1)", "x0(2)", "x0(3)", "x0(4)", "bias(2)"]
    start = truth.with_free(free)
    start = start.with_theta(np.where(np.arange(start.theta.size) < len(COEFFS),
                                      start.theta * 1.05, start.theta))
    # each manoeuvre from its first measured sample (V, alpha, theta, q), as in practice
    res = mlid.fit(start, records, initial_states=[r.y[0, :4] for r in records],
                   biases=[np.zeros(7), np.zeros(7)])
    assert res.converged
    assert "bias(2)#2" in res.names and "x0(1)#1" in res.names
    want = dict(zip(truth.free_names(), truth.theta[truth.free_indices()]))
    want.update({f"x0({i + 1})#{k + 1}": m.x0[i] for k, m in enumerate((truth, other))
                 for i in range(4)})
    want.update({"bias(2)#1": 0.0, "bias(2)#2": 0.01})
    z = np.array([(e - want[n]) / s for n, e, s in zip(res.names, res.estimate, res.sigma)])
    assert np.all(np.abs(z) < 3), dict(zip(res.names, z))
    # each manoeuvre's model carries its own estimates
    assert res.manoeuvres[1].x0[1] == res.estimate[res.names.index("x0(2)#2")]
    assert res.manoeuvres[0].bias[1] == res.estimate[res.names.index("bias(2)#1")]
    # the shared coefficients are better determined than from either record alone
    alone = [mlid.fit(m.with_free(free), r) for m, r in zip((truth, other), records)]
    k = len(COEFFS)
    assert np.all(res.sigma[:k] < np.minimum(alone[0].sigma[:k], alone[1].sigma[:k]))


def test_joint_gradient_matches_finite_differences():
    truth, other, records = _two_manoeuvres()
    free = COEFFS[:6] + ["x0(1)", "x0(4)", "bias(6)"]
    m = truth.with_free(free)
    x0s, biases = [truth.x0 * 1.01, other.x0 * 0.99], [np.zeros(7), other.bias]
    ev = mlid.evaluate(m, records, initial_states=x0s, biases=biases)
    params = mlid.model.maneuvers.Params(m, 2, x0s, biases)

    def cost(theta):
        p = params.model_of(theta, 0)
        x = [params.model_of(theta, k).x0 for k in range(2)]
        b = [params.model_of(theta, k).bias for k in range(2)]
        return mlid.evaluate(p, records, initial_states=x, biases=b)["cost"]

    fd = finite_difference(cost, params.theta, params.free, rel=1e-4, floor=1e-4,
                           five_point=True)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1.0)
    assert np.max(rel) < 1e-5, dict(zip(params.free_names(), rel))


def test_filter_error_cost_adds_over_manoeuvres():
    """With the noise statistics fixed, each manoeuvre's filter starts anew
    (its own x0, P = 0): the joint cost is the sum of the two."""
    q = [1e-4, 4e-6, 0.0, 4e-5]
    truth, other, records = _two_manoeuvres(q)
    m = truth.with_free(COEFFS)
    joint = mlid.evaluate(m, records, initial_states=[truth.x0, other.x0],
                          biases=[truth.bias, other.bias], method="filter_error")
    one = mlid.evaluate(m, records[0], method="filter_error")
    two = mlid.evaluate(other.with_free(COEFFS), records[1], method="filter_error")
    assert joint["cost"] == pytest.approx(one["cost"] + two["cost"], rel=1e-12)
    np.testing.assert_allclose(joint["information"], one["information"] + two["information"],
                               rtol=1e-6)


def test_equation_error_start_up_on_several_manoeuvres():
    truth, other, records = _two_manoeuvres()
    start = truth.with_free(COEFFS)
    start = start.with_theta(start.theta * np.where(start.free_mask == 1, 1.3, 1.0))
    res = mlid.fit(start, records, initial_states=[truth.x0, other.x0],
                   biases=[truth.bias, other.bias], startup="equation_error")
    assert res.converged
    z = (res.estimate - truth.theta[truth.with_free(COEFFS).free_indices()]) / res.sigma
    assert np.all(np.abs(z) < 3), z


@pytest.mark.parametrize("kwargs, match", [
    ({"initial_states": [np.zeros(4)]}, "one per manoeuvre"),
    ({"biases": [np.zeros(3), np.zeros(3)]}, "each needs 7 values"),
])
def test_bad_manoeuvre_input(kwargs, match):
    truth, other, records = _two_manoeuvres()
    with pytest.raises(mlid.InputError, match=match):
        mlid.fit(truth.with_free(COEFFS), records, **kwargs)
    with pytest.raises(mlid.InputError, match="several manoeuvres"):
        mlid.fit(truth.with_free(COEFFS), records[0], **kwargs)


def test_several_manoeuvres_in_a_deck_through_both_front_ends(tmp_path):
    """&data file = 'a.dat', 'b.dat': two manoeuvres, shared derivatives,
    each its own initial state and bias; both front ends, the same numbers."""
    import json
    import subprocess

    from conftest import BIN
    deck = tmp_path / "two.nml"
    deck.write_text("""
&case title = 'first manoeuvre', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.2, 0.5, -1.0, -2.0, g = 1.5, 0.3,
    h = 1, 0, 0, 1, x0 = 0.2, 0.0 /
&simulate out = 'a.dat', t_end = 3.0, dt = 0.02, seed = 4, noise_std = 0.01, 0.01,
    input_shape = '3211', amplitude = 1.0, t_start = 0.2, pulse_width = 0.2 /
&case title = 'second manoeuvre', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.2, 0.5, -1.0, -2.0, g = 1.5, 0.3,
    h = 1, 0, 0, 1, x0 = -0.1, 0.05, bias = 0.0, 0.03 /
&simulate out = 'b.dat', t_end = 2.0, dt = 0.02, seed = 5, noise_std = 0.01, 0.01,
    input_shape = 'doublet', amplitude = 0.8, t_start = 0.3, pulse_width = 0.4 /
&case title = 'both together', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.0, 0.5, -0.8, -2.0, g = 1.0, 0.3,
    h = 1, 0, 0, 1, free = 'g(1,1)', 'f(1,1)', 'f(2,1)', 'x0(1)', 'x0(2)', 'bias(2)',
    names = 'b1', 'a11', 'a21', 'x0(1)', 'x0(2)', 'bias(2)' /
&data file = 'a.dat', 'b.dat', input_cols = 2, output_cols = 3, 4 /
""")
    res = []
    for cmd, out in (([str(BIN / "mlid"), "run"], "py.json"), ([str(BIN / "mlid-batch")], "fo.json")):
        run = subprocess.run(cmd + [str(deck), "--json", str(tmp_path / out)], capture_output=True,
                             text=True)
        assert run.returncode == 0, run.stderr
        res.append(json.loads((tmp_path / out).read_text())[2])
    a, b = res
    # the order of free; each manoeuvre's own copies after the shared ones
    order = ["b1", "a11", "a21", "x0(1)#1", "x0(2)#1", "bias(2)#1", "x0(1)#2", "x0(2)#2",
             "bias(2)#2"]
    assert a["parameters"] == b["parameters"] == order
    # the Python way, the same order (the core's manoeuvre_places and Params agree)
    import os
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        case = mlid.read_deck(deck)[2]
        api = mlid.fit(case.model, case.record(), **case.options())
    finally:
        os.chdir(here)
    assert api.names == order
    np.testing.assert_allclose(api.estimate, a["estimate"], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(a["estimate"], b["estimate"], rtol=1e-10, atol=1e-14)
    est = dict(zip(a["parameters"], a["estimate"]))
    sig = dict(zip(a["parameters"], a["sigma"]))
    for name, truth in (("a11", -1.2), ("a21", -1.0), ("b1", 1.5), ("x0(1)#1", 0.2),
                        ("x0(1)#2", -0.1), ("x0(2)#2", 0.05), ("bias(2)#2", 0.03)):
        assert abs(est[name] - truth) < 4 * sig[name], (name, est[name], sig[name])


MANOEUVRE_DECK = """&case title = 'manoeuvre channel', job = 'estimate' /
&model kind = 'linear', nx = 1, nu = 2, ny = 1, f = -1, g = 1, 0, h = 1,
    free = 'f(1,1)', 'g(1,2)' /
&data file = 'a.dat', 'b.dat', 'a.dat', columns = 't', 'u', 'y', time_col = 't',
    derived = 'k = manoeuvre', 'last = step(manoeuvre - 2.5)',
    input_cols = 'u', 'last', output_cols = 'y' /
"""


def test_each_file_carries_its_place_in_the_list(tmp_path):
    """The channel 'manoeuvre' is a file's place in the case's list (a
    file listed twice is two manoeuvres), for indicator channels of
    per-manoeuvre parameters; a file that has a column of that name is
    refused in one line, in both front ends."""
    t = np.arange(50) * 0.1
    for name in ("a", "b"):
        np.savetxt(tmp_path / f"{name}.dat", np.column_stack([t, np.sin(t), np.cos(t)]))
    (tmp_path / "m.nml").write_text(MANOEUVRE_DECK)
    case = mlid.read_deck(tmp_path / "m.nml")[0]
    records = case.record()
    assert [list(np.unique(r.u[:, 1])) for r in records] == [[0.0], [0.0], [1.0]]
    (tmp_path / "bad.nml").write_text(MANOEUVRE_DECK.replace("'t', 'u', 'y'",
                                                             "'t', 'u', 'manoeuvre'").replace(
        "output_cols = 'y'", "output_cols = 'manoeuvre'"))
    refused_by_both(tmp_path / "bad.nml", "column manoeuvre: the name manoeuvre is reserved",
                    cwd=tmp_path)


def test_a_held_out_file_keeps_its_number_in_both_front_ends(tmp_path):
    """validate splits the files into fitted and held out; each keeps its
    place in the deck's list as its manoeuvre number (mlid-batch used to
    number the split lists)."""
    t = np.arange(80) * 0.1
    u = np.sin(t)
    for k, name in enumerate(("a", "b", "c")):
        x = np.zeros(80)
        for j in range(1, 80):                 # xdot = -x + u + 0.1 in the third file only
            x[j] = x[j - 1] + 0.1 * (-x[j - 1] + u[j - 1] + (0.1 if k == 2 else 0.0))
        np.savetxt(tmp_path / f"{name}.dat", np.column_stack([t, u, x]))
    (tmp_path / "v.nml").write_text(
        "&case title = 'holdout numbering', job = 'validate' /\n"
        "&model kind = 'linear', nx = 1, nu = 2, ny = 1, f = -1, g = 1, 0, h = 1,\n"
        "    free = 'f(1,1)', 'g(1,2)' /\n"
        "&data file = 'a.dat', 'b.dat', 'c.dat', columns = 't', 'u', 'y', time_col = 't',\n"
        "    derived = 'm3 = step(manoeuvre - 2.5)', input_cols = 'u', 'm3', output_cols = 'y',\n"
        "    holdout = 2 /\n")
    fit = both_front_ends_json(tmp_path / "v.nml", tmp_path)
    k = fit["parameters"].index("g(1,2)")
    assert abs(fit["estimate"][k] - 0.1) < 0.01


def test_a_case_without_data_files_says_so():
    case = mlid.read_deck(REPO / "cases" / "c8_short_period" / "c8.nml")[0]
    with pytest.raises(mlid.MlidError, match="has no data file 1"):
        case.record()
