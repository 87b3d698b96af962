"""Progress of the core's long work (issue 42, item 6): a Monte Carlo's runs
and a fit's Newton iterations are counted by the core (fortran/base/
mlid_progress.f90) in what the call was given, and shown on a terminal
only: mlid-batch as a percentage line on stderr, `mlid run` as a tqdm bar
(python/mlid/progress.py's core_bar).  Nothing is printed when stderr is
not a terminal, and no number of the work changes: the report of a run
with a bar is the report of one without, whatever the thread count.

Terminals are pseudo-terminals (the pty module) with a size, as a user's
has one.  mlid-batch shows its line after half a second of work: its
Monte Carlo here is 20,000 runs (seconds); the Python bar's waits are set
to nothing in the child, so that it shows at once."""

import io
import os
import re
import select
import signal
import struct
import subprocess
import sys
import time

import pytest

import mlid
import mlid.progress
from conftest import BIN, REPO
from mlid._bridge import Handle, api, progress_of
from mlid.cli import deck as deck_module

#: The C-8 loop's design case and its Monte Carlo (runs set per test).
LOOP = REPO / "cases" / "c8_design_loop" / "c8_loop.nml"


def mc_deck(folder, runs):
    """A deck of two cases in folder: design the C-8 input, then a Monte
    Carlo of runs identifications on it (the loop deck's cases 1 and 4)."""
    parts = LOOP.read_text().split("&case ")
    text = "&case " + parts[1] + "&case " + parts[4].replace("runs = 50", f"runs = {runs}")
    assert f"runs = {runs}" in text
    path = folder / "mc.nml"
    path.write_text(text)
    return path


def under_pty(argv, cwd, env=None, until=None, then=None):
    """Run argv with stderr on a pseudo-terminal (24 x 100) and stdout to a
    pipe: (exit code, stdout bytes, what the terminal got).  until: bytes
    which, once on the terminal, make then(process) be called."""
    import fcntl
    import pty
    import termios
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    proc = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                            stdout=subprocess.PIPE, stderr=slave)
    os.close(slave)
    out, term, fired = b"", b"", False
    streams = {proc.stdout.fileno(): "out", master: "term"}
    while streams:
        ready, _, _ = select.select(list(streams), [], [], 60)
        assert ready, "no output for a minute"
        for fd in ready:
            try:
                data = os.read(fd, 65536)
            except OSError:          # the terminal's other side closed
                data = b""
            if not data:
                del streams[fd]
            elif streams[fd] == "out":
                out += data
            else:
                term += data
        if until is not None and not fired and until in term:
            fired = True
            then(proc)
    os.close(master)
    return proc.wait(), out, term


def env_with(**kw):
    env = dict(os.environ)
    env.update({k: str(v) for k, v in kw.items()})
    return env


# -- the count itself, read from the core as the bar reads it --------------

def counted_run(case):
    """Run case with a handle of its own counting its progress: its output
    and what the count says after it (label, done, total, exact, active)."""
    counter = Handle()
    status, msg = api.mlid_deck_case_run(case._handle.value, case.index, counter.value)
    kept = deck_module.values(case._handle, case.index, "run")
    label, done, total, exact, active, phase = progress_of(counter)
    return int(status), kept["report"], (label, done, total, exact, active), phase


