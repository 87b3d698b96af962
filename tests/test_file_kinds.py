"""Only regular files are read (issue 41, class 5): a FIFO or a device
(/dev/zero) as a deck or a data file is refused at once with one line, by
both front ends and by the API, where main waited on the FIFO for a writer
and read /dev/zero without end.  Each run has a timeout, so that a hang
fails the test instead of stopping the suite."""

import os
import shutil
import subprocess

import pytest

import mlid
from conftest import BIN, two_case_deck

DECK = two_case_deck("DATA")

needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")


def _fifo(tmp_path, name):
    path = tmp_path / name
    os.mkfifo(path)
    return path


def _both(args, cwd):
    return [subprocess.run([str(BIN / exe), *pre, *args], capture_output=True, text=True,
                           cwd=cwd, timeout=120)
            for exe, pre in (("mlid", ["run"]), ("mlid-batch", []))]


@needs_fifo
@pytest.mark.parametrize("data, kind", [("fifo.dat", "a FIFO"), ("fifo.mat", "a FIFO"),
                                        ("/dev/zero", "a device")])
def test_a_data_file_that_is_no_regular_file_is_refused(data, kind, tmp_path):
    if not data.startswith("/"):
        _fifo(tmp_path, data)
    elif not os.path.exists(data):
        pytest.skip(f"no {data}")
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", data))
    runs = _both([deck.name], tmp_path)
    lines = [r.stderr.splitlines()[0] for r in runs]
    for run, line in zip(runs, lines):
        assert run.returncode == 1, run.stderr
        assert "case 2" in line and f"is {kind}, not a regular file" in line, line
    assert lines[0].split(":", 1)[1] == lines[1].split(":", 1)[1]
    assert runs[0].stdout == runs[1].stdout


@needs_fifo
def test_a_deck_that_is_no_regular_file_is_refused(tmp_path):
    _fifo(tmp_path, "deck.nml")
    for run in _both(["deck.nml"], tmp_path):
        assert run.returncode != 0
        assert "deck.nml is a FIFO, not a regular file" in run.stderr, run.stderr


@needs_fifo
def test_the_api_refuses_what_is_no_regular_file(tmp_path):
    fifo = _fifo(tmp_path, "fifo.dat")
    with pytest.raises(mlid.InputError, match="is a FIFO, not a regular file"):
        mlid.FlightData.load(fifo, 1, [2], [3, 4])
    with pytest.raises(mlid.InputError, match="is a FIFO, not a regular file"):
        mlid.read_deck(fifo)
    if os.path.exists("/dev/zero"):
        with pytest.raises(mlid.InputError, match="is a device, not a regular file"):
            mlid.FlightData.load("/dev/zero", 1, [2], [3, 4])


# ---- outputs: only regular files are replaced (issue 41, class 1) ----------

def _loop(tmp_path):
    (tmp_path / "loop1").symlink_to("loop2")
    (tmp_path / "loop2").symlink_to("loop1")
    return "loop1"


@needs_fifo
@pytest.mark.parametrize("target, says", [
    ("fifo.json", "(a FIFO, not a regular file)"),
    ("/dev/null", "(a device, not a regular file)"),
    ("loop1", "(a link to nothing, or a loop of links)"),
    ("dangling", "(a link to nothing, or a loop of links)")])
def test_json_is_written_only_to_a_regular_file(target, says, tmp_path):
    if target == "fifo.json":
        _fifo(tmp_path, target)
    elif target == "loop1":
        _loop(tmp_path)
    elif target == "dangling":
        (tmp_path / "dangling").symlink_to("no_such_folder/x.json")
    elif not os.path.exists(target):
        pytest.skip(f"no {target}")
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "small.dat"))
    before = os.lstat(target if target.startswith("/") else tmp_path / target)
    for run in _both([deck.name, "--json", target], tmp_path):
        assert run.returncode == 1
        assert f"cannot write --json {target} {says}" in run.stderr.splitlines()[0], run.stderr
        assert run.stdout == ""                       # refused before any case runs
    after = os.lstat(target if target.startswith("/") else tmp_path / target)
    assert (after.st_mode, after.st_ino) == (before.st_mode, before.st_ino)
    assert not (tmp_path / "small.dat").exists()


@needs_fifo
def test_a_simulation_does_not_replace_a_fifo(tmp_path):
    _fifo(tmp_path, "small.dat")
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "small.dat"))
    runs = _both([deck.name], tmp_path)
    for run in runs:
        assert run.returncode == 1
        line = run.stderr.splitlines()[0]
        assert "case 1" in line and "cannot write small.dat (a FIFO, not a regular file)" in line
    assert os.path.exists(tmp_path / "small.dat") and not (tmp_path / "small.dat").is_file()


@needs_fifo
def test_the_api_does_not_replace_a_fifo(tmp_path):
    fifo = _fifo(tmp_path, "out.dat")
    data, _ = mlid.simulate(mlid.LinearModel([[-1.0]], [[1.0]], [[1.0]]), [0.0, 0.1, 0.2],
                            [[0.0], [1.0], [0.0]])
    with pytest.raises(mlid.InputError, match="a FIFO, not a regular file"):
        data.save(fifo)


