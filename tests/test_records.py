"""Text flight records through the core's one reader (mlid_record): what it
tolerates, what it refuses (one line naming file and line), the same for
FlightData.load and mlid-batch, and FlightData's refusal of silently wrong
shapes."""
import re
import subprocess
import sys
import time

import numpy as np
import pytest

import mlid
from conftest import BIN
from mlid._bridge import api as _api, text as _text
from test_decks import SIM, SMALL

T3 = [0.0, 0.1, 0.2]


def load(tmp_path, data, name="rec.dat", **kw):
    f = tmp_path / name
    f.write_bytes(data if isinstance(data, bytes) else data.encode())
    args = {"time_col": 1, "input_cols": [2], "output_cols": [3]}
    args.update(kw)
    return mlid.FlightData.load(f, **args)


def test_bom_crlf_comment_bytes_d_exponents(tmp_path):
    data = (b"\xef\xbb\xbf# caf\xe9 (latin-1) \xce\xb4e (UTF-8)\r\n\r\n"
            b"0.0D+00\t1,  2d-3  # trailing \xff comment\r\n"
            b"   # \x00\x80 any bytes\r\n"
            b"1.0d-1 , -1.5E+01 3\r\n2e-1 .5 +4.\r\n")
    d = load(tmp_path, data)
    np.testing.assert_array_equal(d.t, T3)
    np.testing.assert_array_equal(d.u[:, 0], [1.0, -15.0, 0.5])
    np.testing.assert_array_equal(d.y[:, 0], [2e-3, 3.0, 4.0])


def test_header_names_become_channel_names(tmp_path):
    d = load(tmp_path, "# time, de, q\n0 1 2\n0.1 1 3\n0.2 0 4\n", time_col="time",
             input_cols=["de"], output_cols=["q"])
    assert d.input_names == ["de"] and d.output_names == ["q"]
    d = load(tmp_path, "time de q\n0 1 2\n0.1 1 3\n0.2 0 4\n", output_names=["pitch rate"])
    assert d.input_names == ["de"] and d.output_names == ["pitch rate"]
    d = load(tmp_path, "0 1 2\n0.1 1 3\n0.2 0 4\n")
    assert d.input_names == ["u1"] and d.output_names == ["y1"]


@pytest.mark.parametrize("note", [b"# operator \x00 note", b"# \x1b[0m 12 deg C", b"# ok"])
def test_a_note_after_the_header_keeps_the_names_and_holds_any_bytes(note, tmp_path):
    """Issue 41, class 8: a # comment between the header and the data, of
    any bytes (a NUL too, as the README says), is read past; the names are
    the last header line's with a name per column (a NUL in the note was
    refused, and the note took the header's place: no names)."""
    (tmp_path / "r.dat").write_bytes(b"# time de q\n" + note + b"\n0 1 2\n0.1 1 3\n0.2 0 4\n")
    d = mlid.FlightData.load(tmp_path / "r.dat", time_col="time", input_cols=["de"],
                             output_cols=["q"])
    assert d.input_names == ["de"] and d.output_names == ["q"] and d.nt == 3


def test_skip_rows_then_header(tmp_path):
    d = load(tmp_path, "flight 12, run 3\nt,u,y\n0,1,2\n0.1,1,3\n0.2,0,4\n", skip_rows=1,
             output_cols=["y"])
    assert d.output_names == ["y"] and d.nt == 3


