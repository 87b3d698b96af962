"""Table-lookup coefficients (fortran/models/mlid_tables.f90, python/mlid/model/tables.py):
values interpolated (multi)linearly and held beyond the ends, exact Jacobians,
a nonlinear table recovered by output error within its Cramer-Rao bounds, a
cell no sample reaches named, and the smoothness prior."""

from pathlib import Path

import numpy as np
import pytest

import mlid
from mlid.errors import InputError, MlidError
from mlid.model.tables import Table

SIXDOF_CONSTANTS = dict(m=7000.0, Ix=1.2e4, Iy=6.0e4, Iz=7.0e4, Ixz=1.0e3, S=30.0, cbar=2.5,
                        b=14.0, g=9.80665)


def lookup(bps, values, point):
    """Multilinear interpolation, held beyond the ends (the reference)."""
    w = []
    for b, v in zip(bps, point):
        v = min(max(v, b[0]), b[-1])
        i = min(np.searchsorted(b, v, side="right") - 1, len(b) - 2)
        f = (v - b[i]) / (b[i + 1] - b[i])
        wi = np.zeros(len(b))
        wi[i], wi[i + 1] = 1 - f, f
        w.append(wi)
    out = values
    for wi in w:
        out = np.tensordot(wi, out, axes=(0, 0))
    return float(out)


def test_values_interpolate_and_hold_beyond_the_ends():
    """A regression through 1-, 2- and 3-variable tables: the outputs are
    the multilinear interpolation of the values, the end values beyond."""
    rng = np.random.default_rng(4)
    b1, b2, b3 = [-0.1, 0.0, 0.15, 0.3], [0.3, 0.6, 0.9], [0.0, 1.0]
    v1, v2, v3 = rng.normal(size=4), rng.normal(size=(4, 3)), rng.normal(size=(4, 3, 2))
    m = mlid.EquationModel(
        outputs={"y1": "T1", "y2": "T2", "y3": "T3"}, inputs=["alpha", "M", "flap"],
        definitions={"T1": Table("alpha", b1, v1), "T2": Table(["alpha", "M"], [b1, b2], v2),
                     "T3": Table(["alpha", "M", "flap"], [b1, b2, b3], v3)})
    t = np.arange(200) * 0.05
    u = np.column_stack([np.linspace(-0.3, 0.45, t.size), 0.2 + 0.9 * np.abs(np.sin(t)),
                         (t > 5).astype(float)])
    u[7] = [0.15, 0.6, 1.0]                        # on breakpoints: the values themselves
    d, _ = mlid.simulate(m, t, u, noise_std=[0.0, 0.0, 0.0])
    want = np.array([[lookup([b1], v1, r[:1]), lookup([b1, b2], v2, r[:2]),
                      lookup([b1, b2, b3], v3, r)] for r in u])
    np.testing.assert_allclose(d.y, want, rtol=0, atol=1e-14)
    assert d.y[7, 2] == v3[2, 1, 1]


def test_parameter_names_order_and_cells():
    m = mlid.EquationModel(
        outputs={"CL": "T + k*de"}, inputs=["alpha", "M", "de"], params={"k": 0.3},
        definitions={"T": Table(["alpha", "M"], [[0, 0.1, 0.2], [0.5, 0.8]],
                                np.arange(6.0).reshape(3, 2))})
    assert m.element_labels()[:7] == ["k", "T[1,1]", "T[2,1]", "T[3,1]", "T[1,2]", "T[2,2]",
                                      "T[3,2]"]
    np.testing.assert_array_equal(m.p, [0.3, 0, 2, 4, 1, 3, 5])   # values[i, j] is T[i+1,j+1]
    assert m.value("T[2,1]") == 2.0
    assert m.table_cells["T[2,2]"] == ("T[2,2] (alpha = 0.1, M = 0.8; weighted where "
                                       "0 < alpha < 0.2, 0.5 < M)")


@pytest.mark.parametrize("bad, why", [
    (Table("alpha", [0.0, 0.2, 0.1]), "breakpoints of alpha: the breakpoints must increase"),
    (Table("beta", [0.0, 0.1]), "no state, input, parameter or definition before it is "
                                "named beta"),
    (Table("alpha", [0.0]), "at least two breakpoints"),
])
def test_bad_tables_are_refused_with_a_reason(bad, why):
    with pytest.raises(InputError, match="table T") as err:
        mlid.EquationModel(outputs={"CL": "T"}, inputs=["alpha"], definitions={"T": bad})
    assert why in str(err.value)


