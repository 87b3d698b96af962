"""Flight-data channels (fortran/case/mlid_channels.f90 and its helpers
mlid_units, mlid_expr): channels by name, units converted on reading and
shown back, derived channels in a small safe language, time windows,
segments cut from one file, and the binary formats the Python front end
reads into the same path (.mat v5 and v7.3, HDF5, DataFrame)."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, REPO, refused_by_both

DATA = REPO.parent / "shared" / "data"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason="real flight data not beside the checkout")
DEG = np.pi / 180

HEADER = "t[s] a[deg] b [ft] c[kt] d[g] e[degC] f[deg/s]\n"
ROWS = np.array([[0.0, 1.5, 1000.0, 120.0, 1.0, 15.0, -3.0],
                 [0.1, -2.0, 1010.0, 121.0, 0.9, 15.5, 4.0],
                 [0.2, 0.25, 1020.0, 122.0, 1.1, 16.0, 0.5]])


def _record(tmp_path, header=HEADER, rows=ROWS, name="rec.dat"):
    path = tmp_path / name
    path.write_text(header + "".join(" ".join(repr(float(v)) for v in r) + "\n" for r in rows))
    return path


def test_units_are_converted_and_shown_back(tmp_path):
    d = mlid.FlightData.load(_record(tmp_path), "t", ["a", "b", "c"], ["d", "e", "f"])
    assert np.allclose(d.u[:, 0], ROWS[:, 1] * DEG, rtol=1e-15)
    assert np.allclose(d.u[:, 1], ROWS[:, 2] * 0.3048, rtol=1e-15)
    assert np.allclose(d.u[:, 2], ROWS[:, 3] * 1852 / 3600, rtol=1e-15)
    assert np.allclose(d.y[:, 0], ROWS[:, 4] * 9.80665, rtol=1e-15)
    assert np.allclose(d.y[:, 1], ROWS[:, 5] + 273.15, rtol=1e-15)
    assert np.allclose(d.y[:, 2], ROWS[:, 6] * DEG, rtol=1e-15)
    assert d.input_units == ["rad", "m", "m/s"] and d.output_units == ["m/s2", "K", "rad/s"]
    for which, cols in (("u", [1, 2, 3]), ("y", [4, 5, 6])):
        for i, c in enumerate(cols):
            values, unit = d.shown(which, i)
            assert np.allclose(values, ROWS[:, c], rtol=1e-13, atol=1e-12)
            assert unit == HEADER.replace(" [", "[").split()[c].split("[")[1].rstrip("]")


def test_units_declared_by_the_caller(tmp_path):
    path = _record(tmp_path, header="t a b\n", rows=ROWS[:, :3])
    d = mlid.FlightData.load(path, "t", ["a"], ["b"], units={"a": "deg", "B": "ft"})
    assert np.allclose(d.u[:, 0], ROWS[:, 1] * DEG) and d.output_units == ["m"]
    d2 = mlid.FlightData.load(path, 1, [2], [3], columns=["t", "a[deg]", "b[ft]"])
    assert np.array_equal(d.u, d2.u) and np.array_equal(d.y, d2.y)
    with pytest.raises(mlid.InputError, match="a is declared in rad but the file says deg"):
        mlid.FlightData.load(_record(tmp_path, name="h.dat"), "t", ["a"], ["b"],
                             units={"a": "rad"})
    with pytest.raises(mlid.InputError, match=r"column a: unknown unit 'furlong' \(known: s ms"):
        mlid.FlightData.load(path, "t", ["a"], ["b"], units={"a": "furlong"})
    with pytest.raises(mlid.InputError, match="units: no channel named zz"):
        mlid.FlightData.load(path, "t", ["a"], ["b"], units={"zz": "deg"})


def test_time_must_be_in_a_unit_of_time(tmp_path):
    """A time declared in kt, deg or rad would be scaled as one (a fit on a
    time axis 0.51 or 0.017 times the record's); refused the same way by
    FlightData.load, mlid run and mlid-batch.  ms and no unit are times."""
    path = _record(tmp_path)
    assert np.allclose(mlid.FlightData.load(path, "t", ["a"], ["d"], columns=["t[ms]"]).t,
                       ROWS[:, 0] * 1e-3, rtol=1e-15)
    assert np.array_equal(mlid.FlightData.load(path, "t", ["a"], ["d"], columns=["t"]).t,
                          ROWS[:, 0])
    for none in ("t[-]", "t[1]"):            # declared as none: read as it is
        assert np.array_equal(mlid.FlightData.load(path, "t", ["a"], ["d"], columns=[none]).t,
                              ROWS[:, 0])
    with pytest.raises(mlid.InputError, match=r"rec.dat: time channel t is in kt, not a unit "
                                              r"of time \(s ms\)$"):
        mlid.FlightData.load(path, "t", ["a"], ["d"], columns=["t[kt]"])
    with pytest.raises(mlid.InputError, match="time channel t is in deg, not a unit of time"):
        mlid.FlightData.load(_record(tmp_path, "", ROWS, "bare.dat"), 1, [2], [3],
                             columns=["t[deg]"])
    model = ("&case title = 'time unit', job = 'estimate' /\n"
             "&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1.0, g = 1.0, h = 1,\n"
             "    free = 'f(1,1)' /\n")
    for data, unit in (("columns = 't[kt]', 'a', 'b'", "kt"),
                       ("columns = 't', 'a', 'b', units = 't = rad'", "rad"),
                       ("columns = 't[deg]', 'a', 'b'", "deg")):
        deck = tmp_path / "bad.nml"
        deck.write_text(model + f"&data file = 'bare.dat', {data}, time_col = 't', "
                                "input_cols = 'a', output_cols = 'b' /\n")
        refused_by_both(deck, f"bare.dat: time channel t is in {unit}, not a unit of "
                              "time (s ms)", cwd=tmp_path)


def test_derived_channels(tmp_path):
    d = mlid.FlightData.load(_record(tmp_path), "t", ["da", "flip", "one"], ["shifted"],
                             derived={"da": "(a - A/4)/2", "flip": "-a", "one": "1",
                                      "shifted": "2.5*b + 100"})
    assert np.allclose(d.u[:, 0], (ROWS[:, 1] - ROWS[:, 1] / 4) / 2 * DEG, rtol=1e-14)
    assert np.allclose(d.u[:, 1], -ROWS[:, 1] * DEG, rtol=1e-14)
    assert np.array_equal(d.u[:, 2], np.ones(3))
    assert np.allclose(d.y[:, 0], 2.5 * ROWS[:, 2] * 0.3048 + 100, rtol=1e-14)
    # a derived channel takes its channels' unit where they share one
    assert d.input_units == ["rad", "rad", ""] and d.input_display[1][0] == "deg"
    assert d.output_units == ["m"]


RANDOM_FUNCS = {"sin": 1, "cos": 1, "atan": 1, "abs": 1, "atan2": 2, "min": 2, "max": 2}


def _random_expression(rng, depth):
    """A random expression and the same in numpy's spelling."""
    if depth == 0 or rng.random() < 0.25:
        if rng.random() < 0.5:
            v = f"{rng.uniform(-5, 5):.6g}"
            return v, f"({v})"
        n = rng.choice(["a", "b", "c", "A"])
        return n, f"x['{n.lower()}']"
    kind = rng.integers(4)
    if kind == 0:
        f = rng.choice(list(RANDOM_FUNCS))
        args = [_random_expression(rng, depth - 1) for _ in range(RANDOM_FUNCS[f])]
        npf = {"min": "np.minimum", "max": "np.maximum", "atan": "np.arctan",
               "atan2": "np.arctan2"}.get(f, f"np.{f}")
        return (f"{f}({', '.join(a for a, _ in args)})",
                f"{npf}({', '.join(b for _, b in args)})")
    if kind == 1:
        a, b = _random_expression(rng, depth - 1)
        return f"-{a}" if not a.startswith("-") else f"-({a})", f"(-{b})"
    op = rng.choice(["+", "-", "*", "/"])
    (a1, b1), (a2, b2) = _random_expression(rng, depth - 1), _random_expression(rng, depth - 1)
    return f"({a1} {op} {a2})", f"({b1} {op} {b2})"


def test_expressions_against_numpy(tmp_path):
    """300 random expressions evaluated by the core and by numpy (a second
    implementation): the same to rounding."""
    rng = np.random.default_rng(11)
    x = {"t": np.arange(50) * 0.1, "a": rng.normal(size=50), "b": rng.normal(size=50) + 3,
         "c": rng.uniform(0.5, 2, size=50)}
    frame = _Frame(x)
    for _ in range(300):
        text, numpy_text = _random_expression(rng, 4)
        with np.errstate(all="ignore"):
            expect = np.broadcast_to(eval(numpy_text, {"np": np, "x": x}), (50,))
        if not np.all(np.isfinite(expect)):
            continue
        d = mlid.FlightData.from_frame(frame, "t", [], ["z"], derived={"z": text})
        assert np.allclose(d.y[:, 0], expect, rtol=1e-12, atol=1e-12), text
    powers = mlid.FlightData.from_frame(frame, "t", [], ["p", "q"],
                                        derived={"p": "-c^2^0.5", "q": "2^-1*c"})
    assert np.allclose(powers.y[:, 0], -(x["c"] ** (2 ** 0.5)))
    assert np.allclose(powers.y[:, 1], 0.5 * x["c"])


class _Frame:
    """What from_frame asks of a DataFrame (pandas is tested below)."""

    def __init__(self, cols):
        self.columns = list(cols)
        self._x = np.column_stack(list(cols.values()))

    def to_numpy(self, dtype=float):
        return self._x.astype(dtype)


@pytest.mark.parametrize("text, match", [
    ("(a +", r"'\(a \+' at character 5: a value is missing at the end"),
    ("a + foo", "at character 5: no channel named foo"),
    ("sqrtt(a)", "unknown function sqrtt"),
    ("min(a)", "min takes 2 arguments"),
    ("sin(a, b)", r"at character 6: sin takes 1 argument"),
    ("1.2.3", "'1.2.3' is not a number"),
    ("a b", "unexpected 'b'"),
    ("__import__('os').system('true')", "no channel named __import__|unknown function"),
    ("a; b", "unexpected ';'"),
    ("", "the expression is empty"),
    ("log(0)", "derived channel z is not finite"),
    ("a/0", "derived channel z is not finite"),
])
def test_expression_errors_are_one_clear_line(tmp_path, text, match):
    with pytest.raises(mlid.InputError, match=match):
        mlid.FlightData.load(_record(tmp_path), "t", [], ["z"], derived={"z": text})


def test_definitions_are_checked(tmp_path):
    path = _record(tmp_path)
    with pytest.raises(mlid.InputError, match="is not of the form NAME = "):
        mlid.FlightData.load(path, "t", [], ["a"], derived=["z (a)"])
    with pytest.raises(mlid.InputError, match="a channel named a exists already"):
        mlid.FlightData.load(path, "t", [], ["a"], derived=["a = 2*b"])
    with pytest.raises(mlid.InputError, match="'2x' in '2x = a' is not a name"):
        mlid.FlightData.load(path, "t", [], ["a"], derived=["2x = a"])


def test_time_window(tmp_path):
    t = np.arange(0, 10.001, 0.5)
    rows = np.column_stack([t, np.sin(t), np.cos(t)])
    path = _record(tmp_path, "t u y\n", rows)
    d = mlid.FlightData.load(path, "t", ["u"], ["y"], t_start=2.0, t_end=4.0)
    assert np.array_equal(d.t, t[(t >= 2) & (t <= 4)]) and np.array_equal(d.u[:, 0], np.sin(d.t))
    with pytest.raises(mlid.InputError, match=r"no samples between 20 s and 30 s \(the record "
                                              r"runs from 0 s to 10 s\)"):
        mlid.FlightData.load(path, "t", ["u"], ["y"], t_start=20, t_end=30)
    gap = np.delete(rows, [8, 9, 10], axis=0)
    path = _record(tmp_path, "t u y\n", gap, "gap.dat")
    mlid.FlightData.load(path, "t", ["u"], ["y"], t_end=3.9)     # the gap outside the window
    with pytest.raises(mlid.InputError, match=r"gap.dat line 10: a gap in time from 3.5 s to 5.5 s"):
        mlid.FlightData.load(path, "t", ["u"], ["y"])


SEGMENTS = """
&case title = 'two segments of one file', job = 'estimate' /
&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1.0, g = 1.0, h = 1,
    free = 'f(1,1)', 'g(1,1)', 'x0(1)' /
&data file = '{file}', '{file}', time_col = 'time', input_cols = 'de', output_cols = 'y',
    columns = 'time', 'de[deg]', 'y[deg]', t_start = 0, 5.5, t_end = 4.5, 10 /
"""


def test_segments_of_one_file_in_both_front_ends(tmp_path):
    """One file cut into two manoeuvres by windows, through mlid run and
    mlid-batch: the same bytes."""
    t = np.arange(0, 10.001, 0.05)
    u = np.where((t % 4) < 1, 2.0, -1.0)
    x = np.zeros_like(t)
    for k in range(1, t.size):          # x' = -2x + 1.5u, Euler on a fine grid is enough here
        x[k] = x[k - 1] + 0.05 * (-2 * x[k - 1] + 1.5 * u[k - 1])
    path = _record(tmp_path, "", np.column_stack([t, u, x]), "seg.dat")
    deck = tmp_path / "seg.nml"
    deck.write_text(SEGMENTS.format(file=path.name))
    case = mlid.read_deck(deck)[0]
    records = case.record()
    assert len(records) == 2 and records[0].t[-1] == 4.5 and records[1].t[0] == 5.5
    assert np.allclose(records[1].u[:, 0], u[t >= 5.5] * DEG)
    outs = {}
    for who in ("mlid", "mlid-batch"):
        cmd = [str(BIN / who)] + (["run"] if who == "mlid" else []) + [
            str(deck), "--json", str(tmp_path / f"{who}.json")]
        run = subprocess.run(cmd, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        outs[who] = (tmp_path / f"{who}.json").read_bytes()
    assert outs["mlid"] == outs["mlid-batch"]
    assert json.loads(outs["mlid"])[0]["status"] == 0


def _binary_records(tmp_path, x, names):
    """The same table as .mat v5, .mat v7.3 (HDF5 with MATLAB's 512-byte
    header, stored transposed) and HDF5 vectors with units."""
    import h5py
    import scipy.io
    scipy.io.savemat(tmp_path / "v5.mat", {"rec": x})
    with h5py.File(tmp_path / "v73.mat", "w", userblock_size=512) as f:
        f.create_dataset("rec", data=x.T)
    with open(tmp_path / "v73.mat", "r+b") as fh:
        fh.write(b"MATLAB 7.3 MAT-file".ljust(116))
    with h5py.File(tmp_path / "vec.h5", "w") as f:
        for k, n in enumerate(names):
            name, unit = (n.split("[") + [""])[:2]
            f.create_dataset(name, data=x[:, k]).attrs["units"] = unit.rstrip("]")
    return tmp_path / "v5.mat", tmp_path / "v73.mat", tmp_path / "vec.h5"


def test_binary_formats_and_dataframe_read_as_text(tmp_path):
    import pandas as pd
    x = ROWS[:, :4]
    names = ["t[s]", "a[deg]", "b[ft]", "c[kt]"]
    text = mlid.FlightData.load(_record(tmp_path, " ".join(names) + "\n", x), "t", ["a"],
                                ["b", "c"], derived={"s": "a + 1"})
    v5, v73, h5 = _binary_records(tmp_path, x, names)
    got = [mlid.FlightData.load(v5, "t", ["a"], ["b", "c"], columns=names),
           mlid.FlightData.load(v73, "t", ["a"], ["b", "c"], columns=names),
           mlid.FlightData.load(h5, "t", ["a"], ["b", "c"]),
           mlid.FlightData.from_frame(pd.DataFrame(x, columns=names), "t", ["a"], ["b", "c"])]
    for d in got:
        assert np.array_equal(d.t, text.t) and np.array_equal(d.u, text.u)
        assert np.array_equal(d.y, text.y)
        assert d.output_units == text.output_units == ["m", "m/s"]
        assert d.input_names == ["a"] and d.output_names == ["b", "c"]


def test_binary_format_problems(tmp_path):
    import scipy.io
    scipy.io.savemat(tmp_path / "two.mat", {"p": np.ones((4, 3)), "q": np.ones((5, 3))})
    with pytest.raises(mlid.InputError, match=r"several matrices \(p, q\); name one with "
                                              r"variable="):
        mlid.FlightData.load(tmp_path / "two.mat", 1, [2], [3])
    scipy.io.savemat(tmp_path / "two.mat", {"p": ROWS, "q": np.ones((5, 3))})
    d = mlid.FlightData.load(tmp_path / "two.mat", 1, [2], [3], variable="p")
    assert np.array_equal(d.t, ROWS[:, 0])
    with pytest.raises(mlid.InputError, match="no numeric variable 'r'"):
        mlid.FlightData.load(tmp_path / "two.mat", 1, [2], [3], variable="r")
    (tmp_path / "junk.mat").write_bytes(b"not a mat file at all" * 20)
    with pytest.raises(mlid.InputError, match="junk.mat: not a MATLAB file"):
        mlid.FlightData.load(tmp_path / "junk.mat", 1, [2], [3])
    with pytest.raises(mlid.InputError, match="none.h5: no such file"):
        mlid.FlightData.load(tmp_path / "none.h5", 1, [2], [3])
    scipy.io.savemat(tmp_path / "nan.mat", {"r": np.array([[0, 1, 2], [1, np.nan, 2.0]])})
    with pytest.raises(mlid.InputError, match=r"nan.mat row 2: column 2 is not finite"):
        mlid.FlightData.load(tmp_path / "nan.mat", 1, [2], [3])


def test_batch_reads_binary_files_as_mlid_run_does(tmp_path):
    import scipy.io
    scipy.io.savemat(tmp_path / "r.mat", {"r": ROWS[:, :3]})
    deck = tmp_path / "m.nml"
    deck.write_text(SEGMENTS.format(file="r.mat").replace(", '{file}'".format(file="r.mat"), "")
                    .replace("t_start = 0, 5.5, t_end = 4.5, 10", ""))
    runs = [subprocess.run([str(BIN / exe), *pre, str(deck)], capture_output=True, text=True)
            for exe, pre in (("mlid", ["run"]), ("mlid-batch", []))]
    assert runs[0].returncode == runs[1].returncode and runs[0].stdout == runs[1].stdout
    assert len(mlid.read_deck(deck)[0].record().t) == 3


@needs_data
def test_attas_text_and_mat_records_give_the_same_channels():
    """fAttasElv1_pqrDot.asc (text) and fAttasElv1.mat hold the same 45
    columns: read by name with units and a derived channel, they agree."""
    cols = ["T[s]", "AXCG", "AYCG", "AZCG", "AYCKP", "AZCKP", "PRGX[deg/s]", "QRGY[deg/s]",
            "RRGZ[deg/s]", "PHI[deg]", "THE[deg]", "PSI[deg]", "ALCG[deg]", "BECG[deg]",
            "VTASCG[m/s]", "HQNH[ft]", "PDOT", "QDOT", "RDOT", "HRADIO", "VCAS", "DELV[deg]",
            "IHTRM", "N1T1L", "N1T2R", "DLC_L", "DLC_R", "DAIL_L[deg]", "DAIL_R[deg]"]
    args = dict(time_col="T", input_cols=["de", "da"], output_cols=["ALCG", "QRGY", "HQNH"],
                columns=cols, derived={"de": "DELV", "da": "(DAIL_R - DAIL_L)/2"},
                t_start=3, t_end=20)
    text = mlid.FlightData.load(DATA / "fAttasElv1_pqrDot.asc", **args)
    mat = mlid.FlightData.load(DATA / "fAttasElv1.mat", **args)
    raw = np.loadtxt(DATA / "fAttasElv1_pqrDot.asc")
    keep = (raw[:, 0] >= 3) & (raw[:, 0] <= 20)
    assert text.nt == keep.sum() == 426
    assert np.allclose(text.u[:, 1], (raw[keep, 28] - raw[keep, 27]) / 2 * DEG, rtol=1e-14)
    assert np.allclose(text.y[:, 2], raw[keep, 15] * 0.3048, rtol=1e-14)
    assert np.allclose(text.u, mat.u, rtol=1e-12, atol=1e-14)
    assert np.allclose(text.y, mat.y, rtol=1e-12, atol=1e-14)
