"""Input design and Monte Carlo as deck jobs (issue 17): the C-8 loop deck
(design -> simulate with the designed input -> estimate -> Monte Carlo) gives
the same bytes from `mlid run` and `mlid-batch` with 1 and 2 threads; each
design method's input and information agree with mlid.InputDesign on the
same problem; bad &design and &monte_carlo groups are one line each."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, C8_F, C8_G, REPO

import sys
sys.path.insert(0, str(REPO / "cases" / "c8_monte_carlo"))
from c8_longitudinal import R_SAMPLE  # noqa: E402  the one reading of the noise line, the deck's r

LOOP = REPO / "cases" / "c8_design_loop" / "c8_loop.nml"
DT, T, ENERGY = 0.02, 2.0, 58.0
UNKNOWNS = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]
FILES = ("c8_designed.dat", "c8_flown.dat")


def _run(front, deck, json_path, threads):
    cmd = [str(BIN / "mlid"), "run"] if front == "py" else [str(BIN / "mlid-batch")]
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    out = subprocess.run(cmd + [str(deck), "--json", str(json_path)], capture_output=True,
                         text=True, env=env)
    assert out.returncode == 0, (front, out.stderr)
    return out


@pytest.fixture(scope="module")
def loop_runs(tmp_path_factory):
    """The loop deck run by both front ends with 1 and 2 threads, each in a
    folder of its own: stdout, JSON bytes and the files written."""
    runs = {}
    for front in ("py", "fo"):
        for threads in (1, 2):
            folder = tmp_path_factory.mktemp(f"{front}{threads}")
            deck = folder / LOOP.name
            shutil.copy(LOOP, deck)
            out = _run(front, deck, folder / "out.json", threads)
            runs[front, threads] = (out.stdout.replace(str(folder), "<dir>"),
                                    (folder / "out.json").read_bytes().replace(
                                        str(folder).encode(), b"<dir>"),
                                    {f: (folder / f).read_bytes() for f in FILES})
    return runs


def test_loop_deck_same_bytes_from_both_front_ends_and_thread_counts(loop_runs):
    first = loop_runs["fo", 1]
    for key, run in loop_runs.items():
        assert run[0] == first[0], key          # report text
        assert run[1] == first[1], key          # JSON bytes
        assert run[2] == first[2], key          # the designed input and the flown record
    cases = json.loads(first[1])
    assert [c["job"] for c in cases] == ["design", "simulate", "estimate", "monte_carlo"]
    assert all(c["status"] == 0 for c in cases)


def test_loop_deck_design_is_input_design_of_the_same_problem(loop_runs):
    """The deck's design against mlid.InputDesign (R = r dt, 50 and 100 cells)."""
    design = json.loads(loop_runs["fo", 1][1])[0]
    d = mlid.InputDesign(C8_F, C8_G, np.eye(4), np.diag(R_SAMPLE * DT), UNKNOWNS)
    opt = d.optimal_input(T, ENERGY, cells=50)
    assert design["cells"] == 100 and design["unknowns"] == ["M_q", "M_alpha", "Z_alpha",
                                                              "M_delta", "Z_delta"]
    np.testing.assert_allclose(design["mu"], opt.mu, rtol=1e-12)
    np.testing.assert_allclose(design["M"], opt.M, rtol=1e-10)
    np.testing.assert_allclose(design["trace_M"], opt.summary["trace"], rtol=1e-10)
    np.testing.assert_allclose(design["det_M"], opt.summary["det"], rtol=1e-8)
    np.testing.assert_allclose(design["sigma"], opt.summary["sigma"], rtol=1e-8)
    np.testing.assert_allclose(design["energy"], ENERGY, rtol=1e-12)
    np.testing.assert_allclose(design["peak"], np.abs(opt.u).max(), rtol=1e-12)
    # the record: the input held over each step, the last sample holding the last cell
    rec = np.loadtxt(_text(loop_runs["fo", 1][2]["c8_designed.dat"]))
    assert rec.shape == (101, 2)
    np.testing.assert_allclose(rec[:, 0], np.arange(101) * DT, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rec[:, 1], np.r_[opt.u[:, 0], opt.u[-1, 0]], rtol=1e-14)


