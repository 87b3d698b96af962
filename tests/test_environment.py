"""The environment `mlid run` meets (issue 41, class 10)."""

import os
import subprocess

import pytest

from conftest import BIN, two_case_deck


def test_an_unwritable_home_says_nothing_about_matplotlib(tmp_path):
    """Issue 41, class 10: with a HOME no folder can be made in, `mlid run
    --plots` draws its plots and says nothing of matplotlib's settings
    folder (matplotlib made a temporary one on every run and said so)."""
    deck = tmp_path / "deck.nml"
    deck.write_text(two_case_deck())
    env = {k: v for k, v in os.environ.items()
           if k not in ("MPLCONFIGDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")}
    env["HOME"] = "/proc/no_such_home"            # /proc takes no new folder, even for root
    run = subprocess.run([str(BIN / "mlid"), "run", deck.name, "--plots", "plots"],
                         capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "matplotlib" not in run.stderr.lower(), run.stderr
    assert (tmp_path / "plots" / "case2_fit.png").is_file()


@pytest.mark.parametrize("stdout", ["closed", "/dev/full"])
def test_a_report_that_cannot_reach_stdout_fails_the_run(stdout, tmp_path):
    """Issue 41, classes 6 and 10: stdout closed or full.  Both front ends
    run every case, write the JSON whole, say on stderr that the report was
    lost and exit 1 (mlid run ended in an internal error with no JSON,
    mlid-batch lost the report and exited 0)."""
    if stdout == "/dev/full" and not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    deck = tmp_path / "deck.nml"
    deck.write_text(two_case_deck())
    jsons = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        (tmp_path / "small.dat").unlink(missing_ok=True)
        cmd = [str(BIN / exe), *pre, deck.name, "--json", f"{exe}.json"]
        if stdout == "closed":      # the child starts with file descriptor 1 closed
            run = subprocess.run(cmd, stderr=subprocess.PIPE, text=True, cwd=tmp_path,
                                 timeout=300, preexec_fn=lambda: os.close(1))
        else:
            with open(stdout, "w") as target:
                run = subprocess.run(cmd, stdout=target, stderr=subprocess.PIPE, text=True,
                                     cwd=tmp_path, timeout=300)
        assert run.returncode == 1, run.stderr
        assert run.stderr.strip().splitlines() == [
            f"{exe}: the report could not be written to stdout (closed or full)"], run.stderr
        jsons.append((tmp_path / f"{exe}.json").read_bytes())
    assert jsons[0] == jsons[1] and jsons[0].startswith(b"[")


@pytest.mark.parametrize("stderr", ["closed", "/dev/full"])
@pytest.mark.parametrize("data", ["small.dat", "no_such.dat"])
def test_a_closed_stderr_loses_only_the_error_lines(stderr, data, tmp_path):
    """Issue 41, class 10: stderr closed or full.  Only what goes to stderr
    is lost: both front ends run every case, print the same report, write
    the same JSON and give the exit code they give with a stderr (1 when a
    case fails), with no traceback in the report (mlid run met a closed
    stderr with an AttributeError and no JSON)."""
    if stderr == "/dev/full" and not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    deck = tmp_path / "deck.nml"
    deck.write_text(two_case_deck(data))
    got = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        (tmp_path / "small.dat").unlink(missing_ok=True)
        cmd = [str(BIN / exe), *pre, deck.name, "--json", f"{exe}.json"]
        if stderr == "closed":
            run = subprocess.run(cmd, stdout=subprocess.PIPE, text=True, cwd=tmp_path,
                                 timeout=300, preexec_fn=lambda: os.close(2))
        else:
            with open(stderr, "w") as target:
                run = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=target, text=True,
                                     cwd=tmp_path, timeout=300)
        assert run.returncode == (0 if data == "small.dat" else 1), run.stdout
        assert "Traceback" not in run.stdout
        assert ("converged (" in run.stdout) == (data == "small.dat"), run.stdout
        got.append((run.stdout, (tmp_path / f"{exe}.json").read_bytes()))
    assert got[0] == got[1]
    assert got[0][1].count(b'"title"') == 2, got[0][1]


def test_a_c_locale_writes_the_same_utf8_json(tmp_path):
    """LC_ALL=C and PYTHONUTF8=0 with an accented title and a failing case:
    mlid run wrote no JSON ('ascii' codec can't encode); now both write
    the same UTF-8 bytes."""
    deck = tmp_path / "deck.nml"
    deck.write_text(two_case_deck("no_such.dat").replace("'middle'", "'\u00e9t\u00e9'"),
                    encoding="utf-8")
    env = {**os.environ, "LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0"}
    env.pop("PYTHONIOENCODING", None)
    got = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        run = subprocess.run([str(BIN / exe), *pre, deck.name, "--json", f"{exe}.json"],
                             capture_output=True, cwd=tmp_path, env=env, timeout=300)
        assert run.returncode == 1, run.stderr
        got.append((run.stdout, (tmp_path / f"{exe}.json").read_bytes()))
    assert got[0] == got[1] and "\u00e9t\u00e9".encode() in got[0][1]


def test_python_optimized_runs():
    """PYTHONOPTIMIZE=2 strips docstrings: mlid run ended at import
    (AttributeError in models' docstring filling)."""
    run = subprocess.run([str(BIN / "mlid"), "--version"], capture_output=True, text=True,
                         env={**os.environ, "PYTHONOPTIMIZE": "2"}, timeout=120)
    assert run.returncode == 0 and run.stderr == "", run.stderr


def test_a_working_folder_that_is_gone(tmp_path):
    """Run from a folder deleted under it, --json relative: one line, the
    same from both front ends (mlid run ended in an internal error)."""
    deck = tmp_path / "deck.nml"
    deck.write_text(two_case_deck())
    gone = tmp_path / "gone"
    lines = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        gone.mkdir()
        script = f'cd {gone} && rmdir {gone} && exec "$@"'
        run = subprocess.run(["bash", "-c", script, "sh", str(BIN / exe), *pre, str(deck),
                              "--json", "x.json"], capture_output=True, text=True, timeout=120)
        assert run.returncode == 1 and run.stdout == "", run.stderr
        lines.append(run.stderr.replace(exe, "", 1))
    assert lines[0] == lines[1] == ": cannot write --json x.json (its folder is missing or not " \
                                   "writable)\n"
