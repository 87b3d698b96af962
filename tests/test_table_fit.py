"""The two-step route from local fits to tables (issue 46, item 2;
fortran/estimation/fit/mlid_table_fit.f90, python/mlid/estimate/table_fit.py):
the tables recovered from a synthetic campaign within 3 sigma and their sigma
against a Monte Carlo over seeds; the chi-square test naming a manoeuvre
with a wrong sensor bias or a wrong derivative and passing clean campaigns;
an unreached value named; the numbers against an independent computation.
The campaign: tests/table_campaign.py."""

import numpy as np
import pytest
from scipy import stats

import mlid
from mlid.model.tables import Table

import table_campaign as tc

CONDS = tc.grid(5, [0.3, 0.5, 0.7])          # 15 manoeuvres: alpha 0 .. 0.18 x Mach
SEEDS = 100


def labels(n):
    return [f"manoeuvre {k + 1}" for k in range(n)]


@pytest.fixture(scope="module")
def monte_carlo():
    """The clean campaign over SEEDS seeds: each run's values, sigma, the
    manoeuvres it named and its total chi2 (about 4 s)."""
    tabs = tc.tables()
    runs = [mlid.fit_tables(tc.campaign(CONDS, s), tabs, CONDS) for s in range(SEEDS)]
    return tabs, runs


def test_two_step_recovers_every_value_within_3_sigma(monte_carlo):
    tabs, runs = monte_carlo
    truth = tc.true_values(tabs)
    fit = runs[0]
    assert fit.reached.all() and not fit.unreached
    z = (np.asarray(fit.values) - truth) / fit.sigma
    assert np.all(np.abs(z) < 3), z
    np.testing.assert_allclose(fit.table("M_alpha"), tc.MA_TRUTH, atol=4 * fit.sigma.max())
    assert fit.names[:2] == ["M_alpha[1,1]", "M_alpha[2,1]"] and fit.names[8] == "M_q[1]"


def test_sigma_matches_a_monte_carlo_over_seeds(monte_carlo):
    """Measured (100 seeds, 17 values): MC std / mean two-step sigma from
    0.96 to 1.19, mean 1.06; the estimates' mean within 0.45 MC std of the
    truth (measured at most 0.1: unbiased)."""
    tabs, runs = monte_carlo
    values = np.array([np.asarray(r.values) for r in runs])
    sigma = np.array([np.asarray(r.sigma) for r in runs])
    ratio = values.std(axis=0, ddof=1) / sigma.mean(axis=0)
    assert np.all(np.abs(ratio - 1) < 0.25), ratio
    assert abs(ratio.mean() - 1) < 0.1, ratio.mean()
    bias = (values.mean(axis=0) - tc.true_values(tabs)) / values.std(axis=0, ddof=1)
    assert np.all(np.abs(bias) < 3 / np.sqrt(SEEDS) * 1.5), bias


def test_clean_campaigns_pass_at_the_level(monte_carlo):
    """The first clean campaign names no manoeuvre; over all runs the share
    of clean manoeuvres named is the level (measured 12 of 1500), and the
    total chi2's mean its degrees of freedom (measured 58.9 on 58)."""
    _, runs = monte_carlo
    assert runs[0].disagree == [] and runs[0].p_total > 0.01
    named = sum(len(r.disagree) for r in runs) / (SEEDS * len(CONDS))
    assert named < 0.025, named
    dof = runs[0].dof_total
    assert dof == 15 * 5 - (8 + 3 + 2 + 2 + 2)
    assert abs(np.mean([r.chi2_total for r in runs]) - dof) < 3 * np.sqrt(2 * dof / SEEDS)
    assert all(r.dof.tolist() == [5] * 15 for r in runs[:3])