def test_loop_deck_flies_the_designed_input_and_identifies(loop_runs):
    """The simulate case took the designed input; the fit from the a priori
    values (50% off) lands within 3 sigma of the truth; the Monte Carlo's
    sample sigma are the Cramer-Rao sigma within the sampling error of 50
    runs (a sigma's relative standard error is 1/sqrt(2 * 49) = 10%)."""
    cases = json.loads(loop_runs["fo", 1][1])
    files = loop_runs["fo", 1][2]
    flown = np.loadtxt(_text(files["c8_flown.dat"]))
    designed = np.loadtxt(_text(files["c8_designed.dat"]))
    np.testing.assert_array_equal(flown[:, :2], designed)
    truth = np.array(cases[3]["truth"])
    fit = cases[2]
    assert fit["converged"]
    assert np.all(np.abs(np.array(fit["estimate"]) - truth) < 3 * np.array(fit["sigma"]))
    mc = cases[3]
    assert mc["runs"] == 50 and mc["failed"] == 0 and mc["seed"] == 1
    ratio = np.array(mc["sample_sigma"]) / np.array(mc["mean_cr_sigma"])
    assert np.all(np.abs(ratio - 1) < 0.35), ratio
    assert np.all(np.abs(np.array(mc["mean"]) - truth) < 3 * np.array(mc["sample_sigma"])
                  / np.sqrt(50) + 1e-12)


def test_monte_carlo_job_is_the_python_monte_carlo(loop_runs):
    """The same runs by mlid.monte_carlo (the core's Monte Carlo through
    Python): the same statistics, from the one summary in the core, to the
    bit."""
    cases = json.loads(loop_runs["fo", 1][1])
    rec = np.loadtxt(_text(loop_runs["fo", 1][2]["c8_designed.dat"]))
    names = dict(zip(UNKNOWNS, cases[3]["parameters"]))
    start = mlid.LinearModel(C8_F, C8_G, np.eye(4), r=R_SAMPLE, free=UNKNOWNS, names=names,
                             input_hold="zoh")
    theta = start.theta.copy()
    theta[start.free_indices()] = cases[3]["truth"]
    mc = mlid.monte_carlo(start.with_theta(theta), start, rec[:, 0], rec[:, 1:], runs=50, seed=1,
                          progress=False)
    summary = mc["summary"]
    assert summary["runs"] == cases[3]["runs"] - cases[3]["failed"]
    for key in ("mean", "sample_sigma", "mean_cr_sigma", "sample_cov_trace", "sample_cov_det",
                "mean_info_trace", "mean_info_det"):
        # the JSON's 17 digits give the double back
        np.testing.assert_array_equal(np.array(cases[3][key]), summary[key], err_msg=key)


def _text(b):
    from io import StringIO
    return StringIO(b.decode())


# -- each method against mlid.InputDesign ------------------------------------------------

SHORT = """&case title = 'design', job = 'design' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.588, -0.562, 1.0, -0.737,   g = -1.66, 0.005,   h = 1, 0, 0, 1,
    r = {r1}, {r2},
    free = 'f(1,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'g(2,1)' /
&design t_end = {T}, dt = {dt}, out = 'u.dat', {extra} /
"""
SHORT_F = np.array([[-1.588, -0.562], [1.0, -0.737]])
SHORT_G = np.array([[-1.66], [0.005]])
SHORT_UNK = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "g(2,1)"]
SHORT_R = np.diag([0.02, 0.04])          # §8.1's spectral density (CASES.md §1)


def _design(tmp_path, extra, T=4.0, dt=0.02, front="fo"):
    deck = tmp_path / "d.nml"
    deck.write_text(SHORT.format(r1=0.02 / dt, r2=0.04 / dt, T=T, dt=dt, extra=extra))
    out = _run(front, deck, tmp_path / f"{front}.json", 1)
    return json.loads((tmp_path / f"{front}.json").read_text())[0], \
        np.loadtxt(tmp_path / "u.dat"), out.stdout


def test_riccati_method_is_the_riccati_mu_and_the_costate_input(tmp_path):
    got, rec, _ = _design(tmp_path, "energy = 311.0, method = 'riccati'")
    d = mlid.InputDesign(SHORT_F, SHORT_G, np.eye(2), SHORT_R, SHORT_UNK)
    np.testing.assert_allclose(got["mu"], d.mu_max(4.0, cells=100, method="riccati"),
                               rtol=1e-10)
    # CASES.md §1: mu = 65.89 recomputed; tr M = mu E = 20,492 at E = 311
    np.testing.assert_allclose(got["mu"], 65.89, rtol=2e-3)
    np.testing.assert_allclose(got["M"], d.information(4.0, rec[:-1, 1]), rtol=1e-10)
    np.testing.assert_allclose(got["trace_M"], got["mu"] * 311.0, rtol=2e-3)


def test_amplitude_method_is_amplitude_limited(tmp_path):
    got, rec, _ = _design(tmp_path, "peak = 12.7, min_width = 0.2, method = 'amplitude'")
    d = mlid.InputDesign(SHORT_F, SHORT_G, np.eye(2), SHORT_R, SHORT_UNK)
    sq = d.amplitude_limited(4.0, 12.7, 0.2)
    assert got["cells"] == 20 and got["mu"] is None
    np.testing.assert_array_equal(rec[:-1, 1], np.repeat(sq.u[:, 0], 10))
    np.testing.assert_allclose(got["M"], sq.M, rtol=1e-12)
    np.testing.assert_allclose(got["sigma"], sq.summary["sigma"], rtol=1e-8)