def test_a_variable_matching_two_names_but_for_case_says_so():
    """A table's variable is found by its exact name, else by any case
    when one name matches: two that match are named, not 'no ... is named'."""
    with pytest.raises(InputError) as err:
        mlid.EquationModel(outputs={"CL": "T"}, inputs=["alpha", "Alpha"],
                           definitions={"T": Table("ALPHA", [0.0, 0.1])})
    assert str(err.value).endswith("equations model, table T: its variable ALPHA matches 2 "
                                   "names but for case (alpha, Alpha): write one of them exactly")
    m = mlid.EquationModel(outputs={"CL": "T"}, inputs=["alpha", "Alpha"],
                           definitions={"T": Table("Alpha", [0.0, 0.1])})
    assert m.np == 2                                  # the exact name still wins


def test_values_of_the_wrong_shape_are_refused():
    with pytest.raises(InputError, match=r"shape \(3,\)"):
        Table("alpha", [0, 1, 2], [1.0, 2.0])


def table_model(**kw):
    """States alpha, q; the lift coefficient a table in alpha (nonlinear:
    its slope falls off towards a stall), measured as CL."""
    return mlid.EquationModel(
        states={"alpha": "q - 0.3*CLt", "q": "-6*(alpha - de) - 2*q"},
        outputs={"alpha": "alpha", "q": "q", "CL": "CLt"}, inputs=["de"],
        definitions={"CLt": Table("alpha", BREAKS, kw.pop("values"))}, **kw)


BREAKS = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
TRUTH = np.array([0.05, 0.6, 1.1, 1.45, 1.6, 1.55])
START = 3.5 * np.array(BREAKS)                   # linear: the smoothness prior's reference
NAMES = [f"CLt[{i}]" for i in range(1, 7)]


def table_record(seed=7):
    t = np.arange(1500) * 0.02
    de = 0.05 + 0.35 * np.clip(t / 24.0, 0, 1) + 0.04 * np.sign(np.sin(2.1 * t))
    truth = table_model(values=TRUTH, x0=[0.09, 0.0])
    d, _ = mlid.simulate(truth, t, de[:, None], noise_std=[1e-3, 2e-3, 0.02], seed=seed)
    return d


def test_jacobians_of_tables_against_central_differences():
    """Equations with 1-, 2- and 3-variable tables over states and inputs,
    inside cells: the exact Jacobians agree with central differences (the
    project's check, mlid_jacobian_check)."""
    rng = np.random.default_rng(2)
    b1, b2, b3 = [-0.1, 0.05, 0.2, 0.4], [0.3, 0.6, 0.9], [0.0, 1.0]
    m = mlid.EquationModel(
        states={"alpha": "q - 0.3*CLt - 0.01*Cd3", "q": "Cmt*alpha + Cmq*q + 2*de"},
        outputs={"alpha": "alpha", "az": "CLt*M^2", "Cd": "Cd3"}, inputs=["de", "M", "flap"],
        definitions={"CLt": Table(["alpha", "M"], [b1, b2], rng.normal(size=(4, 3))),
                     "Cmt": Table("alpha", b1, rng.normal(size=4)),
                     "Cmq": Table(["M"], [b2], -rng.uniform(1, 2, size=3)),
                     "Cd3": Table(["alpha", "M", "flap"], [b1, b2, b3],
                                  rng.normal(size=(4, 3, 2)))})
    for x, u in [([0.1, 0.3], [0.05, 0.45, 0.0]), ([0.3, -0.2], [0.0, 0.8, 1.0]),
                 ([0.6, 0.1], [0.1, 1.2, 0.5]), ([-0.3, 0.0], [0.0, 0.1, -1.0])]:
        err = mlid.check_jacobians(m, x, u)
        assert max(err.values()) < 1e-6, (x, u, err)