def test_reads_what_mlid_batch_writes(tmp_path):
    """The batch program's own output ('# t, inputs, outputs (mlid simulate)',
    a comma in the header) reads back, in Python and in mlid-batch."""
    deck = tmp_path / "sim.nml"
    deck.write_text(SIM)
    out = subprocess.run([str(BIN / "mlid-batch"), str(deck)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    text = (tmp_path / "small.dat").read_text()
    assert text.startswith("# t, inputs, outputs (mlid simulate)\n")
    d = mlid.FlightData.load(tmp_path / "small.dat", 1, [2], [3, 4])
    assert d.nt == 201 and d.input_names == ["u1"]
    table = np.array([[float(v) for v in ln.split()] for ln in text.splitlines()[1:]])
    np.testing.assert_array_equal(d.y, table[:, 2:4])
    deck.write_text(SIM + SMALL.format(title="fit", file="small.dat"))
    out = subprocess.run([str(BIN / "mlid-batch"), str(deck)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr


def test_a_100000_character_line(tmp_path):
    data = "#" + "x" * 100_000 + "\n0 " + " " * 100_000 + "1 2\n0.1 1 3 #" + "c" * 100_000 + \
        "\n0.2 1 4\n"
    d = load(tmp_path, data)
    np.testing.assert_array_equal(d.y[:, 0], [2, 3, 4])
    wide = np.arange(20_000) * 1e-3   # 20,000 columns on one line of ~ 170,000 characters
    f = tmp_path / "wide.dat"
    f.write_text(" ".join(f"{v:.6e}" for v in wide) + "\n" +
                 " ".join(f"{v + 1:.6e}" for v in wide) + "\n")
    d = mlid.FlightData.load(f, 1, [2], [20_000])
    np.testing.assert_allclose(d.y[:, 0], [wide[-1], wide[-1] + 1])


@pytest.mark.parametrize("data, match", [
    ("0 1 2\n0.1 3*0.0\n", "rec.dat line 2: column 2: repeat count '3[*]0.0'"),
    ("0 1 2\n0.1 NaN 3\n", "line 2: column 2: 'NaN' is not finite"),
    ("0 1 2\n0.1 1 inf\n", "line 2: column 3: 'inf' is not finite"),
    ("0 1 1e400\n", "line 1: column 3: '1e400' is not finite"),
    ("0 1 2\n0.1 x 3\n", "line 2: column 2: 'x' is not a number"),
    ("0 1 2\n\n0.1 1\n", "line 3: 2 columns, the first data row has 3"),
    ("0 1 2\n0.1 1 2 3\n", "line 2: 4 columns, the first data row has 3"),
    ("0,1,2\n0.1,,3\n", "line 2: an empty field"),
    ("0 1\n0.1 2\n", "column 3 requested, the file has columns 1 to 2"),
    ("0 1 2\n0.1 1 2\n# c\n0.1 1 2\n", r"line 4: time does not increase: 0.1 s after 0.1 s "
                                       r"\(sample 3\)"),
    ("", "no data rows"),
    ("# only\n# comments\n", "no data rows"),
])
def test_refused(tmp_path, data, match):
    with pytest.raises(mlid.InputError, match=match):
        load(tmp_path, data)


def test_gap_named_with_time_and_row(tmp_path):
    t = np.r_[np.arange(618) * 0.02, 20.0 + np.arange(10) * 0.02]
    rows = "\n".join(f"{v:.2f} 0 0" for v in t)
    with pytest.raises(mlid.InputError) as err:
        load(tmp_path, "# t u y\n" + rows + "\n")
    msg = str(err.value)
    assert ("rec.dat line 620: a gap in time from 12.34 s to 20 s at sample 619 (sampling "
            "0.02 s): split the record into manoeuvres (several files, or windows t_start/t_end "
            "of one)") in msg
    assert "\n" not in msg and len(msg) <= 256
    status, text = _api.mlid_check_time(t, [1])
    assert status == 1 and "at sample 619" in _text(text)
    status, _ = _api.mlid_check_time(np.arange(5.0), [1])
    assert status == 0


def test_no_crash_on_what_is_no_record(tmp_path):
    for data in (bytes(range(256)) * 64, b"\x00" * 1000, b"\n" * 10_000, b",,,\n", b"#"):
        with pytest.raises(mlid.InputError):
            load(tmp_path, data)
    with pytest.raises(mlid.InputError):
        mlid.FlightData.load(tmp_path, 1, [2], [3])      # a folder
    with pytest.raises(mlid.InputError, match="not found"):
        mlid.FlightData.load(tmp_path / "none.dat", 1, [2], [3])
    with pytest.raises(mlid.InputError):
        mlid.FlightData.load(None, 1, [2], [3])
    with pytest.raises(mlid.InputError, match="no channel named q \\(the file names no columns"):
        load(tmp_path, "0 1 2\n0.1 1 3\n", output_cols=["q"])


def test_batch_and_python_refuse_alike(tmp_path):
    (tmp_path / "bad.dat").write_text("0 1 2 3\n0.02 1 3*0.0\n")
    deck = tmp_path / "bad.nml"
    deck.write_text(SMALL.format(title="bad", file="bad.dat"))
    for cmd in ("mlid", "mlid-batch"):
        args = [str(BIN / cmd)] + (["run"] if cmd == "mlid" else []) + [str(deck)]
        out = subprocess.run(args, capture_output=True, text=True)
        assert out.returncode == 1 and "line 2: column 3: repeat count" in out.stderr


def test_save_load_round_trip_names_and_exact_values(tmp_path):
    rng = np.random.default_rng(3)
    d = mlid.FlightData(np.arange(50) * 0.02, rng.normal(size=(50, 2)) * 1e-300,
                        rng.normal(size=(50, 3)) * 1e300, ["de", "da"], ["p", "q", "r"])
    d.save(tmp_path / "x.dat")
    e = mlid.FlightData.load(tmp_path / "x.dat", 1, [2, 3], [4, 5, 6])
    np.testing.assert_array_equal(d.t, e.t)
    np.testing.assert_array_equal(d.u, e.u)
    np.testing.assert_array_equal(d.y, e.y)
    assert e.input_names == ["de", "da"] and e.output_names == ["p", "q", "r"]


def test_flightdata_refuses_silently_wrong_shapes():
    t = np.arange(300) * 0.02
    y = np.zeros((300, 4))
    with pytest.raises(mlid.InputError,
                       match=r"y has shape \(4, 300\); expected \(nt, ny\) = \(300, n\), "
                             r"one row per sample \(given ny x nt: transpose it\)"):
        mlid.FlightData(t, np.zeros((300, 1)), y.T)
    with pytest.raises(mlid.InputError, match=r"u has shape \(2, 300\)"):
        mlid.FlightData(t, np.zeros((2, 300)), y)
    with pytest.raises(mlid.InputError, match=r"y has shape \(1200,\)"):
        mlid.FlightData(t, np.zeros(300), y.ravel())
    with pytest.raises(mlid.InputError, match=r"t has shape \(300, 2\)"):
        mlid.FlightData(np.c_[t, t], np.zeros(300), y)
    assert mlid.FlightData(t[:, None], np.zeros(300), y).t.shape == (300,)   # a column: clear
    # NaN is the fit's to refuse, with the sample named (a record may be cleaned first)
    gappy = mlid.FlightData(np.r_[0, 1, np.nan], np.zeros(3), np.zeros((3, 2)))
    model = mlid.LinearModel([[-1.0]], [[1.0]], [[1.0], [1.0]], free=["f(1,1)"])
    with pytest.raises(mlid.InputError, match="time is not finite at sample 3"):
        mlid.fit(model, gappy)
    for bad in (None, "abc", np.array([1 + 1j] * 300), np.array([object()] * 300)):
        with pytest.raises(mlid.InputError):
            mlid.FlightData(t, bad, y)
    with pytest.raises(mlid.InputError):
        mlid.FlightData(None, np.zeros(300), y)
    d = mlid.FlightData(t, np.zeros(300), y)           # one input as a 1-D array
    assert d.u.shape == (300, 1) and d.y.shape == (300, 4)
    d = mlid.FlightData(t, np.zeros((300, 0)), y)      # no inputs
    assert d.u.shape == (300, 0)


def test_load_time_against_loadtxt(tmp_path):
    """Prints the time to read a 10,000-row record (not a pass/fail bound)."""
    rng = np.random.default_rng(0)
    d = mlid.FlightData(np.arange(10_000) * 0.01, rng.normal(size=(10_000, 2)),
                        rng.normal(size=(10_000, 4)))
    d.save(tmp_path / "big.dat")
    t0 = time.perf_counter()
    e = mlid.FlightData.load(tmp_path / "big.dat", 1, [2, 3], [4, 5, 6, 7])
    t1 = time.perf_counter()
    table = np.loadtxt(tmp_path / "big.dat")
    t2 = time.perf_counter()
    np.testing.assert_array_equal(e.y, table[:, 3:])
    print(f"\n10,000 x 7 record: FlightData.load {1e3 * (t1 - t0):.1f} ms, "
          f"numpy.loadtxt {1e3 * (t2 - t1):.1f} ms")


def test_a_record_rewritten_while_it_is_read_is_never_read_as_a_prefix(tmp_path, monkeypatch):
    """Issue 41, class 8: a logger rewrites the record (truncate, then write
    it in 64 KiB pieces, then rest) while it is loaded again and again.
    Each load gives all its rows, or is refused in words: 'changed while it
    was read' (its size or modification time differ after the read from
    before), or 'no data rows' (opened just after the truncation: the file
    was empty, and unchanged, while it was read).  Main fitted a prefix of
    the record without a word in 5 of 16 runs."""
    rows = 20_000
    path = tmp_path / "rec.dat"
    t = 0.01 * np.arange(rows)
    path.write_bytes(b"# t u y\n" + b"".join(
        f"{a:.2f} {np.sin(a):.6f} {np.cos(a):.6f}\n".encode() for a in t))
    writer = subprocess.Popen([sys.executable, "-c", f"""
import os, time
blob = open({str(path)!r}, 'rb').read()
while True:
    fd = os.open({str(path)!r}, os.O_WRONLY | os.O_TRUNC)
    for k in range(0, len(blob), 65536):
        os.write(fd, blob[k:k + 65536])
    os.close(fd)
    time.sleep(0.005)
"""])
    outcomes = []
    monkeypatch.chdir(tmp_path)      # messages name the file as given
    try:
        time.sleep(0.2)
        for _ in range(40):
            try:
                outcomes.append(mlid.FlightData.load("rec.dat").nt)
            except mlid.InputError as exc:
                outcomes.append(str(exc))
    finally:
        writer.kill()
        writer.wait()
    for got in outcomes:
        assert got == rows or got == "data file rec.dat: no data rows" or re.fullmatch(
            r"data file rec\.dat changed while it was read \(\d+ bytes when "
            r"opened, \d+ after, or a new modification time\): read it once it is written "
            r"whole", str(got)), got


def test_a_long_record_is_noted_with_its_size(tmp_path):
    """Issue 41, class 8: a fit of a long record (from 200,000 samples) says
    so on stderr, the same from both front ends (a 1e6-sample fit took
    12-18 s with nothing said); a manoeuvre's record says nothing."""
    deck = tmp_path / "deck.nml"
    from conftest import two_case_deck
    deck.write_text(two_case_deck().replace("t_end = 4.0", "t_end = 4000.0"))
    notes = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        (tmp_path / "small.dat").unlink(missing_ok=True)
        run = subprocess.run([str(BIN / exe), *pre, deck.name], capture_output=True, text=True,
                             cwd=tmp_path, timeout=300)
        assert run.returncode == 0, run.stderr
        notes.append(run.stderr.replace(exe + ":", "", 1))
    assert notes[0] == notes[1]
    assert notes[0].splitlines() == [
        " deck.nml case 2 (line 6) 'middle': a long record: 200001 samples of 4 channels (6 MB "
        "of numbers) and 3 free parameters: the fit takes longer than a manoeuvre's"]
    deck.write_text(two_case_deck())
    run = subprocess.run([str(BIN / "mlid-batch"), deck.name], capture_output=True, text=True,
                         cwd=tmp_path, timeout=300)
    assert run.returncode == 0 and run.stderr == ""


def test_a_csv_with_every_field_quoted(tmp_path):
    """A spreadsheet's CSV that quotes every field, header and numbers:
    read as the plain one (it said 'no data rows')."""
    plain = "t,de,q\n0.0,1.0,2.0\n0.1,1.0,3.0\n0.2,0.0,4.0\n"
    quoted = '"t","de","q"\n"0.0","1.0","2.0"\n"0.1","1.0","3.0"\n"0.2","0.0","4.0"\n'
    (tmp_path / "p.csv").write_text(plain)
    (tmp_path / "q.csv").write_text(quoted)
    kw = dict(time_col="t", input_cols=["de"], output_cols=["q"])
    a, b = (mlid.FlightData.load(tmp_path / n, **kw) for n in ("p.csv", "q.csv"))
    assert np.array_equal(a.t, b.t) and np.array_equal(a.y, b.y) and b.output_names == ["q"]
