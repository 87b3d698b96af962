import numpy as np
import pytest

import mlid


def test_load_named_csv_columns(tmp_path):
    f = tmp_path / "rec.csv"
    f.write_text("time,de,q,alpha\n0.0,0.1,1.0,2.0\n0.1,0.2,1.5,2.5\n0.2,0.3,2.0,3.0\n")
    d = mlid.FlightData.load(f, time_col="time", input_cols=["de"], output_cols=["alpha", "q"],
                             skip_rows=1)
    np.testing.assert_array_equal(d.t, [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(d.y[:, 0], [2.0, 2.5, 3.0])
    np.testing.assert_array_equal(d.u[:, 0], [0.1, 0.2, 0.3])


def test_load_whitespace_numbered_columns_with_comments(tmp_path):
    f = tmp_path / "rec.dat"
    f.write_text("# t u y\n0 1 2\n1 1 3   # trailing comment\n2 0 4\n")
    d = mlid.FlightData.load(f, 1, [2], [3])
    assert d.nt == 3 and d.y[2, 0] == 4


def test_save_load_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    d = mlid.FlightData(np.arange(5) * 0.1, rng.normal(size=(5, 2)), rng.normal(size=(5, 3)))
    d.save(tmp_path / "x.dat")
    e = mlid.FlightData.load(tmp_path / "x.dat", 1, [2, 3], [4, 5, 6])
    np.testing.assert_array_equal(d.y, e.y)
    np.testing.assert_array_equal(d.u, e.u)


@pytest.mark.parametrize("text, kwargs, match", [
    ("0 1 2\n1 x 3\n", {}, "line 2: column 2: 'x' is not a number"),
    ("0 1 2\n1 1\n", {}, "line 2: 2 columns, the first data row has 3"),
    ("0 1 2\n", {"output_cols": [7]}, "column 7 requested"),
    ("time,a\n0,1\n", {"time_col": "t", "skip_rows": 1}, "no channel named t \\(channels: time a\\)"),
])
def test_bad_files(tmp_path, text, kwargs, match):
    f = tmp_path / "bad.dat"
    f.write_text(text)
    args = {"time_col": 1, "input_cols": [2], "output_cols": [3]}
    args.update(kwargs)
    with pytest.raises(mlid.InputError, match=match):
        mlid.FlightData.load(f, **args)


def test_missing_file(tmp_path):
    with pytest.raises(mlid.InputError, match="not found"):
        mlid.FlightData.load(tmp_path / "none.dat", 1, [2], [3])