def test_jacobians_of_a_sixdof_model_with_tables():
    """The six-degree-of-freedom kind: its coefficients tables in alpha and
    Mach (a definition) and a derivative, Cmq, a table in alpha."""
    rng = np.random.default_rng(5)
    ba, bm = [-0.05, 0.05, 0.15, 0.3], [0.2, 0.4, 0.6]
    m = mlid.SixDofModel(
        SIXDOF_CONSTANTS, states=["u", "w", "q", "theta"],
        outputs={"alpha": "alpha", "q": "q", "az": "az", "V": "V"},
        inputs=["de", "v", "p", "r", "phi"],
        params={"CDde": 0.05, "Cmde": -1.2},
        definitions={"rho": "1.0", "Mach": "V/330",
                     "CLtab": Table(["alpha", "Mach"], [ba, bm], 4 + rng.normal(size=(4, 3))),
                     "CL": "CLtab*alpha + 0.3",
                     "CD": "0.03 + 0.5*alpha^2 + CDde*de",
                     "Cmq": Table("alpha", ba, -rng.uniform(8, 12, 4)),
                     "Cm": "-0.8*alpha + Cmq*qhat + Cmde*de"})
    for x, u in [([120.0, 8.0, 0.02, 0.05], [0.01, 0, 0, 0, 0]),
                 ([95.0, 20.0, -0.05, 0.1], [-0.02, 1.0, 0.01, 0, 0.1])]:
        err = mlid.check_jacobians(m, x, u)
        assert max(err.values()) < 1e-6, (x, u, err)


def test_output_error_recovers_the_reached_cells():
    """A record made with a nonlinear table, fitted by output error from a
    linear start: each reached value within 3 Cramer-Rao sigma of the
    truth."""
    d = table_record()
    alpha = d.y[:, 0]
    assert alpha.min() < 0.1 and 0.3 < alpha.max() < 0.4     # reaches CLt[1] .. CLt[5]
    res = mlid.fit(table_model(values=START, x0=[0.09, 0.0], free=NAMES[:5]), d)
    assert res.converged
    z = (res.estimate - TRUTH[:5]) / res.sigma
    assert np.all(np.abs(z) < 3), z
    # CLt[5] (alpha = 0.4) is reached only near alpha = 0.35: a wider sigma
    assert np.all(res.sigma[:4] < 2e-3) and res.sigma[4] < 0.05, res.sigma
    assert np.all(np.abs(START[:5] - TRUTH[:5]) > 5 * res.sigma)   # the start was not it


def test_a_cell_no_sample_reaches_is_named():
    """CLt[6] (alpha = 0.5) acts only above alpha = 0.4, which the record
    never reaches: its information is zero.  A full-rank fit fails naming
    it; a rank-deficient one leaves it at its start, and its report and
    unreached_cells name it (and say where it acts)."""
    d = table_record()
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES)
    with pytest.raises(MlidError, match=r"'CLt\[6\]' is not identifiable"):
        mlid.fit(m, d)
    res = mlid.fit(m, d, rank_min=1)
    assert res.converged and res.rank == 5
    assert res.estimate[5] == START[5] and res.sigma[5] == 0.0
    assert (" not identifiable, left at the a priori value (no information; a table value: "
            "reached by no sample): CLt[6]\n") in res.report()
    assert m.unreached_cells(res) == [
        "CLt[6] (alpha = 0.5; weighted where 0.4 < alpha) is reached by no sample: "
        "not identifiable"]
    z = (res.estimate[:5] - TRUTH[:5]) / res.sigma[:5]     # the others as before
    assert np.all(np.abs(z) < 3), z


def test_the_smoothness_prior_fills_an_unreached_cell():
    """With a weight on the second differences, the unreached CLt[6] is
    the linear extrapolation of its neighbours (no data pulls it), with a
    finite sigma; the reached cells barely move for a small weight and the
    table straightens as the weight grows."""
    d = table_record()
    plain = mlid.fit(table_model(values=START, x0=[0.09, 0.0], free=NAMES[:5]), d)
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES)
    second = []
    for lam in (1e-2, 1e4, 1e8):
        res = mlid.fit(m, d, prior_weight=m.smoothness_weight({"CLt": lam}))
        assert res.converged and res.rank == 6
        v = res.estimate
        assert v[5] == pytest.approx(2 * v[4] - v[3], abs=1e-6)
        assert np.isfinite(res.sigma[5]) and res.sigma[5] > res.sigma[4]
        if lam == 1e-2:
            np.testing.assert_allclose(v[:5], plain.estimate, atol=0.05 * plain.sigma.min())
        second.append(np.abs(np.diff(v, 2)).max())
    assert second[0] > second[1] > second[2]
    assert second[2] < 1e-3 * second[0]


def test_smoothness_weight_names_only_tables():
    m = table_model(values=START, free=NAMES)
    with pytest.raises(InputError, match="no table named CLx"):
        m.smoothness_weight({"CLx": 1.0})
    w = m.smoothness_weight({"CLt": 2.0})
    # even breakpoints: the rows (1, -2, 1) of the second differences, times 2
    D = np.zeros((4, 6))
    for i in range(4):
        D[i, i:i + 3] = [1, -2, 1]
    np.testing.assert_allclose(w, 2.0 * D.T @ D, atol=1e-9)