def test_equalised_method_is_equalised(tmp_path):
    """§7.8 at T = 0.77 s, E = 62.61 (CASES.md §1: diag(WM) max/min -> 1.00,
    det M 2.30e4 recomputed, 2.27e4 the report's)."""
    got, _, text = _design(tmp_path, "energy = 62.61, method = 'equalised'", T=0.77, dt=0.0077)
    d = mlid.InputDesign(SHORT_F, SHORT_G, np.eye(2), SHORT_R, SHORT_UNK)
    best, ratios = d.equalised(0.77, 62.61, iterations=12, cells=50)
    np.testing.assert_allclose(got["weights"], best.weights, rtol=1e-12)
    np.testing.assert_allclose(got["equalise_ratios"], ratios, rtol=1e-12)
    np.testing.assert_allclose(got["M"], best.M, rtol=1e-10)
    assert got["equalise_ratios"][-1] < 1.01
    np.testing.assert_allclose(got["det_M"], 2.27e4, rtol=0.02)
    assert "equalised weights (eq. 7.88)" in text


def test_servo_is_a_state_of_the_design_model(tmp_path):
    """servo = tau: the command through a first-order servo, as the model with
    the servo as a third state designs it (c8_input_design's §8.3 servo)."""
    got, _, text = _design(tmp_path, "energy = 311.0, servo = 0.2")
    Fs = np.zeros((3, 3))
    Fs[:2, :2], Fs[:2, 2], Fs[2, 2] = SHORT_F, SHORT_G[:, 0], -5.0
    Gs = np.array([[0.0], [0.0], [5.0]])
    Hs = np.hstack([np.eye(2), np.zeros((2, 1))])
    d = mlid.InputDesign(Fs, Gs, Hs, SHORT_R, ["f(1,1)", "f(1,2)", "f(2,2)", "f(1,3)", "f(2,3)"])
    opt = d.optimal_input(4.0, 311.0, cells=100)
    np.testing.assert_allclose(got["mu"], opt.mu, rtol=1e-12)
    np.testing.assert_allclose(got["M"], opt.M, rtol=1e-10)
    assert "servo on u1: first order, time constant" in text


def test_process_noise_designs_on_the_filter_sensitivities(tmp_path):
    """Gamma Q Gamma' = 0.5 I: mu at T = 4 s falls from 65.86 to 6.60
    (cases/c8_input_design/README.md)."""
    got, _, _ = _design(tmp_path, "energy = 311.0, process_noise = 0.5, 0, 0, 0.5")
    d = mlid.InputDesign(SHORT_F, SHORT_G, np.eye(2), SHORT_R, SHORT_UNK,
                         process_noise=0.5 * np.eye(2))
    np.testing.assert_allclose(got["mu"], d.mu_max(4.0, cells=100), rtol=1e-12)
    np.testing.assert_allclose(got["mu"], 6.60, rtol=2e-3)
    assert got["process_noise"] is True


def test_python_front_end_writes_the_same_design(tmp_path):
    a, rec_a, out_a = _design(tmp_path, "energy = 311.0, method = 'equalised', weights = 1, 2, "
                              "1, 1, 3, iterations = 4", front="fo")
    (tmp_path / "u.dat").rename(tmp_path / "u_fo.dat")
    b, rec_b, out_b = _design(tmp_path, "energy = 311.0, method = 'equalised', weights = 1, 2, "
                              "1, 1, 3, iterations = 4", front="py")
    assert (tmp_path / "fo.json").read_bytes() == (tmp_path / "py.json").read_bytes()
    assert (tmp_path / "u_fo.dat").read_bytes() == (tmp_path / "u.dat").read_bytes()
    assert out_a == out_b


# -- bad input: one line naming file, case, line and problem; the rest runs ---------------