@pytest.mark.parametrize("k", [2, 7, 11])
def test_a_wrong_sensor_bias_is_named(k):
    """Manoeuvre k fitted with its alpha vane's offset held at the deck's
    alpha_trim, 0.03 rad off what the vane reads: named, and no other."""
    res = tc.campaign(CONDS, 0, {k: "bias"})
    fit = mlid.fit_tables(res, tc.tables(), CONDS)
    assert fit.disagree == [f"manoeuvre {k + 1}"], fit.chi2
    assert fit.chi2[k] > fit.limit[k] and fit.p_value[k] < 0.01


@pytest.mark.parametrize("k", [2, 7, 11])
def test_a_wrong_derivative_is_named_first(k):
    """Manoeuvre k flies with M_alpha 10 % off the table: named first (its
    pull on the tables drags some neighbours past the limit too); fitted
    again without it, no manoeuvre disagrees."""
    res = tc.campaign(CONDS, 0, {k: "derivative"})
    fit = mlid.fit_tables(res, tc.tables(), CONDS)
    assert fit.disagree[0] == f"manoeuvre {k + 1}" and np.argmax(fit.chi2) == k
    keep = [j for j in range(len(CONDS)) if j != k]
    again = mlid.fit_tables([res[j] for j in keep], tc.tables(), [CONDS[j] for j in keep])
    assert again.disagree == [], again.chi2


def test_an_unreached_value_is_named():
    """M_q with a breakpoint at alpha = 0.3, beyond every manoeuvre: that
    value is named, NaN, and the others are the fit without it."""
    res = tc.campaign(CONDS, 0)
    plain = mlid.fit_tables(res, tc.tables(), CONDS)
    fit = mlid.fit_tables(res, tc.tables(extra_q_breakpoint=0.3), CONDS)
    assert fit.unreached == ["M_q[4] (alpha = 0.3; weighted where 0.18 < alpha) is reached by "
                             "no manoeuvre: not identifiable"]
    assert np.isnan(fit.values["M_q[4]"]) and np.isnan(fit.sigma["M_q[4]"])
    assert fit.reached.tolist() == [True] * 11 + [False] + [True] * 6
    keep = [n for n in fit.names if n != "M_q[4]"]
    np.testing.assert_allclose(fit.values[keep], plain.values, rtol=1e-12)
    np.testing.assert_allclose(fit.sigma[keep], plain.sigma, rtol=1e-9)
    assert fit.dof_total == plain.dof_total
    assert "not identifiable: reached by no manoeuvre" in fit.text()
    value, sd = fit.curve("M_q", [[0.1], [0.25]])
    assert np.isfinite(value[0]) and np.isnan(value[1]) and np.isnan(sd[1])


def test_the_numbers_against_an_independent_computation():
    """Values, covariance and every chi2 against numpy's generalised least
    squares and pseudo-inverses; p-values and limits against scipy."""
    res = tc.campaign(CONDS, 3, {7: "bias"})
    fit = mlid.fit_tables(res, tc.tables(), CONDS, level=0.05)
    a, theta = fit.weights, fit.theta
    cov = np.zeros((len(theta),) * 2)
    man = np.array([labels(15).index(m) for m, _ in fit.entries])
    for i, r in enumerate(res):
        j = [r.names.index(q) for q in tc.tables()]
        cov[np.ix_(man == i, man == i)] = np.asarray(r.covariance)[np.ix_(j, j)]
    ci = np.linalg.inv(cov)
    p = np.linalg.inv(a.T @ ci @ a)
    v = p @ a.T @ ci @ theta
    np.testing.assert_allclose(fit.values, v, rtol=1e-9)
    np.testing.assert_allclose(fit.covariance, p, rtol=1e-8, atol=1e-14)
    r = theta - a @ v
    np.testing.assert_allclose(fit.residuals, r, atol=1e-10)
    assert fit.chi2_total == pytest.approx(r @ ci @ r, rel=1e-9)
    s = cov - a @ p @ a.T
    for i in range(15):
        m = man == i
        chi2 = r[m] @ np.linalg.pinv(s[np.ix_(m, m)], rcond=1e-9) @ r[m]
        assert fit.chi2[i] == pytest.approx(chi2, rel=1e-7)
    np.testing.assert_allclose(fit.p_value, stats.chi2.sf(fit.chi2, fit.dof), rtol=1e-10)
    np.testing.assert_allclose(fit.limit, stats.chi2.isf(0.05, fit.dof), rtol=1e-10)
    assert fit.p_total == pytest.approx(stats.chi2.sf(fit.chi2_total, fit.dof_total), rel=1e-10)
    # the curve is the interpolation of the values, its sigma w' P w
    value, sd = fit.curve("M_alpha", [[0.09, 0.5]])
    w = np.zeros(8)
    w[[1, 2, 5, 6]] = 0.25
    assert value[0] == pytest.approx(w @ v[:8], rel=1e-12)
    assert sd[0] == pytest.approx(np.sqrt(w @ p[:8, :8] @ w), rel=1e-10)