@pytest.mark.parametrize("lam, said", [(-1.0, "-1"), (float("nan"), "NaN"),
                                       (float("inf"), "Infinity")])
def test_a_smoothness_weight_not_finite_and_at_least_0_is_refused(lam, said):
    """lambda < 0 would reward roughness, NaN spoil the fit: refused with
    the table named, never read as 'no prior' (which 0 is)."""
    m = table_model(values=START, free=NAMES)
    with pytest.raises(InputError) as err:
        m.smoothness_weight({"CLt": lam})
    assert str(err.value).endswith(f"smoothness: the weight of table CLt is {said}, not a "
                                   f"finite number >= 0 (0: no prior)")
    assert not m.smoothness_weight({"CLt": 0.0}).any()


def test_table_values_are_ordinary_parameters():
    """Tied, bounded and with a prior, by their names."""
    d = table_record()
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES[:4],
                    ties={"CLt[5]": "CLt[4] + 0.15", "CLt[6]": "CLt[4] + 0.1"})
    free = mlid.fit(m, d)
    res = mlid.fit(m, d, bounds={"CLt[1]": (-0.1, 0.03)}, prior={"CLt[2]": 0.5},
                   prior_weight={"CLt[2]": 1e6})
    theta = res.model.theta
    assert theta[4] == theta[3] + 0.15 and theta[5] == theta[3] + 0.1
    assert res.estimate[0] == 0.03 < free.estimate[0]                 # held at its bound
    assert 0.5 < res.estimate[1] < free.estimate[1]                   # pulled to the prior


# HFB-320-like longitudinal model (tests/test_sixdof.py's scenario)
LONG = dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                              7472.0, 0.0524, 0.792, 1.215]))
LONG_REGS = {"CD": ["1", "V/V0", "alpha"], "CL": ["1", "V/V0", "alpha", "alpha^2"],
             "Cm": ["1", "V/V0", "alpha", "qhat", "de"]}
LONG_VALS = {"CD": [0.117758, -0.0517459, 0.234846], "CL": [-0.204711, 0.363549, 3.21232, 1.5],
             "Cm": [0.134413, -0.0139045, -1.00241, -27.0570, -1.43707]}


def longitudinal_run(model):
    from mlid.design.signals import input_signal
    t = np.arange(601) * 0.1
    de = -0.008 + input_signal("3211", 0.03, 2.0, 1.5, 0.1, 601)
    return mlid.simulate(model, t, np.column_stack([de, np.full(601, 11600.0)]))[0]


def test_the_longitudinal_kind_as_equations_is_itself():
    """The longitudinal model written out as equations (mlid_long_text)
    with no table gives the built-in model's outputs: the same equations."""
    lm = mlid.LongitudinalModel(LONG_REGS, LONG_VALS, LONG, x0=[106.0, 0.11, 0.105, -0.003],
                                substeps=4, free=["cl(3)", "cm(4)"])
    eq = lm.with_tables({})
    assert eq.element_labels()[:4] == ["C_D0", "C_DV", "C_Dalpha", "C_L0"]
    assert eq.free_names() == ["C_Lalpha", "C_mq"]
    a, b = longitudinal_run(lm), longitudinal_run(eq)
    np.testing.assert_allclose(b.y, a.y, rtol=1e-12, atol=1e-12 * np.ptp(a.y, axis=0).max())


def test_the_longitudinal_text_asks_the_model_for_its_facts():
    """mlid_long_text writes the longitudinal model out: its regressors,
    constants and sizes are mlid_aero_long's, asked there, not copied (a
    copy would drift when the model changes).  Every regressor in one
    coefficient: the text is still the model itself."""
    from conftest import REPO
    src = (REPO / "fortran" / "models" / "mlid_long_text.f90").read_text()
    code = "\n".join(line.split("!")[0] for line in src.splitlines())   # comments dropped
    for copy in ("'alpha^2'", "'qhat'", "'ScIy'", "'sigT'", "'c2'", "4, 2, 7, 4"):
        assert copy not in code, copy
    regs = dict(LONG_REGS, CD=["1", "V/V0", "alpha", "alpha^2", "qhat", "de"])
    vals = dict(LONG_VALS, CD=[0.117758, -0.0517459, 0.234846, 0.3, 0.5, 0.02])
    lm = mlid.LongitudinalModel(regs, vals, LONG, x0=[106.0, 0.11, 0.105, -0.003], substeps=4)
    eq = lm.with_tables({})
    assert [ln.split(" =")[0] for ln in eq.text.split("\n") if ln.startswith("l ")][:9] == [
        "l g", "l Sm", "l ScIy", "l lTIy", "l V0", "l mass", "l sigT", "l rho", "l c2"]
    a, b = longitudinal_run(lm), longitudinal_run(eq)
    np.testing.assert_allclose(b.y, a.y, rtol=1e-12, atol=1e-12 * np.ptp(a.y, axis=0).max())


