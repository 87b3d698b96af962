"""Ctrl-C during a long core call (issue 41, class 5): a fit, a Monte Carlo,
`mlid run` and `mlid-batch` answer SIGINT promptly, with a clean
KeyboardInterrupt (API) or one line and exit code 130 (front ends), and the
interpreter goes on: the next call works.

The core polls a flag a SIGINT sets (fortran/base/mlid_interrupt.c) in its
long loops and unwinds with the status 'interrupted'.  The answer is timed:
the target is 0.2 s; the bound asserted, RESPONSE, is ten times that, because
the test machine is shared (other jobs can hold both cores for a second) and
the process must also leave the call and unwind Python.  Before the flag, a
call answered only when it returned: the Monte Carlo here never would (a
million runs, half an hour), so the bound tests the polls, not luck."""

import json
import os
import select
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import mlid
from conftest import BIN, REPO, c8_record, c8_start

#: Seconds from the SIGINT to the process's answer (see the module's text).
RESPONSE = 2.0

#: The child's preamble: the C-8 model and a long synthetic 4x7 record.
PREAMBLE = textwrap.dedent(f"""
    import sys, time
    import numpy as np
    sys.path.insert(0, {str(REPO / "tests")!r})
    sys.path.insert(0, {str(REPO / "benchmarks")!r})
    import mlid
    from conftest import c8_truth, c8_start, c8_record
    from mlid.design.signals import input_signal
""")

#: Long calls of the API, each in a loop or long enough never to end here.
CALLS = {
    # output-error fits of a 150,000-sample record, 11 parameters, one after another
    "fit": """
        from bench_fit import synthetic_600
        truth, start, _ = synthetic_600()
        nt, dt = 150_000, 0.1
        t = np.arange(nt) * dt
        u = np.column_stack([input_signal("3211", 0.02, 2.0, 1.0, dt, nt),
                             2000.0 * np.sin(0.2 * t)])
        data, _ = mlid.simulate(truth, t, u, [0.2, 0.002, 0.002, 0.002, 0.01, 0.05, 0.1],
                                seed=3)
        def long_call():
            while True:
                mlid.fit(start, data)
    """,
    # one core call of a million C-8 identifications
    "monte_carlo": """
        rec = c8_record()
        def long_call():
            mlid.monte_carlo(c8_truth(), c8_start(), rec.t, rec.u, runs=10**6, progress=False)
    """,
}

#: After the interrupt: the time it came, then a fit that must work.
AFTER = """
    print("calling", flush=True)
    try:
        long_call()
        print("returned", flush=True)
    except KeyboardInterrupt as exc:
        print(f"interrupted {time.time():.6f} {type(exc).__name__}", flush=True)
    res = mlid.fit(c8_start(), c8_record())
    print(f"next fit converged={res.converged} M_q={res.estimate[0]:.6f}", flush=True)
"""


def _answer_time(proc, sent):
    """Seconds from sent (time.time()) to the child's 'interrupted' line."""
    line = proc.stdout.readline().split()
    assert line[:1] == ["interrupted"], f"the call did not raise KeyboardInterrupt: {line}"
    assert line[2] == "KeyboardInterrupt"
    return float(line[1]) - sent


@pytest.mark.parametrize("call", sorted(CALLS))
def test_api_call_answers_ctrl_c_and_the_next_call_works(call):
    code = PREAMBLE + textwrap.dedent(CALLS[call]) + textwrap.dedent(AFTER)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "calling"
        time.sleep(1.0)                                  # well inside the core call
        assert proc.poll() is None
        sent = time.time()
        proc.send_signal(signal.SIGINT)
        answered = _answer_time(proc, sent)
        out, err = proc.stdout.read(), proc.stderr.read()   # (not communicate: what
        proc.wait(timeout=120)                              # readline buffered is kept)
    finally:
        proc.kill()
    print(f"{call}: answered Ctrl-C in {answered:.3f} s")
    assert answered < RESPONSE
    assert proc.returncode == 0, err
    assert "Traceback" not in err
    # the interpreter and the core are intact: the C-8 fit gives what it gives here
    assert "next fit converged=True" in out
    m_q = float(out.split("M_q=")[1])
    assert m_q == pytest.approx(mlid.fit(c8_start(), c8_record()).estimate[0], abs=2e-6)


