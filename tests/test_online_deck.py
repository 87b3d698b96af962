"""The online job (issue 45 item 4; job = 'online', &online): Fourier-
transform regression, the augmented-state filters and recursive least
squares over a deck's record in both front ends, the history written as a
record &data reads, the report's last estimates and convergence times the
Python API's, and bad settings one line each."""

import json

import numpy as np
import pytest

import mlid
from conftest import REPO, refused_by_both, run_both

DATA = REPO.parent / "shared" / "data"
needs_data = pytest.mark.skipif(not (DATA / "refs" / "recursive" / "hist_tc11_FTR.csv").is_file(),
                                reason="the ATTAS records and references are not in ../shared")

#: A short-period model simulated with a 3-2-1-1, then fitted online.
SIMULATE = """&case title = 'record', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 1.0, -4.0, -1.5,   g = 0.1, -6.0,   h = 1, 0, 0, 1, r = 1e-6, 1e-6 /
&simulate out = 'rec.dat', t_end = 20.0, dt = 0.02, seed = 3, input_shape = '3211',
    amplitude = 1.0, t_start = 1.0, pulse_width = 0.5 /
"""
ONLINE = """&case title = 'online', job = 'online' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = 0, 0, 0, 0,   g = 0, 0,   h = 1, 0, 0, 1,
    names = 'Za', 'Zq', 'Ma', 'Mq', 'Zd', 'Md',
    free = 'f(1,1)', 'f(1,2)', 'f(2,1)', 'f(2,2)', 'g(1,1)', 'g(2,1)' /
&data file = 'rec.dat', columns = 't', 'de', 'a', 'q', time_col = 't', input_cols = 'de',
    output_cols = 'a', 'q' /
&online f_min = 0.1, f_max = 1.45, n_freq = 28, every = 50, trim = 0, out = 'hist.dat' /
"""


def test_online_deck_in_both_front_ends_is_the_python_api(tmp_path):
    """A simulated record (noise 1e-3): both front ends print and write the
    same bytes; the history file's columns are mlid.online.ftr's estimates
    and sigma on the same record (a second path: Python's own call); the
    last estimates are within 2% of the truth; the JSON's convergence times
    are OnlineEstimate.convergence_time()'s."""
    (tmp_path / "sim.nml").write_text(SIMULATE)
    assert run_both(tmp_path / "sim.nml", cwd=tmp_path)[1].returncode == 0
    deck = tmp_path / "online.nml"
    deck.write_text(ONLINE)
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0, runs[0].stderr
    assert runs[0].stdout == runs[1].stdout
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    out = json.loads((tmp_path / "mlid.json").read_text())[0]
    rec = np.loadtxt(tmp_path / "rec.dat")
    est = mlid.online.ftr(rec[:, 0], rec[:, 2:4], rec[:, 1], np.linspace(0.1, 1.45, 28),
                          every=50, trim=0)
    hist = mlid.FlightData.load(tmp_path / "hist.dat", "t", ["Za", "Zq", "Zd", "Ma", "Mq", "Md"],
                                ["sigma_Za", "sigma_Md"])
    # the record starts at the first solve that determined every estimate
    first = np.flatnonzero(np.all(np.isfinite(est.estimates), axis=1))[0]
    assert first > 0 and np.all(np.isnan(est.estimates[0]))
    np.testing.assert_allclose(hist.t, est.t[first:], rtol=1e-15)
    np.testing.assert_allclose(hist.u, est.estimates[first:], rtol=1e-13)
    np.testing.assert_allclose(hist.y[:, 0], est.sigma[first:, 0], rtol=1e-13)
    assert out["parameters"] == ["Za", "Zq", "Zd", "Ma", "Mq", "Md"]
    np.testing.assert_allclose(out["estimates"][-1], [-1.0, 1.0, 0.1, -4.0, -1.5, -6.0],
                               rtol=0.02, atol=0.005)
    assert out["converged"] == pytest.approx(list(est.convergence_time().values()))
    assert "converged [s]" in runs[0].stdout