def test_a_longitudinal_coefficient_as_a_table():
    """C_Lalpha a table over alpha, C_mq one over alpha: equal to the
    constant coefficient when every value is that constant, exact Jacobians
    inside the cells, values named C_Lalpha[i]."""
    lm = mlid.LongitudinalModel(LONG_REGS, LONG_VALS, LONG, x0=[106.0, 0.11, 0.105, -0.003],
                                substeps=4)
    ba = [0.0, 0.05, 0.1, 0.15, 0.2]
    flat = lm.with_tables({"C_Lalpha": Table("alpha", ba, np.full(5, 3.21232)),
                           "C_mq": Table("alpha", ba, np.full(5, -27.0570))})
    assert flat.free_names()[-10:] == [f"C_Lalpha[{i}]" for i in range(1, 6)] + [
        f"C_mq[{i}]" for i in range(1, 6)]
    a, b = longitudinal_run(lm), longitudinal_run(flat)
    np.testing.assert_allclose(b.y, a.y, rtol=1e-12, atol=1e-12 * np.ptp(a.y, axis=0).max())
    rng = np.random.default_rng(8)
    bent = lm.with_tables({"C_Lalpha": Table("alpha", ba, 3.2 + rng.normal(0, 0.3, 5)),
                           "C_m0": Table(["alpha", "de"], [ba, [-0.05, 0.0, 0.05]],
                                         0.13 + rng.normal(0, 0.02, (5, 3)))})
    for x, u in [([106.0, 0.11, 0.105, -0.003], [-0.01, 11600.0]),
                 ([98.0, 0.07, 0.02, 0.05], [0.02, 9000.0])]:
        err = mlid.check_jacobians(bent, x, u)
        assert max(err.values()) < 1e-6, err
    with pytest.raises(InputError, match="C_Lbeta"):
        lm.with_tables({"C_Lbeta": Table("alpha", ba)})



def test_with_tables_keeps_the_other_blocks_and_refuses_process_noise():
    """x0, biases, r, the delays, stab and p0 carry over (as in a deck);
    process noise, which an equations model has not, is refused, not
    dropped."""
    lm = mlid.LongitudinalModel(LONG_REGS, LONG_VALS, LONG, x0=[106.0, 0.11, 0.105, -0.003],
                                bias=np.arange(7) * 0.01, r=np.arange(1, 8) * 1e-3,
                                delay=[0, 0.1, 0, 0, 0, 0, 0.2], udelay=[0.05, 0])
    eq = lm.with_tables({"C_Lalpha": Table("alpha", [0.0, 0.1], [3.2, 3.2])})
    for key in ("x0", "bias", "r", "delay", "udelay", "stab", "p0"):
        np.testing.assert_array_equal(eq._block(key), lm._block(key), err_msg=key)
    assert eq.delay[6] == 0.2 and eq.udelay[0] == 0.05
    # a Table made without values starts at the coefficient's value (as a
    # deck's table value without a params entry); one with values at those
    bare = lm.with_tables({"C_Lalpha": Table("alpha", [0.0, 0.1, 0.2])})
    assert [bare.value(f"C_Lalpha[{i}]") for i in (1, 2, 3)] == [lm.value("C_Lalpha")] * 3
    assert eq.value("C_Lalpha[1]") == 3.2 and lm.value("C_Lalpha") != 3.2
    lm.q = [1e-4, 0, 0, 0]
    with pytest.raises(InputError, match="no process noise: q and S must be zero"):
        lm.with_tables({})


TABLE_DECK = """&case title = 'a table', job = 'estimate' /
&model kind = 'equations', state_names = 'alpha', 'q', input_names = 'de',
    output_names = 'alpha', 'q', 'CL',
    definitions = 'CLt(alpha) = 0 0.1 0.2 0.3 0.4 0.5',
    params = {starts},
    xdot = 'q - 0.3*CLt', '-6*(alpha - de) - 2*q', outputs = 'alpha', 'q', 'CLt',
    x0 = 0.09, 0, free = {free} /
&data file = 'rec.dat', time_col = 1, input_cols = 2, output_cols = 3, 4, 5 /
{estimate}"""


