"""The nonlinear longitudinal model on the real HFB-320 record
(../shared/data, read from there; skipped when absent) and on synthetic data."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import BIN, REPO, finite_difference

DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"
DECK = REPO / "cases" / "hfb320" / "hfb320.nml"
needs_data = pytest.mark.skipif(not DATA.is_file(),
                                reason=f"real flight data not found at {DATA}")

# Reference result of ../shared/data/README.md (a second implementation).
REF = np.array([0.117758, -0.0517459, 0.234846, -0.204711, 0.363549, 3.21232, 0.134413,
                -0.0139045, -1.00241, -27.0570, -1.43707])
REF_SIGMA = np.array([0.00323, 0.00280, 0.00639, 0.0196, 0.0173, 0.0394, 0.00512, 0.00473,
                      0.00867, 0.681, 0.0174])
REF_DET_R = 3.0161e-24


@needs_data
def test_hfb320_reproduces_the_reference():
    case = mlid.read_deck(DECK)[0]
    out, res = mlid.cli.deck.run_case(case)
    assert res.converged
    assert np.all(np.abs(res.estimate - REF) / REF_SIGMA < 0.1), (res.estimate - REF) / REF_SIGMA
    assert np.all(np.abs(res.sigma / REF_SIGMA - 1) < 0.05), res.sigma / REF_SIGMA
    assert abs(res.det_r / REF_DET_R - 1) < 0.005


@needs_data
def test_hfb320_both_front_ends_agree(tmp_path):
    py = subprocess.run([str(BIN / "mlid"), "run", str(DECK), "--json", str(tmp_path / "py.json")],
                        capture_output=True, text=True)
    fo = subprocess.run([str(BIN / "mlid-batch"), str(DECK), "--json", str(tmp_path / "fo.json")],
                        capture_output=True, text=True)
    assert py.returncode == 0 and fo.returncode == 0, (py.stderr, fo.stderr)
    cases_py = json.loads((tmp_path / "py.json").read_text())
    cases_fo = json.loads((tmp_path / "fo.json").read_text())
    # plain, from an equation-error start, filter error (EKF) and with the steady-state gain;
    # then FVSysID's ml_fem2 in three criteria (tests/test_hfb320_fem.py)
    assert len(cases_py) == len(cases_fo) == 7
    for a, b in zip(cases_py, cases_fo):
        assert a["parameters"][:3] == b["parameters"][:3] == ["C_D0", "C_DV", "C_Dalpha"]
        np.testing.assert_allclose(a["estimate"], b["estimate"], rtol=1e-10, atol=0)
        np.testing.assert_allclose(a["sigma"], b["sigma"], rtol=1e-10, atol=0)
    # both starts reach the same maximum
    np.testing.assert_allclose(cases_py[0]["estimate"], cases_py[1]["estimate"], rtol=1e-5)
    # turbulence (process noise) explains the record far better than output error
    assert cases_py[2]["converged"] and cases_py[2]["cost"] < cases_py[0]["cost"] - 1000
    # the steady-state gain (linearised at the start) lands near the EKF's maximum
    ekf, steady = cases_py[2], cases_py[3]
    assert steady["converged"] and abs(steady["cost"] - ekf["cost"]) < 1.0
    z = (np.array(steady["estimate"]) - ekf["estimate"]) / np.array(ekf["sigma"])
    assert np.max(np.abs(z)) < 0.5, z


def _hfb_like(free, regressors=None, values=None):
    regs = regressors or {"CD": ["1", "V/V0", "alpha"], "CL": ["1", "V/V0", "alpha"],
                          "Cm": ["1", "V/V0", "alpha", "qhat", "de"]}
    values = values or {"CD": REF[:3], "CL": REF[3:6], "Cm": REF[6:]}
    const = dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                            7472.0, 0.0524, 0.792, 1.215]))
    r = [0.33, 5.2e-6, 1.5e-4, 6.9e-6, 6.2e-5, 6.0e-4, 4.7e-2]   # ~ the HFB residual variances
    return mlid.LongitudinalModel(regs, values, const, x0=[106.0, 0.11, 0.105, -0.003],
                                  free=free, r=r)


def _inputs():
    t = np.arange(601) * 0.1
    de = -0.008 + input_signal("3211", 0.03, 2.0, 1.5, 0.1, 601) \
        + input_signal("pulse", -0.04, 40.0, 2.0, 0.1, 601)
    return t, np.column_stack([de, np.full(601, 11600.0)])


COEFFS = [f"cd({k})" for k in (1, 2, 3)] + [f"cl({k})" for k in (1, 2, 3)] + \
    [f"cm({k})" for k in (1, 2, 3, 4, 5)]


def test_synthetic_longitudinal_fit_recovers_truth():
    truth = _hfb_like(COEFFS)
    t, u = _inputs()
    data, _ = mlid.simulate(truth, t, u, seed=21)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.2, 1.0))
    res = mlid.fit(start, data)
    assert res.converged
    z = (res.estimate - truth.theta[truth.free_indices()]) / res.sigma
    assert np.all(np.abs(z) < 3), z


def test_longitudinal_gradient_matches_finite_differences():
    regs = {"CD": ["1", "V/V0", "alpha", "alpha^2"], "CL": ["1", "alpha", "qhat"],
            "Cm": ["1", "V/V0", "alpha", "alpha^2", "qhat", "de"]}
    free = [f"cd({k})" for k in range(1, 5)] + [f"cl({k})" for k in range(1, 4)] + \
        [f"cm({k})" for k in range(1, 7)] + ["x0(1)", "x0(2)", "x0(4)", "bias(6)"]
    values = {"CD": [0.118, -0.052, 0.235, 0.5], "CL": [0.16, 3.21, 5.0],
              "Cm": [0.12, -0.014, -1.0, 0.5, -27.0, -1.44]}
    model = _hfb_like(free, regs, values)
    t, u = _inputs()
    data, _ = mlid.simulate(model, t[:300], u[:300], seed=4)
    start = model.with_theta(model.theta * np.where(model.free_mask == 1, 1.05, 1.0))
    ev = mlid.evaluate(start, data)
    fd = finite_difference(lambda th: mlid.evaluate(start.with_theta(th), data)["cost"],
                           start.theta, start.free_indices(), rel=1e-4, floor=1e-2,
                           five_point=True)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1.0)
    assert np.max(rel) < 1e-6, dict(zip(start.free_names(), rel))


def test_ekf_without_process_noise_is_the_output_error_predictor():
    """With q = 0 and P(0) = 0 the extended Kalman filter's gain is zero: its
    predictions are the output-error outputs and B = R (eq. 4.22 ff.)."""
    model = _hfb_like(COEFFS)
    t, u = _inputs()
    data, _ = mlid.simulate(model, t[:200], u[:200], seed=1)
    oe = mlid.evaluate(model, data)
    fe = mlid.evaluate(model, data, method="filter_error")
    np.testing.assert_allclose(fe["yhat"], oe["yhat"], rtol=1e-12, atol=1e-12)
    nu = data.y - fe["yhat"]
    r = np.asarray(model.r)
    expected = 0.5 * (np.sum(nu**2 / r) + len(nu) * np.sum(np.log(r)))
    assert fe["cost"] == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("partials", [True, False])
def test_ekf_gradient_matches_finite_differences(partials):
    """With gain partials the EKF's gradient (forward-difference filter
    sensitivities) is that of its cost; without, the analytic sensitivities
    hold the gain: the gradient is near it for the coefficients (measured: up to
    0.9%) and misses the noise variances altogether."""
    free = COEFFS + ["q(2)", "q(4)", "r(1)", "r(2)", "r(4)"]
    model = _hfb_like(free)
    model.q = np.array([0.0, 1e-5, 0.0, 1e-4])
    t, u = _inputs()
    data, _ = mlid.simulate(model, t[:300], u[:300], seed=2)
    start = model.with_theta(model.theta * np.where(model.free_mask == 1, 1.03, 1.0))
    ev = mlid.evaluate(start, data, method="filter_error", partials=partials)
    idx = start.free_indices()
    fd = finite_difference(
        lambda th: mlid.evaluate(start.with_theta(th), data, method="filter_error")["cost"],
        start.theta, idx, rel=1e-5, floor=1e-12)
    rel = np.abs(fd - ev["gradient"]) / np.maximum(np.abs(fd), 1e-3 * np.max(np.abs(fd)))
    if partials:
        assert np.max(rel) < 1e-3, dict(zip(start.free_names(), rel))   # measured 1e-4
    else:
        assert 1e-4 < np.max(rel[:len(COEFFS)]) < 0.2, dict(zip(start.free_names(), rel))


def test_ekf_fit_recovers_truth_with_turbulence():
    """Data with process noise on alpha-dot and q-dot: filter error (EKF)
    recovers the aerodynamic coefficients and the noise variances within 3
    sigma; output error, which ignores the turbulence, fits worse."""
    free = COEFFS + ["q(2)", "q(4)"] + [f"r({i})" for i in range(1, 8)]
    truth = _hfb_like(free)
    truth.q = np.array([0.0, 4e-6, 0.0, 4e-5])
    t, u = _inputs()
    data, _ = mlid.simulate(truth, t, u, seed=5)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.1, 1.0))
    fe = mlid.fit(start, data, method="filter_error",
                  bounds={n: (0.0, None) for n in ("q(2)", "q(4)")})
    assert fe.converged
    z = (fe.estimate - truth.theta[truth.free_indices()]) / fe.sigma
    assert np.all(np.abs(z) < 3), dict(zip(fe.names, z))
    oe = mlid.fit(_hfb_like(COEFFS).with_theta(start.theta), data)
    z_oe = (oe.estimate - truth.theta[oe.model.free_indices()]) / oe.sigma
    assert np.max(np.abs(z_oe)) > np.max(np.abs(z[:len(COEFFS)]))


@pytest.mark.parametrize("change, phrase", [
    (("'alpha', 'qhat', 'de'", "'alpha', 'qbar', 'de'"), "regressor 'qbar' does not exist"),
    (("0.792, 1.215,", "0.792,"), "constants needs 9 values"),
    (("'cm(5)',", "'cm(6)',"), "'cm(6)' does not exist"),
])
def test_bad_longitudinal_decks(tmp_path, change, phrase):
    text = DECK.read_text().replace(*change).replace("../../../shared/data/hfb320_1_10.asc",
                                                     str(DATA))
    deck = tmp_path / "bad.nml"
    deck.write_text(text)
    for cmd in ([str(BIN / "mlid"), "run", str(deck)], [str(BIN / "mlid-batch"), str(deck)]):
        out = subprocess.run(cmd, capture_output=True, text=True)
        assert out.returncode == 1 and phrase in out.stderr, (cmd[0], out.stderr)
        assert "Traceback" not in out.stderr


def test_equation_error_startup_lands_near_the_truth():
    truth = _hfb_like(COEFFS)
    t, u = _inputs()
    data, _ = mlid.simulate(truth, t, u, seed=8)
    far = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.5, 1.0))
    res = mlid.fit(far, data, startup="equation_error")
    assert res.converged
    tr = truth.theta[truth.free_indices()]
    # the start-up alone is a one-pass least squares: much nearer than the start, overall
    # (single coefficients such as C_L0, collinear with C_LV, may not be)
    def rms(x):
        return np.sqrt(np.mean(((x - tr) / res.sigma) ** 2))
    assert rms(res.start) < rms(far.theta[far.free_indices()]) / 3
    assert np.all(np.abs((res.estimate - tr) / res.sigma) < 3)


def test_equation_error_needs_every_state_measured():
    model = mlid.LinearModel([[-1.0, 0.5], [-0.3, -2.0]], [[1.0], [0.4]], [[1.0, 1.0]],
                             free=["f(1,1)"])
    t = np.arange(100) * 0.05
    data, _ = mlid.simulate(model, t, np.sin(t)[:, None], [0.01], seed=1)
    with pytest.raises(mlid.InputError, match="every state measured: state 1"):
        mlid.fit(model, data, startup="equation_error")


@needs_data
@pytest.mark.parametrize("edit, phrase, code", [
    (lambda tab: tab[:, 5].__imul__(57.29578), "look like degrees", 0),
    (lambda tab: tab[:, 4].__imul__(0.0), "positive airspeed", 1),
])
def test_units_checks_in_both_front_ends(tmp_path, edit, phrase, code):
    table = np.loadtxt(DATA)
    edit(table)
    np.savetxt(tmp_path / "hfb.asc", table)
    text = DECK.read_text().split("\n&case title = 'HFB-320 flight 1, output error from")[0]
    (tmp_path / "deck.nml").write_text(text.replace("../../../shared/data/hfb320_1_10.asc",
                                                    str(tmp_path / "hfb.asc")))
    for cmd in ([str(BIN / "mlid"), "run", str(tmp_path / "deck.nml")],
                [str(BIN / "mlid-batch"), str(tmp_path / "deck.nml")]):
        out = subprocess.run(cmd, capture_output=True, text=True)
        assert out.returncode == code and phrase in out.stderr, (cmd[0], out.stderr)
        assert "Traceback" not in out.stderr


@needs_data
def test_the_case_script_prints_and_exports_the_results_table(tmp_path):
    """hfb320.py: the reference comparison and, per case, the table it also
    writes as CSV, LaTeX and JSON; the files hold the fit's own numbers."""
    import csv
    import sys
    out = subprocess.run([sys.executable, str(REPO / "cases" / "hfb320" / "hfb320.py"),
                          str(tmp_path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "largest |diff|/sigma 0.01" in out.stdout and "case 1 results table" in out.stdout
    case = mlid.read_deck(DECK)[0]
    _, res = mlid.cli.deck.run_case(case)
    rows = list(csv.DictReader((tmp_path / "hfb320_case1.csv").open()))
    assert [r["name"] for r in rows] == res.names
    assert [r["unit"] for r in rows] == ["-", "-", "1/rad", "-", "-", "1/rad", "-", "-",
                                         "1/rad", "1/rad", "1/rad"]
    np.testing.assert_allclose([float(r["sigma_corrected"]) for r in rows], res.sigma_corrected,
                               rtol=1e-12)
    assert json.loads((tmp_path / "hfb320_case3.json").read_text())["rows"][-1]["unit"] == "m2/s4"
    assert r"\toprule" in (tmp_path / "hfb320_case1.tex").read_text()
    # the README's table of case 3 (EKF) against case 4 (steady-state gain) is the script's
    block = out.stdout.split("case 3 (extended Kalman filter) against case 4", 1)[1]
    printed = {f[0]: f[1:6] for f in (ln.split() for ln in block.splitlines()[2:22])}
    readme = (REPO / "cases" / "hfb320" / "README.md").read_text(encoding="utf-8")
    table = next(b for b in readme.split("## Filter error with the steady-state gain", 1)[1]
                 .split("\n\n") if b.startswith("| |"))
    rows = [[c.strip().replace("−", "-") for c in r.strip("| ").split("|")]
            for r in table.splitlines()[2:]]
    rows = [cells for cells in rows if cells[1].endswith(")")]    # estimate (sigma)
    names = {"C_Dα": "C_Dalpha", "C_Lα": "C_Lalpha", "C_mα": "C_malpha", "C_mδe": "C_mde"}
    assert len(rows) == len(printed) == 20
    for cells in rows:
        name = names.get(cells[0], cells[0].split(",")[0])
        ekf, steady = (c.replace("(", "").replace(")", "").split() for c in cells[1:3])
        assert [*ekf, *steady, cells[3]] == printed[name], name