def test_the_core_counts_monte_carlo_runs_and_fit_iterations(tmp_path):
    """The count after the run: every run of a Monte Carlo; a fit's
    iterations against max_iter, after its record's reading."""
    cases = deck_module.read_deck(mc_deck(tmp_path, 300))
    deck_module.run_case(cases[0], progress=False)            # the designed input
    plain, _ = deck_module.run_case(cases[1], progress=False)
    status, report, count, phase = counted_run(cases[1])
    assert status == 0 and count == ("monte carlo", 300, 300, 1, 0) and phase == 1
    assert report.decode() == plain.report                 # the same numbers, counted or not

    (tmp_path / "c8.nml").write_text((REPO / "cases" / "c8_short_period" / "c8.nml").read_text())
    simulate, c8 = deck_module.read_deck(tmp_path / "c8.nml")      # its record, then its fit
    deck_module.run_case(simulate, progress=False)
    plain, result = deck_module.run_case(c8, progress=False)
    status, report, count, phase = counted_run(c8)
    label, done, total, exact, active = count
    assert phase == 2                         # reading its record, then its fit
    assert status == 0 and report.decode() == plain.report
    assert (label, exact, active) == ("fit", 0, 0)
    assert done == result.iterations > 0
    assert total == c8.options()["max_iter"] == 20


def test_a_fit_from_python_draws_its_iterations(c8_data, monkeypatch, capfd):
    """mlid.fit(progress=stream) draws the core's count of its Newton
    iterations; asked for from the first step (MLID_PROGRESS_QUIET_MS=0), a
    fit that ends before the bar's thread reads still shows it; the same fit
    with or without it; nothing on a stderr that is no terminal."""
    from conftest import c8_start
    monkeypatch.setenv("MLID_PROGRESS_QUIET_MS", "0")
    data = c8_data
    plain = mlid.fit(c8_start(), data, progress=False)
    stream = io.StringIO()
    shown = mlid.fit(c8_start(), data, progress=stream)
    assert shown.estimate.tolist() == plain.estimate.tolist()
    drawn = stream.getvalue()
    # tqdm's count without a total: 'fit (at most 30 iterations): 5it' (max_iter's default)
    budget = mlid.default_options()["max_iter"]
    counts = [int(n) for n in re.findall(rf"fit \(at most {budget} iterations\): (\d+)it", drawn)]
    assert counts and max(counts) == plain.iterations, drawn[-300:]
    capfd.readouterr()
    mlid.fit(c8_start(), data)                # stderr is no terminal here: nothing
    assert capfd.readouterr().err == ""


def test_a_case_bar_in_python_draws_the_count(tmp_path, monkeypatch, capfd):
    """run_case given a stream draws the core's count there (the waits set to
    nothing: the bar shows as soon as the thread reads a count)."""
    monkeypatch.setattr(mlid.progress, "QUIET_S", 0.0)
    monkeypatch.setattr(mlid.progress, "READ_EVERY_S", 0.002)
    cases = deck_module.read_deck(mc_deck(tmp_path, 3000))
    deck_module.run_case(cases[0], progress=False)
    plain, _ = deck_module.run_case(cases[1], progress=False)
    stream = io.StringIO()
    shown, _ = deck_module.run_case(cases[1], progress=stream)
    assert shown.report == plain.report
    drawn = stream.getvalue()
    assert re.search(r"monte carlo: +\d+%\|.*\| \d+/3000", drawn), drawn[-300:]
    capfd.readouterr()
    deck_module.run_case(cases[1])            # stderr is no terminal here: no bar, no thread
    assert capfd.readouterr().err == ""


# -- the front ends on a terminal and redirected ---------------------------

def test_mlid_batch_prints_a_percentage_line_on_a_terminal_only(tmp_path):
    deck = mc_deck(tmp_path, 20000)
    argv = [str(BIN / "mlid-batch"), deck.name]
    quiet = subprocess.run(argv, cwd=tmp_path, capture_output=True, env=env_with(OMP_NUM_THREADS=1))
    assert quiet.returncode == 0 and quiet.stderr == b""        # redirected: nothing
    # told from the first run on, however fast the machine (not after half a second)
    rc, out, term = under_pty(argv, tmp_path, env_with(OMP_NUM_THREADS=2,
                                                       MLID_PROGRESS_QUIET_MS="0"))
    assert rc == 0
    assert out == quiet.stdout                # the same report, on two threads and with the line
    lines = re.findall(rb"\r monte carlo (\d+)%", term)
    assert lines and all(0 <= int(p) <= 100 for p in lines), term[:300]
    assert [int(p) for p in lines] == sorted(int(p) for p in lines)
    assert term.endswith(b"\r monte carlo 100%\r\n")          # ended by a newline
    assert term.count(b"\n") == 1