def table_deck(tmp_path, free=NAMES[:5], estimate="", starts=None):
    d = table_record()
    np.savetxt(tmp_path / "rec.dat", np.column_stack([d.t, d.u, d.y]))
    starts = starts or ", ".join(f"'{n} = {float(v)!r}'" for n, v in zip(NAMES, START))
    deck = tmp_path / "t.nml"
    deck.write_text(TABLE_DECK.format(starts=starts, free=", ".join(f"'{n}'" for n in free),
                                      estimate=estimate))
    return d, deck


def test_a_deck_declares_a_table(tmp_path):
    """A definitions entry 'NAME(v) = breakpoints' is a table, params
    'NAME[i] = value' its start values: both front ends give the same
    bytes, and the fit of the Python model's."""
    from conftest import both_front_ends_json
    d, deck = table_deck(tmp_path)
    fit = both_front_ends_json(deck, tmp_path)
    res = mlid.fit(table_model(values=START, x0=[0.09, 0.0], free=NAMES[:5]), d)
    assert fit["parameters"] == NAMES[:5]
    np.testing.assert_allclose(fit["estimate"], res.estimate, rtol=1e-9)
    np.testing.assert_allclose(fit["sigma"], res.sigma, rtol=1e-7)


def test_a_deck_names_the_cell_no_sample_reaches(tmp_path):
    from conftest import run_both
    _, deck = table_deck(tmp_path, free=NAMES, estimate="&estimate rank_min = 1 /\n")
    outs = run_both(deck, cwd=tmp_path)
    assert outs[0].stdout == outs[1].stdout and outs[0].returncode == 0, outs[0].stderr
    assert (" not identifiable, left at the a priori value (no information; a table value: "
            "reached by no sample): CLt[6]\n") in outs[0].stdout


def test_a_deck_smooths_a_table_as_python_does(tmp_path):
    """&estimate smoothness = 'CLt = lambda' is the Python fit's
    prior_weight=model.smoothness_weight({'CLt': lambda}), all six values
    free (the unreached CLt[6] filled by the prior), with another a priori
    weight given beside it: same estimates and sigma, same bytes from both
    front ends."""
    from conftest import both_front_ends_json
    d, deck = table_deck(tmp_path, free=NAMES, estimate="&estimate smoothness = 'CLt = 1e4', "
                         "prior_weight(1) = 100 /\n")
    fit = both_front_ends_json(deck, tmp_path)
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES)
    w = m.smoothness_weight({"CLt": 1e4})
    w[0, 0] += 100.0
    res = mlid.fit(m, d, prior_weight=w)
    assert fit["parameters"] == NAMES
    np.testing.assert_allclose(fit["estimate"], res.estimate, rtol=1e-9)
    np.testing.assert_allclose(fit["sigma"], res.sigma, rtol=1e-7)
    assert np.isfinite(fit["sigma"][5])


@pytest.mark.parametrize("entry, said", [
    ("'CLx = 1'", "group &estimate: smoothness: no table named CLx (tables: CLt)"),
    ("'CLt = -1'", "group &estimate: smoothness: the weight of table CLt is -1, not a finite "
                   "number >= 0 (0: no prior)"),
    ("'CLt = 1 2'", "group &estimate: smoothness entry 'CLt = 1 2': "),
    ("'CLt'", "group &estimate: smoothness entry 'CLt' is not 'TABLE = weight'"),
    ("'CLt = 1', 'CLt = 2'", "group &estimate: smoothness: table CLt is given a weight twice")])
def test_a_deck_refuses_a_bad_smoothness_entry(tmp_path, entry, said):
    from conftest import refused_by_both
    _, deck = table_deck(tmp_path, free=NAMES, estimate=f"&estimate smoothness = {entry} /\n")
    refused_by_both(deck, said, cwd=tmp_path)


def test_a_deck_refuses_a_start_of_no_table_value(tmp_path):
    from conftest import refused_by_both
    _, deck = table_deck(tmp_path, starts="'CLt[7] = 1'")
    refused_by_both(deck, "group &model: params entry 'CLt[7] = 1' is not 'NAME[i] = value' "
                          "of a table's value", cwd=tmp_path)