@needs_data
def test_tc11_online_deck_reproduces_the_textbooks_ftr(tmp_path):
    """The textbook's test case 11 as a deck (fAttasElv1 and Elv2 joined,
    0.2-1.48 Hz, 33 frequencies, a solve a second, trim of 10, from sample
    2): every solve's estimates within 1e-6 of the reference's sigma."""
    import pandas as pd
    deck = tmp_path / "tc11.nml"
    deck.write_text(f"""&case title = 'tc11 ftr', job = 'online' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = 0, 0, 0, 0,   g = 0, 0,   h = 1, 0, 0, 1,
    names = 'Zal', 'Zq1', 'Mal', 'Mq', 'Zde', 'Mde',
    free = 'f(1,1)', 'f(1,2)', 'f(2,1)', 'f(2,2)', 'g(1,1)', 'g(2,1)' /
&data file = '{DATA}/fAttasElv1.mat', '{DATA}/fAttasElv2.mat',
    columns = 'T[s]', 'c2', 'c3', 'c4', 'c5', 'c6', 'c7', 'QRGY[deg/s]', 'c9', 'c10', 'c11', 'c12',
              'ALCG[deg]', 'c14', 'c15', 'c16', 'c17', 'c18', 'c19', 'c20', 'c21', 'DELV[deg]',
    time_col = 'T', input_cols = 'DELV', output_cols = 'ALCG', 'QRGY', dt = 0.04 /
&online f_min = 0.2, f_max = 1.48, n_freq = 33, every = 25, trim = 10, first = 2,
    out = 'hist.dat' /
""")
    runs = run_both(deck, "--json", "o.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    out = json.loads((tmp_path / "o.json").read_text())[0]
    ref = pd.read_csv(DATA / "refs" / "recursive" / "hist_tc11_FTR.csv")
    names = ["Zal", "Zq1", "Zde", "Mal", "Mq", "Mde"]
    assert out["parameters"] == names
    dev = np.abs(np.array(out["estimates"]) - ref[names].to_numpy()) / \
        ref[[f"sig_{n}" for n in names]].to_numpy()
    assert np.max(dev) < 1e-6


@pytest.mark.parametrize("change, new, message", [
    ("&online f_min", "&online estimator = 'kalman', f_min",
     "group &online: estimator must be 'ftr' (Fourier-transform regression), 'ekf', 'ukf', "
     "'ukf_augmented' (the augmented-state filters), 'efrls' (the extended filter as "
     "forgetting-factor least squares) or 'rls' (recursive least squares), not 'kalman'"),
    ("n_freq = 28", "n_freq = 1", "the band needs 0 < f_min < f_max (Hz) and n_freq >= 2"),
    ("every = 50", "every = 0", "every (samples between solves) must be >= 1"),
    (", out = 'hist.dat'", "", "out (the record of the estimates' history to write) is missing"),
    ("'g(1,1)', 'g(2,1)' /", "'g(1,1)' /",
     "'ftr' estimates every entry of F and G: free must list them all (6)"),
    ("h = 1, 0, 0, 1,", "h = 1, 0, 0, 2,", "'ftr' needs H = I and D = 0"),
])
def test_bad_online_settings_one_line(tmp_path, change, new, message):
    deck = tmp_path / "bad.nml"
    text = ONLINE.replace(change, new)
    if "names" in text and "'g(2,1)'" not in text:
        text = text.replace("'Zd', 'Md'", "'Zd'")
    deck.write_text(text)
    refused_by_both(deck, message, cwd=tmp_path)
    assert not (tmp_path / "hist.dat").exists()


@needs_data
@pytest.mark.parametrize("estimator, ref_name", [("ekf", "EKF"), ("ukf", "UKF")])
def test_tc11_online_filter_decks_reproduce_the_textbooks(tmp_path, estimator, ref_name):
    """cases/online/tc11_ekf.nml (and the same with estimator 'ukf'): the
    textbook's test case 11 by the augmented-state filters, its header's
    settings, in both front ends alike; every sample's estimates within 1e-6
    of the reference's sigma (the deck's f(1,2) is the reference's 1 + Zq)."""
    import pandas as pd
    deck = tmp_path / "tc11.nml"
    text = (REPO / "cases" / "online" / "tc11_ekf.nml").read_text()
    deck.write_text(text.replace("../../../shared", str(REPO.parent / "shared"))
                    .replace("estimator = 'ekf'", f"estimator = '{estimator}'"))
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    out = json.loads((tmp_path / "mlid.json").read_text())[0]
    ref = pd.read_csv(DATA / "refs" / "recursive" / f"hist_tc11_{ref_name}.csv")
    names = ["Z0", "Zal", "Zq", "Zde", "M0", "Mal", "Mq", "Mde"]
    est = np.array(out["estimates"])
    est[:, out["parameters"].index("Zq1")] -= 1.0
    order = [out["parameters"].index("Zq1" if n == "Zq" else n) for n in names]
    ref_est = ref[names].to_numpy()
    ref_sig = ref[[f"sig_{n}" for n in names]].to_numpy()
    assert np.max(np.abs(est[:, order] - ref_est) / ref_sig) < 1e-6


def test_online_history_figure_draws_each_parameter_with_its_band(tmp_path):
    """mlid.plots.online_history: a panel per parameter with the ±2σ band,
    the online estimate, the batch estimate (dashed) and where it
    converged; written whole to the path given."""
    import matplotlib
    matplotlib.use("Agg")
    from mlid.design.signals import multistep
    t = 0.02 * np.arange(1000)
    de = multistep("3211", 1.0, 1.0, 0.5, 0.02, 1000)
    model = mlid.LinearModel(F=[[-1.0, 1.0], [-4.0, -1.5]], G=[[0.1], [-6.0]], H=np.eye(2),
                             r=[1e-6, 1e-6])
    data, _ = mlid.simulate(model, t, de[:, None], seed=1)
    est = mlid.online.ftr(t, data.y, de, np.arange(0.1, 1.5, 0.05), every=50)
    batch = {"f(1,1)": -1.0, "f(2,1)": -4.0, "g(2,1)": -6.0}
    fig = mlid.plots.online_history(est, batch=batch, path=tmp_path / "history.png")
    axes = [ax for ax in fig.axes if ax.get_title(loc="left")]
    assert [ax.get_title(loc="left") for ax in axes] == est.names
    titled = {ax.get_title(loc="left"): ax for ax in axes}
    dashed = [ln for ln in titled["g(2,1)"].get_lines() if ln.get_linestyle() == "--"]
    assert len(dashed) == 1 and dashed[0].get_ydata()[0] == -6.0
    assert len(titled["g(2,1)"].collections) == 1          # the sigma band
    assert (tmp_path / "history.png").stat().st_size > 10_000


# --- recursive least squares (estimator = 'rls') --------------------------

needs_tc23 = pytest.mark.skipif(not (DATA / "refs" / "recursive" / "data_tc23_RLS.csv").is_file(),
                                reason="the recursive references are not in ../shared")

#: cases/online/tc23_rls.nml's parameters, the reference's order
TC23 = ["CD0", "CDal", "CL0", "CLal", "Cm0", "Cmal", "Cmq", "Cmde", "CY0", "CYbe", "Cl0", "Clbe",
        "Clp", "Clr", "Clda", "Cn0", "Cnbe", "Cnp", "Cnr", "Cndr"]


def _tc23_deck(tmp_path, change=None, new=None):
    """cases/online/tc23_rls.nml in tmp_path, the record read from ../shared."""
    text = (REPO / "cases" / "online" / "tc23_rls.nml").read_text()
    text = text.replace("../../../shared", str(REPO.parent / "shared"))
    if change:
        assert change in text
        text = text.replace(change, new)
    deck = tmp_path / "tc23.nml"
    deck.write_text(text)
    return deck


def _reference_final():
    """ref_tc23_RLS.txt's [final] table: name -> (final, sigma)."""
    out, rows = {}, False
    for line in (DATA / "refs" / "recursive" / "ref_tc23_RLS.txt").read_text().splitlines():
        if line.startswith("# [final]"):
            rows = True
        elif line.startswith("#"):
            rows = False
        elif rows and line.split():
            f = line.split()
            out[f[0]] = (float(f[1]), float(f[2]))
    return out


@needs_tc23
def test_tc23_rls_deck_reproduces_the_textbook(tmp_path):
    """cases/online/tc23_rls.nml (the six coefficients' regressions of test
    case 23 on the reference's exact regressors, its header's settings):
    both front ends print and write the same bytes; the final estimates
    equal the reference's to 1e-6 relative (measured 3.5e-10: the table's ten digits), every sample's
    history the reference's to 1e-6 of each parameter's final size (measured 2.1e-9; its
    hist_tc23_RLS.csv); the history file is mlid.online.rls's estimates and
    sigma on the same columns (Python's own call, a second path), and the
    JSON's convergence times are OnlineEstimate.convergence_time()'s."""
    import pandas as pd
    deck = _tc23_deck(tmp_path)
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert runs[0].stderr == runs[1].stderr == ""
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    out = json.loads((tmp_path / "mlid.json").read_text())[0]
    assert out["parameters"] == TC23 and out["estimator"] == "rls"
    est = np.array(out["estimates"])
    final = _reference_final()
    want = np.array([final[n][0] for n in TC23])
    np.testing.assert_allclose(est[-1], want, rtol=1e-6, atol=0)
    ref = pd.read_csv(DATA / "refs" / "recursive" / "hist_tc23_RLS.csv")
    assert np.max(np.abs(est - ref[TC23].to_numpy()) / np.abs(want)) < 1e-6
    # the same regressions through the Python API
    d = pd.read_csv(DATA / "refs" / "recursive" / "data_tc23_RLS.csv")
    regs = {"CD": ["al"], "CL": ["al"], "Cm": ["al", "qn", "de"], "CY": ["be"],
            "Cl": ["be", "pn", "rn", "da"], "Cn": ["be", "pn", "rn", "dr"]}
    hist = np.loadtxt(tmp_path / "tc23_rls_history.dat")
    k, conv = 0, {}
    for z, cols in regs.items():
        X = np.column_stack([np.ones(len(d))] + [d[c] for c in cols])
        r = mlid.online.rls(X, d[z], names=TC23[k:k + X.shape[1]], t=d["t"],
                            p0=1e7 if z == "Cm" else 1e6)
        np.testing.assert_allclose(hist[:, 1 + k:1 + k + X.shape[1]], r.estimates, rtol=1e-12,
                                   atol=1e-14)
        np.testing.assert_allclose(hist[:, 21 + k:21 + k + X.shape[1]], r.sigma, rtol=1e-12,
                                   atol=1e-14)
        conv.update(r.convergence_time())
        k += X.shape[1]
    assert out["converged"] == pytest.approx([conv[n] for n in TC23], nan_ok=True)
    assert "recursive least squares: 2128 samples" in runs[0].stdout
    assert out["measure"] == "a-priori residual" and np.shape(out["measure_values"]) == (2128, 6)


@needs_tc23
@pytest.mark.parametrize("change, new, message", [
    ("p0 = 1e6, 1e6, 1e7, 1e6, 1e6, 1e6", "p0 = 1e6, 1e7",
     "group &online: 'rls' takes one p0 (P0 = p0 I) for all outputs or one per output (6), got 2"),
    ("p0 = 1e6, 1e6, 1e7,", "p0 = 1e6, -1e6, 1e7,", "group &online: p0 must be > 0 and finite"),
    ("forgetting = 1.0,", "forgetting = 1.0, p_max = -1,",
     "group &online: p_max (the bound on trace(P)/n) must be >= 0"),
    ("forgetting = 1.0,", "forgetting = 1.5,", "forgetting (lambda) must be in (0, 1]"),
    ("forgetting = 1.0,", "forgetting = 1.0, q = 1e-6,",
     "group &online: 'rls' does not take q (it takes p0 p_max forgetting)"),
    ("forgetting = 1.0,", "every = 10,", "'rls' does not take every (it takes p0 p_max forgetting)"),
    ("forgetting = 1.0,", "forgetting = 1.0, delta = 1e-4, r_fade = 0.9,",
     "'rls' does not take delta (it takes p0 p_max forgetting)"),
    ("forgetting = 1.0,", "forgetting = 1.0, trim = 5,", "'rls' does not take trim"),
    ("forgetting = 1.0,", "forgetting = 1.0, tie = 'CDal = 2*CLal',", None),
    ("'Cm0 + Cmal*al + Cmq*qn", "'Cm0 + Cmal*al*Cmal + Cmq*qn",
     "'rls' regresses outputs linear in the free parameters; output Cm is not (sample 1)"),
    ("'CY0 + CYbe*be'", "'CY0 + CYbe*be + Cm0*de'",
     "'rls' regresses each output on its own parameters; Cm0 enters 2 outputs"),
    ("'CY0 + CYbe*be'", "'CY0 + CYbe*be*0'",
     "'rls': CYbe enters no output (its regressor is zero throughout the record)"),
])
def test_bad_rls_settings_one_line(tmp_path, change, new, message):
    """Each bad setting of the rls deck: one line from both front ends, no
    history written.  A setting rls does not take is refused, not ignored;
    a tie would leave its parameter at its start, so it is refused too."""
    if message is None:                 # the tie goes in &model
        change, new = "free = 'CD0', 'CDal',", "tie = 'CDal = 2*CLal', free = 'CD0',"
        message = "'rls' does not follow ties (a tied parameter would stay at its start)"
    deck = _tc23_deck(tmp_path, change, new)
    refused_by_both(deck, message, cwd=tmp_path)
    assert not (tmp_path / "tc23_rls_history.dat").exists()


def test_rls_needs_a_model_of_no_states(tmp_path):
    deck = tmp_path / "bad.nml"
    deck.write_text(ONLINE.replace("&online f_min = 0.1, f_max = 1.45, n_freq = 28, every = 50, "
                                   "trim = 0,", "&online estimator = 'rls',"))
    refused_by_both(deck, "'rls' regresses the outputs of a model with no states (nx = 0, e.g. "
                    "kind = 'equations'), not nx = 2", cwd=tmp_path)
    deck.write_text(ONLINE.replace("n_freq = 28,", "n_freq = 28, p_max = 10,"))
    refused_by_both(deck, "group &online: 'ftr' does not take p_max (it takes f_min f_max n_freq "
                    "every trim first forgetting)", cwd=tmp_path)


RLS_STATES = """&case title = 'equation error by rls', job = 'online' /
&model kind = 'equations', input_names = 'a', 'q', 'de', output_names = 'adot', 'qdot',
    params = 'Za = 0', 'Zq = 0', 'Zd = 0', 'Ma = 0', 'Mq = 0', 'Md = 0',
    outputs = 'Za*a + Zq*q + Zd*de', 'Ma*a + Mq*q + Md*de',
    free = 'Za', 'Zq', 'Zd', 'Ma', 'Mq', 'Md' /
&data file = 'rec.dat', columns = 't', 'de', 'a', 'q', time_col = 't',
    derived = 'adot = deriv(a)', 'qdot = deriv(q)',
    input_cols = 'a', 'q', 'de', output_cols = 'adot', 'qdot' /
&online estimator = 'rls', out = 'hist.dat' /
"""


def test_rls_deck_regresses_state_equations_on_smoothed_derivatives(tmp_path):
    """The state equations x_dot = F x + G u as 'rls' regressions: the
    measured states' smoothed derivatives (&data derived = 'deriv(a)') the
    outputs of an equations model of no states.  On the simulated short
    period (noise 1e-3) both front ends alike; the history is
    mlid.online.rls on mlid.deriv's derivatives (a second path) to 1e-10;
    the last estimates within 6 % of the truth (measured 4.6 % at most: the
    smoothed derivative's bias on Zd)."""
    (tmp_path / "sim.nml").write_text(SIMULATE)
    assert run_both(tmp_path / "sim.nml", cwd=tmp_path)[1].returncode == 0
    deck = tmp_path / "rls.nml"
    deck.write_text(RLS_STATES)
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
    out = json.loads((tmp_path / "mlid.json").read_text())[0]
    rec = np.loadtxt(tmp_path / "rec.dat")
    t, de, a, q = rec.T
    X = np.column_stack([a, q, de])
    hist = np.loadtxt(tmp_path / "hist.dat")
    for k, x in enumerate((a, q)):
        r = mlid.online.rls(X, mlid.deriv(t, x), t=t)
        np.testing.assert_allclose(hist[:, 1 + 3 * k:4 + 3 * k], r.estimates, rtol=1e-10,
                                   atol=1e-12)
    np.testing.assert_allclose(out["estimates"][-1], [-1.0, 1.0, 0.1, -4.0, -1.5, -6.0],
                               rtol=0.06)


def test_timing_is_asked_for_and_changes_nothing_else(tmp_path):
    """timing = .true.: one more report line (the estimator's time per
    sample beside the sampling interval, 20 ms here) and seconds_per_sample
    in the JSON, from both front ends; everything else the untimed run's
    bytes. Untimed, neither appears (the case decks compare bytes)."""
    (tmp_path / "sim.nml").write_text(SIMULATE)
    assert run_both(tmp_path / "sim.nml", cwd=tmp_path)[1].returncode == 0
    (tmp_path / "plain.nml").write_text(ONLINE)
    (tmp_path / "timed.nml").write_text(ONLINE.replace("out = 'hist.dat'",
                                                       "out = 'hist.dat', timing = .true."))
    plain = run_both(tmp_path / "plain.nml", "--json", "plain-{exe}.json", cwd=tmp_path)
    timed = run_both(tmp_path / "timed.nml", "--json", "timed-{exe}.json", cwd=tmp_path)
    for exe, p, t in zip(("mlid", "mlid-batch"), plain, timed):
        assert p.returncode == 0 and t.returncode == 0, t.stderr
        extra = [line for line in t.stdout.splitlines() if line not in p.stdout.splitlines()]
        assert len(extra) == 1 and extra[0].startswith(" time per sample:"), extra
        assert "sampling interval  2.000E+01 ms" in extra[0]
        assert "time per sample" not in p.stdout
        pj = json.loads((tmp_path / f"plain-{exe}.json").read_text())[0]
        tj = json.loads((tmp_path / f"timed-{exe}.json").read_text())[0]
        assert "seconds_per_sample" not in pj and tj.pop("seconds_per_sample") > 0
        assert tj == pj


def test_plots_draw_the_online_history(tmp_path):
    """`mlid run --plots DIR` on an online deck writes its history figure
    (mlid.plots.online_history of the JSON's estimates and sigma)."""
    import subprocess
    from conftest import BIN
    (tmp_path / "sim.nml").write_text(SIMULATE)
    assert run_both(tmp_path / "sim.nml", cwd=tmp_path)[1].returncode == 0
    (tmp_path / "online.nml").write_text(ONLINE)
    run = subprocess.run([str(BIN / "mlid"), "run", "online.nml", "--plots", "figs"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    png = tmp_path / "figs" / "case1_online.png"
    assert f" plot: {png.relative_to(tmp_path)}" in run.stdout or f" plot: {png}" in run.stdout
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10000