def test_chi2_tails_far_out_and_at_many_degrees_of_freedom():
    """The core's chi-square tail (series and continued fraction) against
    scipy, from the centre to 1e-200 and from 1 to 400 degrees of freedom,
    through one-estimate manoeuvres at a breakpoint each."""
    rng = np.random.default_rng(1)
    bps = np.arange(6.0)

    class Local:                      # a FitResult's three fields, of a simple estimate
        def __init__(self, x, var):
            self.names, self.estimate, self.covariance = ["c"], np.array([x]), np.array([[var]])

    for n, spread in ((7, 1.0), (60, 3.0), (406, 0.7)):
        conds = [{"a": float(b)} for b in np.resize(bps, n)]
        res = [Local(rng.normal(0, spread), 1.0) for _ in conds]
        fit = mlid.fit_tables(res, {"c": Table("a", bps)}, conds, level=1e-6)
        assert fit.dof_total == n - 6
        assert fit.p_total == pytest.approx(stats.chi2.sf(fit.chi2_total, n - 6), rel=1e-9)
        assert fit.limit_total == pytest.approx(stats.chi2.isf(1e-6, n - 6), rel=1e-9)
    far = [Local(x, 1.0) for x in (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 45.0)]
    fit = mlid.fit_tables(far, {"c": Table("a", bps)}, [{"a": float(b)} for b in
                                                       [0, 1, 2, 3, 4, 5, 5]])
    assert fit.dof.tolist() == [0] * 5 + [1, 1]
    assert fit.p_value[-1] == pytest.approx(stats.chi2.sf(fit.chi2[-1], 1), rel=1e-8)
    assert fit.p_value[-1] < 1e-200                # the two at a = 5 cannot be told apart
    assert sorted(fit.disagree) == ["manoeuvre 6", "manoeuvre 7"]


def test_values_reached_only_in_a_combination_are_refused():
    """Manoeuvres only at alpha = 0.05 and 0.15 on breakpoints 0, 0.1, 0.2:
    three values, two combinations; refused naming them."""
    conds = [{"alpha": 0.05, "Mach": 0.5}, {"alpha": 0.15, "Mach": 0.5}] * 2
    res = [tc.local_fit(c, k) for k, c in enumerate(conds)]
    with pytest.raises(mlid.SingularInformationError,
                       match=r"the values M_q\[1\], M_q\[2\], M_q\[3\] are reached only in a "
                             "fixed combination"):
        mlid.fit_tables(res, {"M_q": Table("alpha", [0.0, 0.1, 0.2])}, conds)


def test_conditions_from_deck_cases_and_renamed_variables():
    """A condition may be a deck case's (its condition: &case alpha_trim,
    mach), the tables' variables mapped to its names."""
    res = tc.campaign(CONDS, 0)

    class Case:                       # what a deck's Case gives: condition
        def __init__(self, c):
            self.condition = {"alpha_trim": c["alpha"], "mach": c["Mach"], "config": "clean"}

    fit = mlid.fit_tables(res, tc.tables(), [Case(c) for c in CONDS],
                          variables={"alpha": "alpha_trim", "Mach": "mach"})
    plain = mlid.fit_tables(res, tc.tables(), CONDS)
    np.testing.assert_array_equal(fit.values, plain.values)
    assert "Consistency of each manoeuvre" in fit.text() and repr(fit).startswith("<TableFit")


