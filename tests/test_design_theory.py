"""The report's input-design theory (§7.4.2 Levadi, §7.4.3 second order, §7.6
state penalty) against mlid's numerical design, and the case
cases/design_theory tells what its README says."""

import sys

import numpy as np
import pytest

import mlid
from mlid.design import closed_forms as cf
from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "design_theory"))
import design_theory  # noqa: E402

C8_F = np.array([[-1.588, -0.562], [1.0, -0.737]])
C8_G = np.array([[-1.66], [0.005]])
C8_UNKNOWNS = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "g(2,1)"]


def test_levadi_closed_form_limits():
    """a -> inf with 2c/a = r gives §7.4.1 (the report's remark); the printed
    eq. 7.65 root is another frequency with a smaller mu."""
    lim = cf.levadi(1e5, 0.5e5, 1.0)
    first = cf.first_order(1.0)
    assert lim.omega[0] == pytest.approx(first.omega[0], abs=1e-4)
    assert lim.mu * 1.0 == pytest.approx(first.mu, rel=1e-4)
    ours, printed = cf.levadi(3.0, 1.0, 2.0), cf.levadi(3.0, 1.0, 2.0, printed=True)
    assert printed.mu < 0.9 * ours.mu
    with pytest.raises(mlid.InputError):
        cf.levadi(0.5, 1.0, 2.0)


def test_levadi_by_the_kalman_route():
    """The noise as a state, white measurement noise r -> 0: mu converges to
    our closed form as sqrt(r), not to the printed equation's."""
    a, c, T = 3.0, 1.0, 2.0
    ours = cf.levadi(a, c, T)
    mus = [design_theory.levadi_design(a, r).mu_max(T, cells=200) for r in (1e-4, 1e-6)]
    err = [m / ours.mu - 1 for m in mus]
    assert -3e-3 < err[0] < 0 and -3e-4 < err[1] < 0           # below, O(sqrt r)
    assert abs(err[0] / err[1] - 10) < 2                       # sqrt(100) = 10
    assert abs((10 * mus[1] - mus[0]) / 9 / ours.mu - 1) < 2e-5


def test_stiff_cells_are_exact():
    """A fast filter pole (|F_A| h >> 1) no longer wrecks the operator: the
    same mu on 10 and 200 cells within the cells' own O(h^2)."""
    d = design_theory.levadi_design(0.5, 1e-6)
    coarse, fine = d.mu_max(2.0, cells=10), d.mu_max(2.0, cells=200)
    assert 0.98 < coarse < 1.0 and 0.99 < fine < 1.0


@pytest.mark.parametrize("T", [1.0, 4.0, 8.0])
def test_second_order_closed_form(T):
    """§7.4.3: operator, Riccati secant and both critical lengths against
    the closed form; w1 w2 = -a2 and they bracket the natural frequency."""
    a1, a2, r = design_theory.A1, design_theory.A2, design_theory.R_Q
    cfm = cf.second_order(a1, a2, r, T)
    w1, w2 = cfm.omega
    assert w1 * w2 == pytest.approx(-a2, rel=1e-12)
    assert w1 < np.sqrt(-a2) < w2
    assert cfm.mu < 1.0 / (r * a1**2)
    d = mlid.InputDesign([[a1, 1.0], [a2, 0.0]], [[-1.66], [0.0]], [[1.0, 0.0]], [[r]],
                         ["g(1,1)"])
    assert d.mu_max(T) == pytest.approx(cfm.mu, rel=1e-7)
    assert d.mu_max(T, method="riccati") == pytest.approx(cfm.mu, rel=1e-6)
    assert d.critical_length(cfm.mu, tmax=4 * T) == pytest.approx(T, rel=1e-5)
    assert d.critical_length(cfm.mu, "transition", tmax=4 * T)[0] == pytest.approx(T, rel=1e-7)
    errs = []
    for n in (50, 100):
        inp = d.optimal_input(T, 2.0, cells=n)
        ref = cfm.input(inp.t, 2.0)
        errs.append(np.max(np.abs(inp.u[:, 0] - ref)) / np.max(np.abs(ref)))
        assert 0 < 1 - inp.M[0, 0] / (2.0 * cfm.mu) < 2e-3       # a step input loses O(h^2)
    assert errs[1] < 3e-3 and errs[0] / errs[1] == pytest.approx(4, rel=0.05)     # O(h^2)


def test_state_penalty_is_the_criterion_it_says():
    """mu E of the penalised operator equals tr M - k int alpha^2 dt of its
    input, computed from sampled states; the penalty lowers int alpha^2 and
    its mu has critical length T by the Riccati and transition methods."""
    d = mlid.InputDesign(C8_F, C8_G, np.eye(2), np.diag([0.02, 0.04]), C8_UNKNOWNS)
    T, E, k = 4.0, 311.0, 80.0
    free = d.optimal_input(T, E)
    pen = d.state_penalised(T, E, [0.0, k])
    crit = pen.summary["trace"] - k * d.state_integral(T, pen.u)[1, 1]
    assert pen.mu * E == pytest.approx(crit, rel=5e-5)
    assert pen.mu < free.mu and pen.summary["trace"] < free.summary["trace"]
    assert d.state_integral(T, pen.u)[1, 1] < 0.7 * d.state_integral(T, free.u)[1, 1]
    assert d.penalised_length(pen.mu, np.diag([0.0, k])) == pytest.approx(T, rel=1e-5)
    assert d.penalised_length(pen.mu, [0.0, k], "transition")[0] == pytest.approx(T, rel=1e-6)
    zero = d.state_penalised(T, E, [0.0, 0.0])
    assert zero.mu == pytest.approx(free.mu, rel=1e-12)
    with pytest.raises(mlid.InputError, match="semi-definite"):
        d.state_penalised(T, E, [0.0, -1.0])
    with pytest.raises(mlid.InputError, match="one weight per state"):
        d.state_penalised(T, E, [1.0, 2.0, 3.0])


def test_response_is_the_model():
    """The response of a step into x' = -x + u is 1 - exp(-t)."""
    d = mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]], ["g(1,1)"])
    t, x = d.response(2.0, np.ones(10))
    np.testing.assert_allclose(x[:, 0], 1 - np.exp(-t), atol=1e-13)
    assert d.state_integral(2.0, np.ones(10))[0, 0] == pytest.approx(
        2.0 - 2 * (1 - np.exp(-2.0)) + 0.5 * (1 - np.exp(-4.0)), rel=1e-6)


def test_design_theory_case():
    out = design_theory.run()
    lev = out["levadi"]
    assert abs(lev["mu extrapolated"] / lev["closed"].mu - 1) < 1e-4
    assert abs(lev["mu extrapolated"] / lev["printed"].mu - 1) > 0.1
    narrow = lev["narrow"]                    # mu -> 1/(2ac) and w grows as r -> 0
    assert all(m < lev["narrow sup"] for _, m, _ in narrow)
    assert narrow[0][1] < narrow[1][1] < narrow[2][1] and narrow[0][2] < narrow[1][2] < narrow[2][2]
    for row in out["second order"]["rows"]:
        assert abs(row["operator"] / row["closed"].mu - 1) < 1e-7
    pen = out["penalty"]
    for k, mue, crit in pen["checks"]:
        assert abs(mue / crit - 1) < 2e-4
    rows = {row["k"]: row["summary"] for row in pen["rows"]}
    # at the same |alpha| limit the penalised designs beat the energy rescaling
    assert rows[80.0]["det"] > 5 * rows[0.0]["det"]
    assert np.all(rows[80.0]["sigma"] < rows[0.0]["sigma"])
