"""Optimal input design (fortran/design/mlid_design.f90, python/mlid/design/input_design.py)
against the closed form of report §7.4.1 and the C-8 numbers of CASES.md §1."""

import numpy as np
import pytest

import mlid

C8_F = [[-1.588, -0.562], [1.0, -0.737]]
C8_G = [[-1.66], [0.005]]
C8_R = np.diag([0.02, 0.04])
C8_UNKNOWNS = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "g(2,1)"]


def first_order():
    """x' = -x + theta u, y = x, r = 1, theta unknown (report §7.4.1)."""
    return mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]], ["g(1,1)"])


def closed_form(T):
    """omega: smallest positive root of tan(omega T) = -omega; mu = 1/(1+omega^2)."""
    lo, hi = np.pi / (2 * T) + 1e-12, np.pi / T
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.tan(mid * T) + mid < 0:
            lo = mid
        else:
            hi = mid
    omega = 0.5 * (lo + hi)
    return omega, 1.0 / (1.0 + omega**2)


@pytest.mark.parametrize("T", [1.0, 3.0])
def test_three_solvers_agree_with_the_closed_form(T):
    d = first_order()
    omega, mu = closed_form(T)
    if T == 1.0:
        assert omega == pytest.approx(2.028758, abs=1e-6) and mu == pytest.approx(0.195471, abs=1e-6)
    assert d.mu_max(T) == pytest.approx(mu, abs=1e-7)                       # operator
    assert d.mu_max(T, method="riccati") == pytest.approx(mu, abs=1e-6)      # secant, eq. 7.89
    assert d.critical_length(mu, "riccati") == pytest.approx(T, rel=1e-5)
    Tt, lam0 = d.critical_length(mu, "transition")
    assert Tt == pytest.approx(T, rel=1e-7)


def test_optimal_input_is_the_report_shape():
    """u* ~ sin(omega t) + omega cos(omega t) (§7.4.1), from both the operator
    and the costate of the transition method; M = mu E."""
    T, E = 1.0, 2.0
    omega, mu = closed_form(T)
    d = first_order()
    for method in ("operator", "transition"):
        inp = d.optimal_input(T, E, cells=200, method=method)
        shape = np.sin(omega * inp.t) + omega * np.cos(omega * inp.t)
        shape *= np.sqrt(E / (np.sum(shape**2) * (T / len(shape))))
        assert np.max(np.abs(inp.u[:, 0] - shape)) < 1e-3 * np.max(np.abs(shape)), method
        assert inp.M[0, 0] == pytest.approx(mu * E, rel=1e-4)


def test_c8_against_the_recomputed_numbers():
    """CASES.md §1, 'recomputed' column, within 1% (det M at T = 0.77 s: 1.3%)."""
    d = mlid.InputDesign(C8_F, C8_G, np.eye(2), C8_R, C8_UNKNOWNS)
    mu = d.mu_max(4.0)
    assert mu == pytest.approx(65.89, rel=0.01)
    inp = d.optimal_input(4.0, 311.0)
    s = inp.summary
    assert s["trace"] == pytest.approx(mu * 311.0, rel=1e-4)
    assert s["det"] == pytest.approx(1.10e15, rel=0.01)
    np.testing.assert_allclose(s["sigma"], [0.1625, 0.0622, 0.0348, 0.0934, 0.0247], rtol=0.01)
    assert s["spread"] == pytest.approx(438, rel=0.01)
    short = d.optimal_input(0.77, 62.61).summary
    assert short["trace"] == pytest.approx(612.7, rel=0.01)
    assert short["det"] == pytest.approx(7.46e3, rel=0.015)
    np.testing.assert_allclose(short["sigma"][:2], [2.05, 5.65], rtol=0.01)
    best, ratios = d.equalised(0.77, 62.61, iterations=12)
    assert ratios[-1] < 1.01 < ratios[0]
    assert best.summary["det"] == pytest.approx(2.30e4, rel=0.02)
    np.testing.assert_allclose(best.summary["sigma"][:2], [1.57, 4.20], rtol=0.01)
    changed = d.with_model(F=[[-1.429, -0.613], [1.0, -0.663]])
    assert changed.critical_length(mu) == pytest.approx(3.15, rel=0.01)


