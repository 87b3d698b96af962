"""Hypothesis fuzzing of records with non-ASCII text (issue 41, class 2 and
8): Unicode and stray bytes in comments, header names, values and the file's
own name.  FlightData.load may raise only mlid.MlidError, in one line of
text; what sits in a comment changes nothing that is read; a header name of
any text can be asked for by that name."""

import tempfile
from pathlib import Path

import numpy as np
import pytest

import mlid

hypothesis = pytest.importorskip("hypothesis", reason="make install adds hypothesis to .venv")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

ROWS = np.column_stack([0.02 * np.arange(30), np.sin(np.arange(30) / 4.0),
                        np.cos(np.arange(30) / 5.0), 0.1 * np.arange(30)])
BODY = b"".join(b" ".join(f"{v:.6g}".encode() for v in row) + b"\n" for row in ROWS)

# any text a logger or an engineer may put in a record: every plane of
# Unicode (no surrogates), the no-break space, the Unicode minus, a BOM
TEXT = st.text(st.characters(blacklist_categories=("Cs",)), max_size=24) | st.sampled_from(
    ["\u00a0", "\u2212", "\ufeff", "vol été", "µrad/s", "°C", "角速度", "\u202e", "\x00", "\r"])
# bytes that are no UTF-8 at all (Latin-1, a cut sequence)
RAW = st.binary(max_size=16) | st.sampled_from([b"\xe9t\xe9", b"\xc3", b"\xff\xfe", b"\xb5rad"])
FUZZ = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))


def _load(folder, name, data, **kw):
    path = Path(folder) / name
    path.write_bytes(data)
    try:
        return mlid.FlightData.load(path, **kw), None
    except mlid.MlidError as exc:
        text = str(exc)
        assert isinstance(text, str) and "\n" not in text, text
        return None, text


@FUZZ
@given(st.lists(TEXT | RAW, min_size=1, max_size=4), st.integers(0, 30))
def test_text_in_a_comment_changes_nothing_read(notes, where):
    """Comments of any text or bytes, before or among the rows, after the
    header: the record reads as without them (a NUL or a CR in a comment
    too: a comment holds any bytes)."""
    lines = BODY.split(b"\n")
    comments = [b"# " + (n.encode("utf-8", "surrogatepass") if isinstance(n, str) else n)
                .replace(b"\n", b" ") for n in notes]
    lines[where:where] = comments
    with tempfile.TemporaryDirectory() as d:
        data, err = _load(d, "r.dat", b"# t u y1 y2\n" + b"\n".join(lines), time_col=1,
                          input_cols=[2], output_cols=[3, 4])
        assert err is None, (comments, err)
        assert np.array_equal(data.t, np.array([float(f"{v:.6g}") for v in ROWS[:, 0]]))
        assert data.input_names == ["u"] and data.output_names == ["y1", "y2"]


@FUZZ
@given(st.lists(TEXT, min_size=4, max_size=4))
def test_a_header_of_any_text_is_read_or_refused_in_words(names):
    """A header line whose four names are any text: the record reads by
    column number, or is refused with one line; when each name is one word
    of printable text, each column can be asked for by its name."""
    header = "# " + " ".join(names)
    with tempfile.TemporaryDirectory() as d:
        data, err = _load(d, "r.dat", header.encode("utf-8", "surrogatepass") + b"\n" + BODY,
                          time_col=1, input_cols=[2], output_cols=[3, 4])
        if err is not None:
            return
        assert data.nt == 30 and data.y.shape == (30, 2)
        words = [n for n in names]
        plain = all(w and w.isprintable() and len(w.split()) == 1 and "," not in w
                    and "#" not in w and "[" not in w and "\ufeff" not in w
                    and len(w.encode()) <= 32 for w in words) and len(set(words)) == 4
        if plain:
            data, err = _load(d, "r.dat", header.encode() + b"\n" + BODY, time_col=words[0],
                              input_cols=[words[1]], output_cols=words[2:])
            assert err is None, (words, err)
            assert data.output_names == words[2:]


@FUZZ
@given(st.lists(TEXT | RAW, min_size=1, max_size=3), st.integers(1, 29))
def test_text_in_a_row_is_refused_in_words(junk, row):
    """Text or bytes in a data row: refused in one line naming the line
    (a row of other fields is never read as numbers it does not hold)."""
    lines = BODY.split(b"\n")
    bad = b" ".join(j.encode("utf-8", "surrogatepass") if isinstance(j, str) else j
                    for j in junk).replace(b"\n", b" ").replace(b"#", b"")
    if not bad.strip() or bad.strip(b" \t\r,") == b"":
        return
    lines[row] = lines[row] + b" " + bad
    with tempfile.TemporaryDirectory() as d:
        data, err = _load(d, "r.dat", b"# t u y1 y2\n" + b"\n".join(lines), time_col=1,
                          input_cols=[2], output_cols=[3, 4])
        if err is None:            # what was added read as a number: one more column
            pytest.fail(f"row {row + 2} with {bad!r} was read")
        assert f"line {row + 2}" in err, err


@FUZZ
@given(TEXT.filter(lambda s: s and "/" not in s and "\x00" not in s and s not in (".", "..")))
def test_a_file_name_of_any_text(name):
    """A record whose name is any text: it is read, or refused in words (a
    name the file system takes cannot break the reader or its message)."""
    with tempfile.TemporaryDirectory() as d:
        try:
            (Path(d) / name).write_bytes(b"# t u y1 y2\n" + BODY)
        except (OSError, UnicodeEncodeError):
            return
        try:
            data = mlid.FlightData.load(Path(d) / name, time_col=1, input_cols=[2],
                                        output_cols=[3, 4])
        except mlid.MlidError as exc:
            assert "\n" not in str(exc)
            return
        assert data.nt == 30
