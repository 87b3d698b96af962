"""The estimator options of report §4.6: a priori weighting, bounds,
rank-deficient solutions (and fixed parameters, which are just not free)."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, c8_record, c8_start, c8_truth, run_both


@pytest.fixture(scope="module")
def data():
    return c8_record()


def test_prior_weight_zero_changes_nothing_and_large_weight_pins(data):
    plain = mlid.fit(c8_start(), data)
    zero = mlid.fit(c8_start(), data, prior_weight={"M_q": 0.0})
    np.testing.assert_allclose(zero.estimate, plain.estimate, rtol=1e-9)
    pinned = mlid.fit(c8_start(), data, prior={"M_q": -1.6}, prior_weight={"M_q": 1e12})
    assert pinned.estimate[pinned.names.index("M_q")] == pytest.approx(-1.6, abs=1e-5)


def test_prior_optimum_balances_likelihood_and_prior(data):
    w = 400.0
    res = mlid.fit(c8_start(), data, prior={"M_alpha": -0.3}, prior_weight={"M_alpha": w})
    k = res.names.index("M_alpha")
    # at the optimum the likelihood gradient cancels the prior's pull
    g = mlid.evaluate(res.model, data)["gradient"]
    assert g[k] == pytest.approx(-w * (res.estimate[k] + 0.3), rel=1e-3, abs=1e-3)
    assert res.estimate[k] > mlid.fit(c8_start(), data).estimate[k]       # pulled toward -0.3
    # the information includes the prior weight, so sigma shrinks
    assert res.sigma[k] < mlid.fit(c8_start(), data).sigma[k]


def test_bounds_hold_the_estimate_on_the_bound(data):
    free = mlid.fit(c8_start(), data)
    k = free.names.index("M_q")
    lower = free.estimate[k] + 3 * free.sigma[k]    # above the optimum, below the start
    res = mlid.fit(c8_start(), data, bounds={"M_q": (lower, None)})
    assert res.estimate[k] == pytest.approx(lower, abs=1e-12)
    assert res.converged


def test_a_fits_bounds_and_prior_are_its_own(data):
    """The extras go to the one fit they are given with (mlid_set_extras):
    the next fit on the same thread, without them, is the plain fit."""
    free = mlid.fit(c8_start(), data)
    k = free.names.index("M_q")
    lower = free.estimate[k] + 3 * free.sigma[k]
    mlid.fit(c8_start(), data, bounds={"M_q": (lower, None)},
             prior={"M_q": -1.6}, prior_weight={"M_q": 1e12})
    after = mlid.fit(c8_start(), data)
    np.testing.assert_array_equal(after.estimate, free.estimate)
    np.testing.assert_array_equal(after.sigma, free.sigma)


def test_a_parameter_a_rounding_error_off_its_bound_does_not_stall_the_others(data):
    """The step would carry M_q across its bound from 1e-13 (relative) above
    it: M_q goes to the bound and the others take their full step.  (Scaling
    the whole step to the bound made every step vanish: a false convergence
    at the start.)  The fit then equals the one with M_q fixed at the bound."""
    free = mlid.fit(c8_start(), data)
    k = free.names.index("M_q")
    lower = free.estimate[k] + 3 * free.sigma[k]
    start = c8_start().with_theta(c8_start().theta)
    th = start.theta.copy()
    th[start.free_indices()[k]] = lower * (1 + 1e-13) if lower > 0 else lower * (1 - 1e-13)
    start = start.with_theta(th)
    res = mlid.fit(start, data, bounds={"M_q": (lower, None)})
    held = start.with_theta(np.where(np.arange(th.size) == start.free_indices()[k],
                                     lower, th))
    fixed = mlid.fit(held.with_free([n for n in start.free if n != start.free[k]]), data)
    assert res.converged and res.iterations > 1
    others = [j for j in range(len(res.names)) if j != k]
    assert np.allclose(res.estimate[others], fixed.estimate, rtol=0, atol=1e-3 * fixed.sigma.min())


def test_rank_deficient_solution_handles_a_singular_direction():
    model = mlid.LinearModel([[-1.0, 0.5], [0.0, -2.0]], [[1.0], [0.0]], np.eye(2),
                             free=["f(1,1)", "f(1,2)", "g(1,1)"])
    t = np.arange(200) * 0.02
    data, _ = mlid.simulate(model, t, np.sin(3 * t)[:, None], [0.01, 0.01], seed=3)
    with pytest.raises(mlid.SingularInformationError):
        mlid.fit(model, data)
    res = mlid.fit(model, data, rank_min=1)
    assert res.rank <= 2                                     # the null direction left out
    assert f"rank-deficient solution: rank {res.rank} of 3" in res.report()
    k = res.names.index("f(1,1)")
    assert abs(res.estimate[k] + 1.0) < 3 * res.sigma[k]


@pytest.mark.parametrize("rule", ["iteration", "staged"])
def test_rank_search_on_a_well_determined_case_stays_near_the_full_solution(data, rule):
    # a direction is left out only when freeing it would lower the cost by less than
    # 1.92 = delta^2/2 (the 5% likelihood-ratio test), delta in sigma units, so the
    # estimate stays within 1.96 sigma of the full-rank solution
    plain = mlid.fit(c8_start(), data)
    ranked = mlid.fit(c8_start(), data, rank_min=3, rank_rule=rule)
    assert 3 <= ranked.rank <= 5
    assert np.all(np.abs(ranked.estimate - plain.estimate) < 1.96 * plain.sigma)


@pytest.mark.parametrize("kwargs, match", [
    ({"bounds": {"M_q": (-1.0, -2.0)}}, "'M_q': lower bound above upper bound"),
    ({"bounds": {"M_q": (-0.5, 0.0)}}, "'M_q': start value outside its bounds"),
    ({"bounds": {"M_q": (np.nan, None)}}, "^'M_q': lower bound is not a number$"),
    ({"bounds": {"M_q": (-2.0, float("nan"))}}, "^'M_q': upper bound is not a number$"),
    ({"bounds": {"M_q": (None, -np.inf)}}, r"^'M_q': upper bound is -Inf \(no value lies below"),
    ({"bounds": {"M_q": (np.inf, None)}}, r"^'M_q': lower bound is \+Inf \(no value lies above"),
    ({"bounds": {"M_q": (-2.0, "0")}}, "must be a pair .lower, upper. of numbers or None"),
    ({"prior_weight": np.diag([1.0, -1.0, 1.0, 1.0, 1.0])}, "positive semi-definite"),
    ({"rank_min": 6}, "larger than the 5 free parameters"),
    ({"rank_min": 4, "rank_max": 3}, "below rank_min"),
    ({"rank_min": 3, "rank_rule": "greedy"}, "rank_rule must be one of"),
    ({"prior_weight": {"f(1,1)": 1.0}}, "not a free parameter"),
])
def test_bad_options(data, kwargs, match):
    with pytest.raises(mlid.InputError, match=match):
        mlid.fit(c8_start(), data, **kwargs)


def test_infinite_bounds_bound_nothing(data):
    plain = mlid.fit(c8_start(), data)
    res = mlid.fit(c8_start(), data, bounds={"M_q": (-np.inf, np.inf), "M_alpha": (None, np.inf)})
    assert np.array_equal(res.estimate, plain.estimate)
    # numpy scalars and 0-d arrays are numbers too
    res = mlid.fit(c8_start(), data, bounds={"M_q": (np.array(-np.inf), np.float64(np.inf))})
    assert np.array_equal(res.estimate, plain.estimate)


@pytest.mark.parametrize("bounds, message", [
    ("lower(1) = NaN", "'M_q': lower bound is not a number"),
    ("upper(1) = nan", "'M_q': upper bound is not a number"),
    ("lower = -1.0, NaN", "'M_alpha': lower bound is not a number"),
    ("upper(1) = -Inf", "'M_q': upper bound is -Inf (no value lies below it)"),
    ("lower(1) = +Infinity", "'M_q': lower bound is +Inf (no value lies above it)"),
    ("lower(1) = -1.0, upper(1) = -2.0", "'M_q': lower bound above upper bound"),
])
def test_bad_bounds_in_decks_are_one_line_in_both_front_ends(tmp_path, bounds, message):
    """A NaN bound was dropped by mlid run and called 'above the upper
    bound' by mlid-batch; now both say the core's one line."""
    data = tmp_path / "d.dat"
    np.savetxt(data, np.column_stack([np.arange(20) * 0.1, np.ones(20), np.zeros(20)]))
    deck = tmp_path / "b.nml"
    deck.write_text(f"""&case title = 'bounds', job = 'estimate' /