def test_information_of_any_input_matches_a_second_computation():
    """The design's M of a doublet against output sensitivities from the
    simulator by central differences, integrated by the trapezoid rule."""
    d = mlid.InputDesign(C8_F, C8_G, np.eye(2), C8_R, C8_UNKNOWNS)
    T, n = 4.0, 400
    u = np.where(np.arange(n) < n // 2, 1.0, -1.0)[:, None]
    M = d.information(T, u)
    dt = T / n
    model = mlid.LinearModel(C8_F, C8_G, np.eye(2), free=C8_UNKNOWNS, input_hold="zoh",
                             substeps=8)
    t = np.arange(n + 1) * dt
    uu = np.vstack([u, u[-1:]])
    sens = []
    for i in model.free_indices():
        th = model.theta.copy()
        h = 1e-6 * max(1.0, abs(th[i]))
        th[i] += h
        yp, _ = mlid.simulate(model.with_theta(th), t, uu)
        th[i] -= 2 * h
        ym, _ = mlid.simulate(model.with_theta(th), t, uu)
        sens.append((yp.y - ym.y) / (2 * h))
    Mi = np.zeros_like(M)
    for a in range(5):
        for b in range(5):
            f = np.sum(sens[a] * sens[b] / np.diag(C8_R), axis=1)
            Mi[a, b] = np.sum(0.5 * (f[1:] + f[:-1])) * dt
    np.testing.assert_allclose(M, Mi, rtol=1e-3)


@pytest.mark.parametrize("kwargs, match", [
    ({"unknowns": ["f(3,1)"]}, "no element of F, G or H within the dimensions"),
    ({"unknowns": ["q(1)"]}, "'q\\(1\\)' is no element of F, G or H"),
    ({"unknowns": ["x0(1)"]}, r"no element of F, G or H \(the design's unknowns are\)"),
    ({"weights": [1.0, -1.0, 1, 1, 1]}, "weights"),
])
def test_bad_design_input(kwargs, match):
    args = dict(F=C8_F, G=C8_G, H=np.eye(2), R=C8_R, unknowns=C8_UNKNOWNS)
    args.update(kwargs)
    with pytest.raises(mlid.InputError, match=match):
        d = mlid.InputDesign(**args)
        d.mu_max(1.0)


def test_bad_lengths_and_zero_sensitivity():
    d = mlid.InputDesign(C8_F, C8_G, np.eye(2), C8_R, C8_UNKNOWNS)
    with pytest.raises(mlid.InputError, match="T must be > 0"):
        d.mu_max(0.0)
    with pytest.raises(mlid.InputError, match="energy must be > 0"):
        d.optimal_input(1.0, -5.0)
    # an unknown that no output sees (H = 0)
    blind = mlid.InputDesign([[-1.0]], [[1.0]], [[0.0]], [[1.0]], ["g(1,1)"])
    with pytest.raises(mlid.SingularInformationError, match="zero sensitivity"):
        blind.mu_max(1.0)


def test_an_unknown_no_input_reaches_gets_infinite_sigma():
    """F(2,2) of a state neither driven nor measured: the design still runs for
    the others and says so, with no NaN."""
    d = mlid.InputDesign([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [0.0]], [[1.0, 0.0]], [[1.0]],
                         ["g(1,1)", "f(2,2)"])
    inp = d.optimal_input(1.0, 1.0)
    assert np.all(np.isfinite(inp.u))
    assert np.isfinite(inp.summary["sigma"][0]) and np.isinf(inp.summary["sigma"][1])
    assert inp.summary["det"] == 0.0


def test_process_noise_design_matches_the_report_example():
    """§7.5.1: x' = -x + theta u + eta, steady-state gain k; the sensitivity
    pole moves to -(1+k), mu = 1/(r (omega^2 + (1+k)^2)), tan(omega T) = -omega/(1+k)."""
    q, r, T = 3.0, 1.0, 1.0
    d = mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[r]], ["g(1,1)"], process_noise=[[q]])
    k = (-1.0 + np.sqrt(1.0 + q / r))              # Sigma/r from -2 Sigma + q - Sigma^2/r = 0
    a = 1.0 + k
    lo, hi = np.pi / (2 * T) + 1e-12, np.pi / T
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.tan(mid * T) + mid / a < 0 else (lo, mid)
    omega = 0.5 * (lo + hi)
    mu = 1.0 / (r * (omega**2 + a**2))
    assert d.mu_max(T) == pytest.approx(mu, rel=1e-7)
    assert d.mu_max(T) < first_order().mu_max(T)      # process noise costs information