def test_a_handler_of_the_users_own_still_ends_the_call():
    """A SIGINT handler that does not raise: the core still unwinds (its
    handler is passed the signal too), and the call raises KeyboardInterrupt
    from the core's status, with the core's message."""
    code = PREAMBLE + textwrap.dedent(CALLS["fit"]) + textwrap.dedent("""
        import signal
        seen = []
        signal.signal(signal.SIGINT, lambda sig, frame: seen.append(sig))
        print("calling", flush=True)
        try:
            long_call()
        except KeyboardInterrupt as exc:
            print(f"interrupted {time.time():.6f} {type(exc).__name__} {exc} {seen}", flush=True)
    """)
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "calling"
        time.sleep(1.0)
        # A SIGINT that lands in Python between two fits goes to the user's
        # handler alone, which does not raise, and the loop goes on: that
        # one is sent again (on a loaded machine the window is not empty).
        line, sends = "", 0
        while not line and sends < 10:
            sent = time.time()
            proc.send_signal(signal.SIGINT)
            sends += 1
            if select.select([proc.stdout], [], [], 20.0)[0]:
                line = proc.stdout.readline()
        proc.wait(timeout=60)
    finally:
        proc.kill()
    assert line.startswith("interrupted"), line
    assert float(line.split()[1]) - sent < RESPONSE
    # the handler ran once for each signal sent
    assert f"KeyboardInterrupt interrupted (Ctrl-C) {[2] * sends}" in line


#: A deck: a short simulated record, then a Monte Carlo of a million runs on it.
DECK = """\
&case title = 'record', job = 'simulate' /
&model kind = 'linear', nx = 4, nu = 1, ny = 4,
    f = -0.02, -32.2, 0.0, 33.74,  0.0, 0.0, 1.0, 0.0,  0.003, 0.0, -1.588, -0.562,
        -0.004, 0.0, 1.0, -0.737,
    g = 0.0, 0.0, -1.658, 0.005,  h = 1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1 /
&simulate out = 'rec.dat', t_end = 6.0, dt = 0.02, seed = 1,
    noise_std = 0.35, 0.006, 0.006, 0.009,
    input_shape = 'doublet', amplitude = 0.08, t_start = 1.0, pulse_width = 0.5 /

&case title = 'a million identifications', job = 'monte_carlo' /
&model kind = 'linear', nx = 4, nu = 1, ny = 4,
    f = -0.02, -32.2, 0.0, 33.74,  0.0, 0.0, 1.0, 0.0,  0.003, 0.0, -0.95, -0.79,
        -0.004, 0.0, 1.0, -0.48,
    g = 0.0, 0.0, -2.24, 0.0025,  h = 1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1,
    r = 0.125, 0.125, 0.125, 0.25,
    free = 'f(3,3)', 'f(3,4)', 'f(4,4)', 'g(3,1)', 'g(4,1)' /
&monte_carlo runs = 1000000, seed = 1, input_file = 'rec.dat',
    truth = -1.588, -0.562, -0.737, -1.658, 0.005 /
"""


@pytest.mark.parametrize("front", ["mlid run", "mlid-batch"])
def test_front_end_ctrl_c_is_one_line_exit_130_and_no_json(tmp_path, front):
    deck = tmp_path / "long.nml"
    deck.write_text(DECK)
    program = [str(BIN / "mlid"), "run"] if front == "mlid run" else [str(BIN / "mlid-batch")]
    proc = subprocess.Popen([*program, str(deck), "--json", str(tmp_path / "out.json")],
                            cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    try:
        limit = time.time() + 60
        while not (tmp_path / "rec.dat").exists():      # case 1 done: the Monte Carlo runs
            assert proc.poll() is None and time.time() < limit, proc.communicate()
            time.sleep(0.02)
        time.sleep(0.5)
        assert proc.poll() is None
        sent = time.time()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
        answered = time.time() - sent
    finally:
        proc.kill()
    print(f"{front}: answered Ctrl-C in {answered:.3f} s")
    assert answered < RESPONSE
    assert proc.returncode == 130
    prefix = "mlid" if front == "mlid run" else "mlid-batch"
    assert err == f"{prefix}: interrupted\n"
    assert not (tmp_path / "out.json").exists()
    assert not [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name]   # no temporaries
    assert "Monte Carlo" not in out                      # no report of the case it stopped
    # the same stdout from both: the finished case's report, the stopped one's heading
    assert out.startswith("\n case 1: ") and out.count("\n case ") == 2
    assert out.rstrip("\n").split("\n")[-1].startswith(" case 2: ")
    np.loadtxt(tmp_path / "rec.dat")                     # the earlier case's record, whole
