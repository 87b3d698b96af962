"""Habits of the ecosystem: the version, progress bars (shown on request or on
a terminal, silent otherwise and with --quiet), a warning when Monte Carlo
runs fail, and Monte Carlo over threads from a plain script without a
``__main__`` guard giving the serial numbers."""

import io
import subprocess
import sys
import textwrap
import warnings

import numpy as np
import pytest

import mlid
from conftest import BIN, REPO
from mlid.errors import ConvergenceWarning


def small():
    truth = mlid.LinearModel(F=[[-1.0, 0.9], [-4.0, -1.5]], G=[[-0.1], [-6.0]], H=np.eye(2),
                             r=[1e-6, 4e-6], free=["f(2,1)", "f(2,2)", "g(2,1)"])
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.2, 1.0))
    t = np.arange(0, 6, 0.05)
    u = np.where((t > 1) & (t < 1.5), 0.05, np.where((t > 1.5) & (t < 2), -0.05, 0.0))[:, None]
    return truth, start, t, u


def test_version_is_the_package_metadata():
    out = subprocess.run([str(BIN / "mlid"), "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == f"mlid {mlid.__version__}"
    assert mlid.__version__.count(".") >= 2


def test_progress_shows_when_asked_and_not_otherwise(capfd):
    truth, start, t, u = small()
    stream = io.StringIO()
    mlid.monte_carlo(truth, start, t, u, runs=6, progress=stream)
    assert "Monte Carlo" in stream.getvalue() and "/6 " in stream.getvalue()
    mlid.monte_carlo(truth, start, t, u, runs=3)          # stderr is not a terminal here
    assert capfd.readouterr().err == ""
    stream = io.StringIO()
    mlid.diagnose(truth.with_free(["f(2,1)", "g(2,1)"]),
                  mlid.simulate(truth, t, u, seed=3)[0], progress=stream, max_effects=1)
    assert "diagnose" in stream.getvalue()


def test_quiet_and_a_pipe_show_no_bar(tmp_path):
    deck = REPO / "cases" / "c8_short_period" / "c8.nml"
    for extra in ([], ["-q"]):
        out = subprocess.run([str(BIN / "mlid"), *extra, "run", str(deck)], capture_output=True,
                             text=True, cwd=tmp_path)
        assert "it/s" not in out.stderr and "case/s" not in out.stderr and "%|" not in out.stderr


def test_failed_monte_carlo_runs_warn_and_the_summary_leaves_them_out():
    truth, start, t, u = small()
    with pytest.warns(ConvergenceWarning, match=r"of 5 Monte Carlo runs failed"):
        mc = mlid.monte_carlo(truth, start, t, u, runs=5, max_iter=1, progress=False)
    ok = mc["status"] == 0
    assert 0 < (~ok).sum() and mc["summary"][next(iter(mc["summary"]))] == ok.sum()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mlid.monte_carlo(truth, start, t, u, runs=3, progress=False)


def test_threads_from_a_plain_script_give_the_serial_numbers(tmp_path):
    """No __main__ guard: threads start no process, so the script runs as it
    reads; every run is seeded, so the split does not change a number."""
    script = tmp_path / "mc.py"
    script.write_text(textwrap.dedent(f"""
        import sys, numpy as np
        sys.path.insert(0, {str(REPO / 'tests')!r})
        from test_habits import small
        import mlid
        truth, start, t, u = small()
        a = mlid.monte_carlo(truth, start, t, u, runs=12, progress=False)
        b = mlid.monte_carlo_parallel(truth, start, t, u, runs=12, workers=3, chunk=2,
                                      progress=False)
        print(np.array_equal(a["estimates"], b["estimates"]), a["estimates"].shape)
    """))
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[0] == "True", out.stdout
