"""Non-ASCII text in decks, file names and titles (issue 41, class 2): both
front ends give the same report, JSON and exit code, a failure is one line
naming the case, and `mlid run` never ends in an internal error, whatever
the terminal's encoding.  (Main's `mlid run` crashed on each of these with
"internal error: TypeError: function takes exactly 5 arguments".)"""

import os
import subprocess

import pytest

import mlid
from conftest import BIN, two_case_deck

PLAIN = two_case_deck()

#: name: (the deck's change, the failure's text or None when it runs)
DECKS = {
    "no-break space before a number": (("ny = 2,\n    f = -1.0", "ny =\u00a02,\n    f = -1.0"),
                                       "bad value"),
    "Unicode minus in a matrix": (("f = -1.0, 0.5, -0.8", "f = \u22121.0, 0.5, -0.8"),
                                  "bad value \u22121.0 for f"),
    "curly quotes in a title": (("'middle'", "'\u2018middle\u2019'"), None),
    "CJK title": (("'middle'", "'\u98db\u884c\u8a66\u9a13'"), None),
    "missing record with an accented name": (("file = 'small.dat', time",
                                              "file = 'vol_\u00e9t\u00e9.dat', time"),
                                             "file not found: vol_\u00e9t\u00e9.dat"),
}


def _deck(tmp_path, change):
    old, new = change
    assert old in PLAIN
    deck = tmp_path / "deck.nml"
    deck.write_text(PLAIN.replace(old, new), encoding="utf-8")
    return deck


def _run(exe, deck, env=None):
    pre = ["run"] if exe == "mlid" else []
    out = deck.parent / f"{exe}.json"
    run = subprocess.run([str(BIN / exe), *pre, deck.name, "--json", out.name],
                         capture_output=True, cwd=deck.parent, env=env)
    return run, out.read_bytes()


@pytest.mark.parametrize("name", list(DECKS))
def test_both_front_ends_agree_on_non_ascii_text(name, tmp_path):
    change, failure = DECKS[name]
    deck = _deck(tmp_path, change)
    (py, py_json), (fo, fo_json) = (_run(exe, deck) for exe in ("mlid", "mlid-batch"))
    assert py.returncode == fo.returncode == (1 if failure else 0), py.stderr
    assert py.stdout == fo.stdout and py_json == fo_json
    if failure:
        lines = [py.stderr.decode().splitlines()[0], fo.stderr.decode().splitlines()[0]]
        for line in lines:
            assert "case 2" in line and failure in line, line
        assert lines[0].split(":", 1)[1] == lines[1].split(":", 1)[1]
    assert b"internal error" not in py.stderr


def test_an_ascii_terminal_gets_the_same_bytes(tmp_path):
    """PYTHONIOENCODING=ascii (or the C locale): `mlid run` writes the
    core's text in UTF-8, as mlid-batch does."""
    deck = _deck(tmp_path, DECKS["CJK title"][0])
    env = dict(os.environ, PYTHONIOENCODING="ascii", LC_ALL="C", LANG="C")
    (py, py_json), (fo, fo_json) = (_run(exe, deck, env) for exe in ("mlid", "mlid-batch"))
    assert py.returncode == fo.returncode == 0, py.stderr
    assert py.stdout == fo.stdout and py_json == fo_json
    assert "\u98db\u884c\u8a66\u9a13".encode() in py.stdout


def test_the_api_names_a_missing_non_ascii_file(tmp_path):
    """FlightData.load and read_deck: an InputError naming the file."""
    missing = tmp_path / "vol_\u00e9t\u00e9.dat"
    with pytest.raises(mlid.InputError, match="vol_\u00e9t\u00e9.dat"):
        mlid.FlightData.load(missing, 1, [2], [3])
    with pytest.raises(mlid.InputError, match="vol_\u00e9t\u00e9.nml"):
        mlid.read_deck(tmp_path / "vol_\u00e9t\u00e9.nml")



def test_a_deck_whose_name_is_no_utf8_runs_alike(tmp_path):
    """A deck named with raw Latin-1 bytes (d\\xe9ck.nml), its case 2
    failing: mlid run refused the whole deck (UnicodeEncodeError: surrogates
    not allowed), mlid-batch ran it; now both run every case and print the
    same bytes, the name's byte as it is."""
    name = os.fsdecode(b"d\xe9ck.nml")
    (tmp_path / name).write_text(two_case_deck("no_such.dat"))
    got = []
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        run = subprocess.run([os.fsencode(str(BIN / exe)), *pre, b"d\xe9ck.nml", b"--json",
                              f"{exe}.json".encode()], capture_output=True, cwd=tmp_path)
        assert run.returncode == 1, run.stderr
        got.append((run.stdout, run.stderr.split(b": ", 1)[1],
                    (tmp_path / f"{exe}.json").read_bytes()))
    assert got[0] == got[1]
    assert b"d\xe9ck.nml case 2" in got[0][1]


def test_the_api_reads_a_record_whose_name_is_no_utf8(tmp_path):
    """FlightData.load of os.fsdecode(b'vol_\\xe9t\\xe9.dat'): a bare
    UnicodeEncodeError before; now the file is read."""
    (tmp_path / os.fsdecode(b"vol_\xe9t\xe9.dat")).write_text("# t u y\n0 0 1\n0.1 1 2\n0.2 0 3\n")
    d = mlid.FlightData.load(tmp_path / os.fsdecode(b"vol_\xe9t\xe9.dat"), time_col=1,
                             input_cols=[2], output_cols=[3])
    assert d.nt == 3
    with pytest.raises(mlid.InputError, match="file not found"):
        mlid.FlightData.load(tmp_path / os.fsdecode(b"n\xe9ant.dat"), output_cols=[2])