def test_two_inputs_share_the_energy_where_it_buys_most():
    """Two decoupled first-order channels with unknown gains: the optimal
    input puts all its energy on the channel of the larger mu (the weaker
    noise), and the design matches that channel's closed form."""
    d = mlid.InputDesign(np.diag([-1.0, -1.0]), np.eye(2), np.eye(2), np.diag([1.0, 4.0]),
                         ["g(1,1)", "g(2,2)"])
    omega, mu = closed_form(1.0)
    assert d.mu_max(1.0) == pytest.approx(mu, abs=1e-7)      # channel 1, r = 1
    inp = d.optimal_input(1.0, 1.0)
    assert inp.u.shape[1] == 2
    assert np.sum(inp.u[:, 1] ** 2) < 1e-12 * np.sum(inp.u[:, 0] ** 2)


def _oscillator():
    wn, z = 3.0, 0.1                     # a lightly damped mode: the best input alternates
    return mlid.InputDesign([[0, 1], [-wn * wn, -2 * z * wn]], [[0], [wn * wn]], np.eye(2),
                            0.01 * np.eye(2), ["f(2,1)", "f(2,2)", "g(2,1)"])


def test_amplitude_limited_design_is_the_best_square_wave():
    """Against every square wave of 12 cells (2^11 up to sign): the local
    search finds the global optimum, flips no cell for a gain, and beats the
    energy-optimal input scaled to the same peak."""
    import itertools
    d, T, n = _oscillator(), 6.0, 12
    best = d.amplitude_limited(T, 2.0, T / n)
    assert best.u.shape == (n, 1) and np.all(np.abs(best.u) == 2.0)
    tr = [np.trace(d.information(T, 2.0 * np.array((1,) + s, float)))
          for s in itertools.product([-1, 1], repeat=n - 1)]
    assert np.trace(best.M) == pytest.approx(max(tr), rel=1e-10)
    for a in range(n):
        u = best.u.copy()
        u[a] = -u[a]
        assert np.trace(d.information(T, u)) <= np.trace(best.M) * (1 + 1e-12)
    opt = d.optimal_input(T, 1.0)
    scaled = opt.u * 2.0 / np.max(np.abs(opt.u))
    assert np.trace(best.M) > np.trace(d.information(T, scaled))
    assert np.sum(np.abs(np.diff(np.sign(best.u[:, 0])))) > 0    # it alternates


def test_amplitude_limited_two_inputs_and_bad_limits():
    F = np.array([[-1.588, -0.562], [1.0, -0.737]])
    G = np.array([[-1.66, 0.3], [0.005, -0.2]])
    d = mlid.InputDesign(F, G, np.eye(2), np.diag([0.02, 0.04]),
                         ["f(1,1)", "f(1,2)", "g(1,1)", "g(2,2)"])
    two = d.amplitude_limited(4.0, 1.0, 0.5)
    assert two.u.shape == (8, 2) and np.all(np.abs(two.u) == 1.0)
    with pytest.raises(mlid.InputError, match="min_width"):
        d.amplitude_limited(4.0, 1.0, 5.0)
    with pytest.raises(mlid.InputError, match="peak"):
        d.amplitude_limited(4.0, 0.0, 0.5)