def test_a_model_too_large_is_refused_before_its_names_are_made(tmp_path):
    """Forty tables of 56^3 values: 7 million parameters, their names 225
    MB, were made before the model was refused as too large.  Now the
    sizes are counted first: one line from both front ends, and mlid-batch
    stays small (peak resident memory, of the child alone)."""
    import resource
    import subprocess
    import sys
    from conftest import BIN, refused_by_both
    bps = " ".join(str(k) for k in range(1, 57))
    tables = ", ".join(f"'T{k}(u, x1, x2) = {bps}; {bps}; {bps}'" for k in range(1, 41))
    deck = tmp_path / "big.nml"
    deck.write_text(f"""&case title = 'too large', job = 'estimate' /
&model kind = 'equations', state_names = 'x1', 'x2', input_names = 'u',
    definitions = {tables},
    xdot = '-x1 + T1*u', '-x2', outputs = 'x1', 'x2', free = 'T1[1,1,1]' /
&data file = 'rec.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
""")
    refused_by_both(deck, "group &model: equations model: too large: 7024643 states, inputs and "
                          "parameters with the tables' values (at most 511), 2 states and 2 "
                          "outputs (at most 64 each)", cwd=tmp_path)
    code = ("import resource, subprocess, sys; subprocess.run(sys.argv[1:], capture_output=True); "
            "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    run = subprocess.run([sys.executable, "-c", code, str(BIN / "mlid-batch"), str(deck)],
                         capture_output=True, text=True, cwd=tmp_path, check=True)
    assert int(run.stdout) < 100_000, run.stdout             # kB: the names alone were 225 MB


def test_a_sixdof_deck_with_a_table(tmp_path):
    """Kind 'sixdof' in a deck: Cl's beta term a table over beta (truth:
    Clb*beta, linear, so the values are Clb times the breakpoints); the
    table values within 4 sigma of it, the same in both front ends."""
    from conftest import both_front_ends_json
    from test_sixdof import CONSTANTS as SIX, LATERAL_DECK, LAT_TRUTH, lateral_record
    lateral_record(tmp_path / "lat.dat")
    consts = ", ".join(repr(SIX[k]) for k in mlid.model.models.SIXDOF_CONSTANTS)
    deck = LATERAL_DECK.format(consts=consts).replace(
        "'Cl = Clb*beta + Clp*phat", "'Clt(beta) = -0.1 0 0.1', 'Cl = Clt + Clp*phat").replace(
        "'Clb = -0.07', ", "").replace(
        "params = ", "params = 'Clt[1] = 0', 'Clt[2] = 0', 'Clt[3] = 0', ").replace(
        "free = 'CYb', 'Clb'", "free = 'CYb', 'Clt[1]', 'Clt[2]', 'Clt[3]'")
    (tmp_path / "lat.nml").write_text(deck)
    fit = both_front_ends_json(tmp_path / "lat.nml", tmp_path)
    assert fit["converged"]
    truth = dict(LAT_TRUTH, **{"Clt[1]": 0.1 * -LAT_TRUTH["Clb"], "Clt[2]": 0.0,
                               "Clt[3]": 0.1 * LAT_TRUTH["Clb"]})
    assert fit["parameters"][1:4] == ["Clt[1]", "Clt[2]", "Clt[3]"]
    for name, value, sigma in zip(fit["parameters"], fit["estimate"], fit["sigma"]):
        assert abs(value - truth[name]) < 4 * sigma, (name, value, sigma)



# kind = 'longitudinal' in a deck with a coefficient a table: the real HFB-320 record
# (../shared/data, read from there), cases/hfb320/hfb320.nml's first case's model
HFB_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hfb320_1_10.asc"
HFB_REGS = {"CD": ["1", "V/V0", "alpha"], "CL": ["1", "V/V0", "alpha"],
            "Cm": ["1", "V/V0", "alpha", "qhat", "de"]}
HFB_START = {"CD": [5.67516e-3, 7.72612e-3, 0.674256], "CL": [-0.318267, 0.260317, 5.37576],
             "Cm": [4.98218e-2, 1.89182e-2, -0.498586, -25.8439, -0.990687]}
HFB_X0 = [106.023, 0.111685, 0.104887, -0.00332659]
HFB_BREAKS = [0.08, 0.105, 0.13]                  # alpha of the record: 0.086 to 0.126 rad
HFB_FREE = ["C_D0", "C_DV", "C_Dalpha", "C_LV", "C_m0", "C_mV", "C_malpha", "C_mq", "C_mde",
            "C_Lalpha[1]", "C_Lalpha[2]", "C_Lalpha[3]"]