@pytest.mark.parametrize("target, k", [("small.dat", 1), ("record.dat", 2)])
def test_json_is_no_file_the_run_reads_or_writes(target, k, tmp_path):
    """--json naming a record a case writes (case 1's simulation) or reads
    (case 2's data file, there already) is refused before any case runs:
    main overwrote the record with the JSON."""
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", target))
    record = b"# t u y1 y2\n0 0 0 0\n"
    if target == "record.dat":
        (tmp_path / target).write_bytes(record)
    for run in _both([deck.name, "--json", target], tmp_path):
        assert run.returncode == 1 and run.stdout == ""
        assert (f"cannot write --json {target} (a file this run reads or writes: deck.nml case "
                f"{k})") in run.stderr.splitlines()[0], run.stderr
    if target == "record.dat":
        assert (tmp_path / target).read_bytes() == record
    else:
        assert not (tmp_path / target).exists()


@pytest.mark.parametrize("option", ["--table", "--campaign"])
def test_a_table_is_no_file_the_run_reads(option, tmp_path):
    """--table or --campaign naming a .csv record a case reads is refused
    before any case runs, in the words of --json, and the record is kept."""
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "record.csv"))
    record = b"t,u,y1,y2\n0,0,0,0\n"
    (tmp_path / "record.csv").write_bytes(record)
    run = subprocess.run([str(BIN / "mlid"), "run", deck.name, option, "record.csv"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert run.returncode == 1 and run.stdout == ""
    assert run.stderr.splitlines() == [f"mlid: cannot write {option} record.csv (a file this "
                                       "run reads or writes: deck.nml case 2)"], run.stderr
    assert (tmp_path / "record.csv").read_bytes() == record


def test_two_outputs_are_two_files(tmp_path):
    """--json, --table and --campaign naming one file: refused before any
    case runs (the last one written replaced the others)."""
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "small.dat"))
    run = subprocess.run([str(BIN / "mlid"), "run", deck.name, "--json", "out.json",
                          "--table", "./out.json"], capture_output=True, text=True,
                         cwd=tmp_path, timeout=120)
    assert run.returncode == 1 and run.stdout == ""
    assert run.stderr.splitlines() == ["mlid: --json and --table name one file, ./out.json: "
                                       "each output goes to a file of its own"], run.stderr
    assert not (tmp_path / "out.json").exists() and not (tmp_path / "small.dat").exists()


def test_a_hard_link_to_an_input_is_that_input(tmp_path):
    """Files are compared by device and inode (issue 41, class 1): --json
    naming a hard link to the record a case writes, or to the deck, is
    refused by both front ends, and the files are kept."""
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "small.dat"))
    subprocess.run([str(BIN / "mlid-batch"), deck.name], capture_output=True, cwd=tmp_path,
                   timeout=120, check=True)
    os.link(tmp_path / "small.dat", tmp_path / "hard.dat")
    os.link(deck, tmp_path / "deck_link.json")
    record, text = (tmp_path / "small.dat").read_bytes(), deck.read_bytes()
    for target, says in (("hard.dat", "(a file this run reads or writes: deck.nml case 1)"),
                         ("deck_link.json", "")):
        for run in _both([deck.name, "--json", target], tmp_path):
            assert run.returncode == 1 and run.stdout == "", run.stderr
            assert f"cannot write --json {target} " in run.stderr and says in run.stderr
    assert (tmp_path / "small.dat").read_bytes() == record and deck.read_bytes() == text


def test_a_link_is_written_through(tmp_path):
    """--json naming a link to a file: the file it names gets the JSON and
    the link stays a link (a rename onto the link put a file in its place
    and left the file it named as it was)."""
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "small.dat"))
    texts = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        (tmp_path / "real.json").write_text("old")
        (tmp_path / "link.json").unlink(missing_ok=True)
        (tmp_path / "link.json").symlink_to("real.json")
        run = subprocess.run([str(BIN / exe), *pre, deck.name, "--json", "link.json"],
                             capture_output=True, text=True, cwd=tmp_path, timeout=120)
        assert run.returncode == 0, run.stderr
        assert (tmp_path / "link.json").is_symlink()
        texts.append((tmp_path / "real.json").read_text())
    assert texts[0] == texts[1] and texts[0].startswith("[")


@pytest.mark.skipif(os.geteuid() != 0 or not shutil.which("setpriv"),
                    reason="needs root to run as another user (root itself may write anything)")
def test_a_file_the_user_may_not_write_is_refused(tmp_path):
    """A JSON file of another user's, read-only, in a folder this user may
    write: refused in one line before any case runs (the rename replaced
    it, owner and all)."""
    nobody = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"]
    env = {**os.environ, "HOME": str(tmp_path), "MPLCONFIGDIR": str(tmp_path)}
    for exe in ("mlid", "mlid-batch"):      # a checkout in a folder only root may enter
        probe = subprocess.run([*nobody, str(BIN / exe), "--help"], capture_output=True,
                               env=env, timeout=120)
        if probe.returncode != 0:
            pytest.skip(f"user nobody cannot run {BIN / exe} here")
    os.chmod(tmp_path, 0o777)
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK.replace("DATA", "small.dat"))
    os.chmod(deck, 0o644)
    ro = tmp_path / "ro.json"
    ro.write_text("root's")
    os.chmod(ro, 0o444)
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        run = subprocess.run([*nobody, str(BIN / exe), *pre, deck.name, "--json", "ro.json"],
                             capture_output=True, text=True, cwd=tmp_path, timeout=120, env=env)
        assert run.returncode == 1 and run.stdout == "", run.stderr
        assert run.stderr.splitlines()[-1] == (f"{exe}: cannot write --json ro.json (a file you "
                                               "may not write)"), run.stderr
    assert ro.read_text() == "root's" and ro.stat().st_uid == 0
