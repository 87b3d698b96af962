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


# ---- time in a DataFrame (issue 42, data in) ------------------------------------

def _frame():
    pd = pytest.importorskip("pandas")
    t = 0.02 * np.arange(100)
    return pd, t, pd.DataFrame({"t": t, "u": np.sin(3 * t), "y1": np.cos(t), "y2": np.sin(t)})


def _times():
    pd, t, base = _frame()
    start = pd.Timestamp("2026-12-07 10:00:00")
    dates = start + pd.to_timedelta(t, unit="s")
    indexed = base.drop(columns="t")
    return t, {
        "seconds": (base, "t"),
        "timedelta64 column": (base.assign(t=pd.to_timedelta(t, unit="s")), "t"),
        "datetime64 column": (base.assign(t=dates), "t"),
        "datetime64 with a time zone": (base.assign(t=dates.tz_localize("UTC")), "t"),
        "seconds as the index": (base.set_index("t"), "t"),
        "TimedeltaIndex by name": (indexed.set_axis(pd.TimedeltaIndex(
            pd.to_timedelta(t, unit="s"), name="time")), "time"),
        "DatetimeIndex as 'index'": (indexed.set_axis(pd.DatetimeIndex(dates)), "index"),
        "dates from a later start": (base.assign(t=dates + pd.Timedelta(days=400)), "t"),
    }


@pytest.mark.parametrize("kind", list(_times()[1]))
def test_time_of_any_pandas_kind_is_seconds_from_the_first_sample(kind):
    """A timedelta64 column was read as nanoseconds (t = 0, 2e7, ...), a
    datetime64 one as epoch nanoseconds, and time as the index was 'no
    channel named time'."""
    t, kinds = _times()
    frame, time_col = kinds[kind]
    d = mlid.FlightData.from_frame(frame, time_col, ["u"], ["y1", "y2"])
    assert np.max(np.abs(d.t - t)) < 1e-9
    assert np.array_equal(d.y[:, 0], np.cos(t))


def test_dates_elsewhere_and_ambiguous_time_are_refused_in_words():
    pd, t, base = _frame()
    stamp = base.assign(stamp=pd.Timestamp("2026-01-01") + pd.to_timedelta(t, unit="s"))
    with pytest.raises(mlid.InputError, match=r"^column stamp holds dates \(datetime64\[ns\]\); "
                                              r"only the time column may \(time_col = 't'\)$"):
        mlid.FlightData.from_frame(stamp, "t", ["u"], ["y1", "y2"])
    both = base.set_index(pd.Index(t, name="t"))
    with pytest.raises(mlid.InputError, match="names both a column and the index"):
        mlid.FlightData.from_frame(both, "t", ["u"], ["y1", "y2"])
    gap = base.assign(t=pd.to_timedelta(t, unit="s"))
    gap.loc[5, "t"] = pd.NaT
    with pytest.raises(mlid.InputError, match=r"time column t has a missing value \(NaT\) at row 5"):
        mlid.FlightData.from_frame(gap, "t", ["u"], ["y1", "y2"])


def test_an_xarray_dataset_with_a_time_coordinate_and_units():
    """Issue 42, data in: a Dataset along its time coordinate (dates here),
    each variable's units attribute its unit (deg read as deg, the core's
    rad inside)."""
    xr = pytest.importorskip("xarray")
    pd = pytest.importorskip("pandas")
    t = 0.02 * np.arange(100)
    ds = xr.Dataset({"de": ("time", np.sin(3 * t), {"units": "deg"}),
                     "q": ("time", np.cos(t), {"units": "deg/s"}),
                     "a": ("time", np.sin(t))},
                    coords={"time": pd.Timestamp("2026-01-01") + pd.to_timedelta(t, unit="s")})
    d = mlid.FlightData.from_frame(ds, "time", ["de"], ["q", "a"])
    assert np.max(np.abs(d.t - t)) < 1e-9
    assert d.input_units == ["rad"] and d.output_units == ["rad/s", ""]
    assert np.allclose(d.u[:, 0], np.deg2rad(np.sin(3 * t)), rtol=1e-14)
    assert np.array_equal(d.y[:, 1], np.sin(t))
    with pytest.raises(mlid.InputError, match="one dimension"):
        mlid.FlightData.from_frame(xr.Dataset({"x": (("a", "b"), np.zeros((2, 2)))}), "a")