LONG_DECK = """&case title = 'HFB-320, C_Lalpha a table', job = 'estimate' /
&model kind = 'longitudinal', {extra}
    cd_regressors = '1', 'V/V0', 'alpha', cl_regressors = '1', 'V/V0', 'alpha',
    cm_regressors = '1', 'V/V0', 'alpha', 'qhat', 'de',
    cd = 5.67516e-3, 7.72612e-3, 0.674256, cl = -0.318267, 0.260317, 5.37576,
    cm = 4.98218e-2, 1.89182e-2, -0.498586, -25.8439, -0.990687,
    constants = 9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67, 7472.0, 0.0524, 0.792, 1.215,
    x0 = 106.023, 0.111685, 0.104887, -0.00332659,
    definitions = {definitions}, params = {params},
    free = {free} /
&data file = '{data}', time_col = 1, input_cols = 2, 4, output_cols = 5, 6, 7, 8, 9, 10, 11 /
&estimate max_iter = 20 /
"""
needs_hfb = pytest.mark.skipif(not HFB_DATA.is_file(), reason=f"no flight data at {HFB_DATA}")


def long_deck(tmp_path, extra="", definitions=f"'C_Lalpha(alpha) = {' '.join(map(str, HFB_BREAKS))}'",
              params="'C_Lalpha[2] = 5.3'"):
    deck = tmp_path / "long.nml"
    deck.write_text(LONG_DECK.format(extra=extra, definitions=definitions, params=params,
                                     free=", ".join(f"'{n}'" for n in HFB_FREE), data=HFB_DATA))
    return deck


@needs_hfb
def test_a_longitudinal_deck_with_a_table_is_pythons_with_tables(tmp_path):
    """kind = 'longitudinal' with definitions 'C_Lalpha(alpha) = ...' is the
    model's with_tables: its values start at the params entry, the others at
    cl's C_Lalpha (Python: the Table's values); free names the equations
    model's parameters.  Same estimates and sigma as Python's fit, the same
    bytes from both front ends."""
    from conftest import both_front_ends_json
    fit = both_front_ends_json(long_deck(tmp_path, extra="delay(7) = 0.1,"), tmp_path)
    rec = np.loadtxt(HFB_DATA)
    d = mlid.FlightData(rec[:, 0], rec[:, [1, 3]], rec[:, 4:11])
    lm = mlid.LongitudinalModel(HFB_REGS, HFB_START, LONG, x0=HFB_X0, delay=[0] * 6 + [0.1])
    eq = lm.with_tables({"C_Lalpha": Table("alpha", HFB_BREAKS, [5.37576, 5.3, 5.37576])},
                        free=HFB_FREE)
    res = mlid.fit(eq, d, max_iter=20)
    assert fit["parameters"] == HFB_FREE and fit["converged"]
    np.testing.assert_allclose(fit["estimate"], res.estimate, rtol=1e-9)
    np.testing.assert_allclose(fit["sigma"], res.sigma, rtol=1e-7)


@needs_hfb
@pytest.mark.parametrize("change, said", [
    (dict(definitions="'C_L = 3'"), "group &model: longitudinal model: table 'C_L = 3' names no "
                                    "coefficient of the model (its labels: C_D0, C_Lalpha, ...)"),
    (dict(definitions="'C_Lbeta(alpha) = 0 1'"), "group &model: longitudinal model: table "
     "'C_Lbeta(alpha) = 0 1' names no coefficient of the model (its labels: C_D0, C_Lalpha, ...)"),
    (dict(params="'C_mq = -20'"), "group &model: params entry 'C_mq = -20' is not 'NAME[i] = "
     "value' of a table's value (kind = 'longitudinal': its coefficients start in cd, cl, cm)"),
    (dict(params="'C_Lalpha[4] = 1'"), "group &model: params entry 'C_Lalpha[4] = 1' is not "
                                       "'NAME[i] = value' of a table's value"),
    (dict(extra="q = 0, 1e-4, 0, 0,"), "group &model: kind = 'longitudinal' with tables is "
     "written as equations, which have no process noise: q and s must be zero"),
    (dict(extra="xdot = 'q', 'q', 'q', 'q',"), "group &model: xdot, outputs, definitions and "
     "params are for kind = 'equations', 'sixdof' or 'flight_path' (definitions and params also "
     "for 'longitudinal': its tables), not 'longitudinal'")])
def test_a_longitudinal_deck_refuses_a_bad_table_entry(tmp_path, change, said):
    from conftest import refused_by_both
    refused_by_both(long_deck(tmp_path, **change), said, cwd=tmp_path)