&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1.0, g = 1.0, h = 1,
    free = 'f(1,1)', 'g(1,1)', names = 'M_q', 'M_alpha' /
&data file = 'd.dat', input_cols = 2, output_cols = 3 /
&estimate {bounds} /
""")
    runs = run_both(deck, cwd=tmp_path)
    for run in runs:
        assert run.returncode == 1, run.stderr
        assert run.stderr.splitlines()[0].endswith("'bounds': " + message), run.stderr
    assert runs[0].stderr.split(":", 1)[1] == runs[1].stderr.split(":", 1)[1]


def test_every_parameter_fixed(data):
    with pytest.raises(mlid.InputError, match="every parameter is fixed"):
        mlid.fit(c8_truth().with_free([]), data)


def test_options_through_decks_in_both_front_ends(tmp_path):
    deck = tmp_path / "opts.nml"
    deck.write_text("""
&case title = 'make data', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.2, 0.5, -1.0, -2.0, g = 1.5, 0.3,
    h = 1, 0, 0, 1 /
&simulate out = 'd.dat', t_end = 4.0, dt = 0.02, seed = 4, noise_std = 0.01, 0.01,
    input_shape = '3211', amplitude = 1.0, t_start = 0.2, pulse_width = 0.2 /
&case title = 'options', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2, f = -1.0, 0.5, -0.8, -2.0, g = 1.0, 0.3,
    h = 1, 0, 0, 1, free = 'g(1,1)', 'f(1,1)', 'f(2,1)' /
&data file = 'd.dat', input_cols = 2, output_cols = 3, 4 /
&estimate prior(1) = 1.4, prior_weight(1) = 50.0, lower = -10, -10, -0.95, rank_min = 2,
    rank_rule = 'staged' /
""")
    res = []
    for cmd, out in (([str(BIN / "mlid"), "run"], "a.json"), ([str(BIN / "mlid-batch")], "b.json")):
        run = subprocess.run(cmd + [str(deck), "--json", str(tmp_path / out)], capture_output=True,
                             text=True)
        assert run.returncode == 0, run.stderr
        assert "rank-deficient solution: rank" in run.stdout
        res.append(json.loads((tmp_path / out).read_text())[1])
    np.testing.assert_allclose(res[0]["estimate"], res[1]["estimate"], rtol=1e-10, atol=0)
    assert res[0]["estimate"][res[0]["parameters"].index("f(2,1)")] >= -0.95  # the bound holds