GOOD_AFTER = """
&case title = 'good design', job = 'design' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.588, -0.562, 1.0, -0.737,   g = -1.66, 0.005,   h = 1, 0, 0, 1, r = 1, 2,
    free = 'f(1,1)', 'g(1,1)' /
&design t_end = 1.0, dt = 0.02, energy = 10.0, out = 'good.dat' /
"""
BAD_MODEL = """&case title = 'bad', job = '{job}' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.588, -0.562, 1.0, -0.737,   g = -1.66, 0.005,   h = 1, 0, 0, 1, r = 1, 2,
    free = 'f(1,1)', 'g(1,1)' /
"""
DESIGN_OK = "t_end = 1.0, dt = 0.02, energy = 10.0, out = 'bad.dat'"
BAD = {
    "design group missing": ("design", "", "group &design is missing"),
    "design unknown name": ("design", f"&design {DESIGN_OK}, enrgy = 3 /",
                            "group &design (line 11)"),
    "design bad method": ("design", f"&design {DESIGN_OK}, method = 'optimal' /",
                          "method must be 'operator', 'riccati', 'amplitude' or 'equalised'"),
    "design no energy": ("design", "&design t_end = 1.0, dt = 0.02, out = 'bad.dat' /",
                         "method 'operator' takes energy > 0"),
    "design amplitude with energy": ("design", f"&design {DESIGN_OK}, method = 'amplitude', "
                                     "peak = 1, min_width = 0.1 /",
                                     "method 'amplitude' takes peak > 0 and min_width > 0"),
    "design odd steps": ("design", "&design t_end = 1.02, dt = 0.02, energy = 1, out = 'b.dat' /",
                         "needs an even number of steps"),
    "design T not whole steps": ("design", "&design t_end = 1.01, dt = 0.02, energy = 1, "
                                 "out = 'b.dat' /", "whole number of steps"),
    "design unknown not in F G H": ("design", f"&design {DESIGN_OK}, unknowns = 'x0(1)' /",
                                    "unknown 'x0(1)' is no element of F, G or H"),
    "design unknown outside": ("design", f"&design {DESIGN_OK}, unknowns = 'f(3,1)' /",
                               "unknown 'f(3,1)' is no element"),
    "design weights count": ("design", f"&design {DESIGN_OK}, weights = 1, 2, 3 /",
                             "weights takes one value > 0 per unknown (2)"),
    "design negative servo": ("design", f"&design {DESIGN_OK}, servo = -0.2 /",
                              "servo takes one time constant >= 0"),
    "design process noise size": ("design", f"&design {DESIGN_OK}, process_noise = 1, 0, 0 /",
                                  "process_noise is Gamma Q Gamma' (nx x nx = 4 values"),
    "design process noise asymmetric": ("design", f"&design {DESIGN_OK}, "
                                        "process_noise = 1, 0.5, 0, 1 /", "must be symmetric"),
    "design no out": ("design", "&design t_end = 1.0, dt = 0.02, energy = 10.0 /",
                      "out (the record of the designed input to write) is missing"),
    "design without an input": (
        "&case title = 'bad', job = 'design' /\n&model nx = 1, nu = 0, ny = 1, f = -1, h = 1, "
        f"r = 1, free = 'f(1,1)' /\n&design {DESIGN_OK} /", None,
        "input design needs kind = 'linear' with at least one input"),
    "monte carlo group missing": ("monte_carlo", "", "group &monte_carlo is missing"),
    "monte carlo no input": ("monte_carlo", "&monte_carlo runs = 5 /", "input_file"),
    "monte carlo runs": ("monte_carlo", "&monte_carlo runs = 0, input_file = 'good.dat' /",
                         "runs must be 1 to 1000000"),
    "monte carlo truth count": ("monte_carlo", "&monte_carlo runs = 5, input_file = 'good.dat',"
                                " truth = 1 /", "truth takes one value per free parameter (2"),
    "monte carlo input file missing": ("monte_carlo", "&monte_carlo runs = 5, "
                                       "input_file = 'nowhere.dat' /", "nowhere.dat"),
    "monte carlo prior": ("monte_carlo", "&monte_carlo runs = 5, input_file = 'good.dat' /\n"
                          "&estimate lower = -10, -10 /", "not used by job 'monte_carlo'"),
    "simulate input file and shape": (
        "simulate", "&simulate out = 's.dat', input_file = 'good.dat', input_shape = 'step' /",
        "input_file gives the time and inputs"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_design_and_monte_carlo_groups(tmp_path, name):
    job, group, phrase = BAD[name]
    case = job if group is None else BAD_MODEL.format(job=job) + group
    deck = tmp_path / "batch.nml"
    deck.write_text(GOOD_AFTER + case + "\n" + GOOD_AFTER.replace("good design", "after"))
    outs = {}
    for front, who in (("py", "mlid"), ("fo", "mlid-batch")):
        cmd = [str(BIN / "mlid"), "run"] if front == "py" else [str(BIN / "mlid-batch")]
        out = subprocess.run(cmd + [str(deck)], capture_output=True, text=True)
        assert out.returncode == 1, (who, out.stdout, out.stderr)
        assert "Traceback" not in out.stderr and "Error termination" not in out.stderr
        errors = [ln for ln in out.stderr.splitlines() if ln.startswith(who + ":")]
        assert len(errors) == 1, (who, out.stderr)
        assert f"{deck} case 2 (line 7) 'bad': " in errors[0] and phrase in errors[0], errors[0]
        assert "1 of 3 cases failed" in out.stderr
        assert out.stdout.count("designed input written to") == 2    # before and after
        outs[front] = (out.stdout, errors[0].split("': ", 1)[1])
    assert outs["py"] == outs["fo"]