def test_mlid_run_draws_a_bar_on_a_terminal_only(tmp_path):
    deck = mc_deck(tmp_path, 3000)
    child = ("import sys, mlid.progress as p; p.QUIET_S = 0.0; p.READ_EVERY_S = 0.002; "
             "from mlid.cli.command import main; sys.exit(main(['run', *sys.argv[1:]]))")
    argv = [sys.executable, "-c", child, deck.name]
    quiet = subprocess.run(argv, cwd=tmp_path, capture_output=True)
    batch = subprocess.run([str(BIN / "mlid-batch"), deck.name], cwd=tmp_path,
                           capture_output=True)
    assert quiet.returncode == 0 and quiet.stderr == b""
    assert quiet.stdout == batch.stdout
    rc, out, term = under_pty(argv, tmp_path)
    assert rc == 0 and out == quiet.stdout
    assert re.search(rb"monte carlo: +\d+%\|", term), term[-300:]
    rc, out, term = under_pty(argv + ["-q"], tmp_path)          # asked for none
    assert rc == 0 and out == quiet.stdout and term == b""


def test_ctrl_c_ends_mlid_batch_with_its_line_drawn(tmp_path):
    """A SIGINT while the line shows: the line ends with a newline, the run
    with one line and exit code 130, promptly."""
    deck = mc_deck(tmp_path, 1_000_000)
    sent = []

    def interrupt(proc):
        sent.append(time.monotonic())
        proc.send_signal(signal.SIGINT)

    rc, out, term = under_pty([str(BIN / "mlid-batch"), deck.name], tmp_path,
                              until=b" monte carlo ", then=interrupt)
    assert sent and time.monotonic() - sent[0] < 10.0
    assert rc == 130
    assert re.search(rb"\r monte carlo \d+%\r\nmlid-batch: interrupted\r\n$", term), term[-200:]
    assert b"Monte Carlo:" not in out                          # the case did not report


def test_parallel_monte_carlo_bar_moves_in_small_chunks_with_the_same_numbers(monkeypatch):
    """monte_carlo_parallel's bar moves as chunks end: with a bar, some 100
    chunks (not 4 a worker), and the same numbers (run k's seed is k's)."""
    import numpy as np
    import mlid.design.parallel as parallel
    from conftest import c8_record, c8_start, c8_truth
    sizes = []
    runs_of = parallel._mc_runs
    monkeypatch.setattr(parallel, "_mc_runs", lambda call, s, n: sizes.append(n) or
                        runs_of(call, s, n))
    rec = c8_record(t_end=2.0)
    args = (c8_truth(), c8_start(), rec.t, rec.u)
    shown = mlid.monte_carlo_parallel(*args, runs=200, workers=2, progress=io.StringIO())
    assert sorted(set(sizes)) == [2] and len(sizes) == 100
    sizes.clear()
    plain = mlid.monte_carlo_parallel(*args, runs=200, workers=2, progress=False)
    assert sorted(set(sizes)) == [25]
    assert np.array_equal(shown["estimates"], plain["estimates"])
    assert np.array_equal(shown["status"], plain["status"])


def test_ctrl_c_ends_mlid_run_with_its_bar_drawn(tmp_path):
    """The same in mlid run: the bar's thread stops with the call."""
    deck = mc_deck(tmp_path, 1_000_000)
    rc, out, term = under_pty([str(BIN / "mlid"), "run", deck.name], tmp_path,
                              until=b"monte carlo:", then=lambda p: p.send_signal(signal.SIGINT))
    assert rc == 130 and b"mlid: interrupted" in term
    assert b"Monte Carlo:" not in out