def test_the_figure_draws_each_table_with_its_estimates(tmp_path):
    """A panel a table: M_alpha's three Mach curves (the Mach numbers
    flown), 15 local estimates each panel, the disagreeing manoeuvre ringed,
    M_q's unreached breakpoint dashed; written whole."""
    from mlid.report.plots import close, use_file_backend
    from mlid.report.table_fit_plots import table_fit_figure
    use_file_backend()
    res = tc.campaign(CONDS, 0, {7: "bias"})
    fit = mlid.fit_tables(res, tc.tables(extra_q_breakpoint=0.3), CONDS)
    fig = table_fit_figure(fit, tmp_path / "tables.png", quantities=["M_alpha", "M_q"])
    assert (tmp_path / "tables.png").stat().st_size > 10_000
    ax_a, ax_q = fig.axes[:2]
    labels_a = ax_a.get_legend_handles_labels()[1]
    assert [x for x in labels_a if x.startswith("table Mach")] == [
        "table Mach = 0.3", "table Mach = 0.5", "table Mach = 0.7"]
    assert "disagrees (χ² test)" in labels_a
    points = sum(len(c[0].get_xdata()) for c in ax_a.containers)      # the error bars
    assert points == 15
    assert "alpha = 0.3: reached by no manoeuvre" in ax_q.get_legend_handles_labels()[1]
    close(fig)
    with pytest.raises(mlid.InputError, match="no table 'X'"):
        table_fit_figure(fit, quantities=["X"])


DECK_CASE = """&case title = 'short period at alpha {alpha}', job = 'estimate',
    alpha_trim = {alpha}, mach = {mach} /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 1.0, -2.0, -1.0, g = -0.2, -5.0, h = 1, 0, 0, 1, bias = 0, 0,
    free = 'f(1,1)', 'f(2,1)', 'f(2,2)', 'g(1,1)', 'g(2,1)', 'bias(1)', 'bias(2)',
    names = 'Z_alpha', 'M_alpha', 'M_q', 'Z_de', 'M_de', 'b_alpha', 'b_q',
    state_names = 'alpha', 'q', input_names = 'de', output_names = 'alpha', 'q' /
&data file = 'm{k}.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
"""


def test_a_campaign_of_deck_cases(tmp_path):
    """The campaign route: one deck a manoeuvre, its &case alpha_trim and
    mach the condition; the cases run by the core's runner (mlid run's),
    their FitResults and cases into fit_tables: the same tables as the
    Python fits of the same records from the same start (tc.local_model's,
    off the truth)."""
    from mlid.cli.deck import iter_deck
    conds = tc.grid(5, [0.3, 0.7])
    for k, c in enumerate(conds):
        d = tc.record(c, k)
        np.savetxt(tmp_path / f"m{k}.dat", np.column_stack([d.t, d.u, d.y]))
        (tmp_path / f"m{k}.nml").write_text(DECK_CASE.format(alpha=c["alpha"], mach=c["Mach"],
                                                             k=k))
    runs = [next(iter(iter_deck(tmp_path / f"m{k}.nml"))) for k in range(len(conds))]
    assert all(err is None and res.converged for _, _, res, err in runs)
    fit = mlid.fit_tables([res for _, _, res, _ in runs], tc.tables(),
                          [case for case, _, _, _ in runs],
                          variables={"alpha": "alpha_trim", "Mach": "mach"})
    py = mlid.fit_tables([tc.local_fit(c, k) for k, c in enumerate(conds)], tc.tables(), conds)
    np.testing.assert_allclose(fit.values, py.values, rtol=1e-6)
    assert fit.disagree == [] and not fit.unreached
