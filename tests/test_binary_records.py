"""The core's reader of binary flight records (fortran/case/mlid_tablefile.f90:
MATLAB v5 by mlid_matfile, HDF5 and v7.3 by mlid_hdf5file, the table rule
of mlid_named_arrays) against the Python front end's (tests/binary_reference.py,
scipy.io and h5py): the same table, bit for bit, with the same names and
units, for the real ATTAS records and for files written here; damaged
files refused with one line, no crash and no hang; and mlid-batch, which
now reads them, giving the bytes `mlid run` gives.

The core's table is read through tests/fortran/table_dump, built beside the
checkout by `make install` (build/)."""

import json
import subprocess

import numpy as np
import pytest

from conftest import BIN, REPO, run_both
import binary_reference as formats
from mlid.errors import InputError

DATA = REPO.parent / "shared" / "data"
RECORDS = ["fAttasElv1.mat", "fAttasElv2.mat", "fAttasAil1.mat", "fAttasRud1.mat",
           "fAttasAilRud2.mat"]
DUMP = REPO / "build" / "tests" / "fortran" / "table_dump"
#: The case decks that read .mat records.
MAT_DECKS = ["attas_channels/attas_sp.nml", "attas_lateral/attas_lat.nml",
             "frequency_domain/attas_lat_frequency.nml"]
needs_data = pytest.mark.skipif(not DATA.is_dir(),
                                reason="real flight data not beside the checkout")
pytestmark = pytest.mark.skipif(not (REPO / "fortran").is_dir(),
                                reason="no source tree (and build) beside the tests")

DECK = """
&case title = 'binary record', job = 'estimate' /
&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -1.0, g = 1.0, h = 1,
    free = 'f(1,1)', 'g(1,1)' /
&data file = '{file}', time_col = '1', input_cols = '2', output_cols = '3' /
"""


class CoreError(Exception):
    pass


def core(path, variable=None, tmp=None):
    """The core's table of path: x, names, units; CoreError(message) when it
    refuses the file."""
    if not DUMP.is_file():
        pytest.fail(f"{DUMP} is missing: `make install` builds it")
    out = (tmp or path.parent) / "table.bin"
    run = subprocess.run([str(DUMP), str(path), str(out)] + ([variable] if variable else []),
                         capture_output=True, text=True, errors="replace", timeout=60)
    assert run.returncode == 0, f"table_dump crashed on {path}: {run.stderr[-500:]}"
    lines = run.stdout.split("\n")
    if lines[0] != "status 0":
        assert lines[0] == "status 1" and lines[1], run.stdout
        raise CoreError(lines[1])
    nrow, ncol = map(int, lines[2].split())
    cols = [line.split("\t") for line in lines[3:3 + ncol]]
    x = np.fromfile(out, dtype="<f8").reshape((ncol, nrow)).T
    return x, [c[0] for c in cols], [c[1] for c in cols]


def same_bits(a, b):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and np.array_equal(a.view(np.int64), b.view(np.int64))


def agree(path, variable=None, same_words=True):
    """The core and formats.read_table give the same table, or both refuse
    the file (with the same words after the path, unless same_words is
    false: a damaged file, which scipy and h5py describe in their words)."""
    try:
        want = formats.read_table(path, variable)
    except InputError as exc:
        with pytest.raises(CoreError) as got:
            core(path, variable)
        if same_words:
            assert str(got.value).split(": ", 1)[1] == str(exc).split(": ", 1)[1]
        return None
    x, names, units = core(path, variable)
    assert same_bits(x, want[0]), path.name
    assert names == list(want[1]) and units == list(want[2]), (names, want[1], units, want[2])
    return x, names, units


def one_line(message, path):
    """message is one line that names path as the core names it (its last
    60 characters)."""
    p = str(path)
    p = p if len(p) <= 60 else "..." + p[-57:]
    return message.startswith(f"data file {p}: ") and "\n" not in message


# -- the real records ----------------------------------------------------------

@needs_data
@pytest.mark.parametrize("name", RECORDS)
def test_real_records_give_scipys_table(tmp_path, name):
    """Each is a v5 MAT-file (MATLAB 5.0, uncompressed: scipy's version (1, 0))
    holding one 2-D double matrix: the core's table is that matrix, bit for
    bit, as formats.read_table's is; a v7.3 record is held against h5py."""
    import scipy.io
    path = DATA / name
    version = scipy.io.matlab.matfile_version(str(path))
    x, names, units = core(path, tmp=tmp_path)
    if version[0] == 1:
        arrays = {k: v for k, v in scipy.io.loadmat(str(path)).items() if not k.startswith("__")}
        assert len(arrays) == 1
        ref = next(iter(arrays.values()))
    else:
        import h5py
        with h5py.File(path, "r") as f:
            ref = [f[k][()] for k in f if not k.startswith("#")][0].T
    assert same_bits(x, ref) and x.shape[0] > 600 and x.shape[1] == 45
    want = formats.read_table(path)
    assert same_bits(x, want[0]) and names == want[1] and units == want[2] == [""] * 45


# -- files written here --------------------------------------------------------

def _vectors(rng, n=50):
    return {"t": np.arange(n) * 0.1, "zeta": rng.normal(size=n),
            "a": rng.normal(size=(n, 1)).astype(np.float32),
            "i8": np.arange(-25, n - 25, dtype=np.int8), "u8": np.arange(n, dtype=np.uint8),
            "i16": np.arange(n, dtype=np.int16) * -300, "u16": np.arange(n, dtype=np.uint16) * 1000,
            "i32": np.arange(n, dtype=np.int32) * -10**8,
            "u32": np.arange(n, dtype=np.uint32) * 8 * 10**7,
            "i64": (np.arange(n, dtype=np.int64) - 25) * (2**62 // 25 + 12345),
            "u64": np.arange(n, dtype=np.uint64) * np.uint64(2**64 // n - 777),
            "logical": rng.normal(size=n) > 0, "special": np.r_[np.nan, np.inf, -np.inf, -0.0,
                                                                 5e-324, rng.normal(size=n - 5)],
            # not channels: text, cell, struct, complex, a scalar, empty, 3-D
            "txt": "hello", "cell": np.array([[1, "a"]], dtype=object), "s": {"f": np.ones(n)},
            "cplx": np.ones(n) * (1 + 2j), "scal": 3.0, "empty": np.zeros((0, n)),
            "three": np.ones((2, 2, 2))}


@pytest.mark.parametrize("compressed", [False, True])
def test_mat_v5_files_give_read_tables_table(tmp_path, compressed):
    import scipy.io
    rng = np.random.default_rng(3)
    x = rng.normal(size=(60, 5))
    files = {"matrix": {"rec": x, "note": "a matrix and text"},
             "vectors": _vectors(rng),
             "ints": {"m": (x * 1000).astype(np.int32)},
             "single": {"m": x.astype(np.float32)},
             "uint16_matrix": {"m": (np.abs(x) * 1000).astype(np.uint16)},
             "matrix_and_vectors": {"m": x, "v": np.ones(60), "w": np.ones(60)},
             "two": {"p": np.ones((4, 3)), "q": np.ones((5, 3))},
             "lengths": {"a": np.ones(5), "b": np.ones(6)},
             "nothing": {"s": "text only", "c": np.ones(4) * 1j}}
    for name, content in files.items():
        path = tmp_path / f"{name}.mat"
        scipy.io.savemat(path, content, do_compression=compressed)
        got = agree(path)
        assert (got is None) == (name in ("two", "lengths", "nothing")), name
    vectors = agree(tmp_path / "vectors.mat")
    assert vectors[1] == ["t", "zeta", "a", "i8", "u8", "i16", "u16", "i32", "u32", "i64", "u64",
                          "logical", "special"]
    for variable in ("p", "q", "r"):
        agree(tmp_path / "two.mat", variable)
    agree(tmp_path / "vectors.mat", "txt")                  # not numeric: refused
    agree(tmp_path / "vectors.mat", "u64")


def test_big_endian_and_small_elements_as_scipy_reads_them(tmp_path):
    """The files tests/fortran/test_matfile writes byte by byte (little- and
    big-endian, compressed; a small data element, a cell, a complex array,
    a char array): formats.read_table (scipy) reads each as the core does."""
    run = subprocess.run([str(DUMP.parent / "test_matfile")], capture_output=True, text=True,
                         timeout=120, cwd=tmp_path)
    assert run.returncode == 0, run.stdout[-2000:]
    for name in ("ale", "abe", "ac", "ble", "bbe", "bc"):
        got = agree(tmp_path / f"test_matfile_{name}.mat")
        assert got[0].shape == ((3, 2) if name[0] == "a" else (4, 3))


def test_hdf5_files_give_read_tables_table(tmp_path):
    import h5py
    rng = np.random.default_rng(4)
    x = rng.normal(size=(40, 4))
    with h5py.File(tmp_path / "columns.h5", "w") as f:
        f.create_dataset("rec", data=x).attrs["columns"] = ["t[s]", "a [deg] ", " b[m/s]]", "c"]
        f.create_dataset("#refs#/r", data=np.ones((3, 3)))
    with h5py.File(tmp_path / "bytes.hdf5", "w") as f:
        f.create_dataset("rec", data=x.astype(np.float32)).attrs.create(
            "columns", np.array([b"t[s]", b"a[deg]", b"b", b"c"], dtype="S8"))
    with h5py.File(tmp_path / "vectors.h5", "w") as f:
        for n in ["zz", "b", "Aa", "a", "_x", "#hidden", "g/c", "g/a", "h/#k"]:
            f.create_dataset(n, data=rng.normal(size=30)).attrs["units"] = "deg"
        f["b"].attrs["units"] = np.bytes_(b"m/s")
        del f["a"].attrs["units"]
        f["a"].attrs["unit"] = "ft"
        f["zz"].attrs["unit"] = "ignored: units comes first"
        f.create_dataset("ints", data=np.arange(30, dtype=np.int64) * -(2**58 + 1))
        f.create_dataset("u", data=np.arange(30, dtype=np.uint64) * np.uint64(2**59 + 3))
        f.create_dataset("str", data="hello")
        f.create_dataset("flags", data=np.ones(30, bool))
        f.create_dataset("scalar", data=1.0)
        f.create_dataset("cube", data=np.ones((2, 3, 5)))
    with h5py.File(tmp_path / "dense.h5", "w") as f:    # more links than a compact group holds
        for k in rng.permutation(40):
            f.create_dataset(f"v{k:02d}", data=rng.normal(size=10))
    with h5py.File(tmp_path / "two.h5", "w") as f:
        f["p"], f["q"] = np.ones((4, 3)), np.ones((3, 5))
    with h5py.File(tmp_path / "wrong_columns.h5", "w") as f:
        f.create_dataset("rec", data=x).attrs["columns"] = ["t", "a"]
    for name in ("columns.h5", "bytes.hdf5", "vectors.h5", "dense.h5", "two.h5",
                 "wrong_columns.h5"):
        agree(tmp_path / name)
    assert agree(tmp_path / "columns.h5")[1:] == (["t", "a", "b", "c"], ["s", "deg]", "m/s", ""])
    got = agree(tmp_path / "vectors.h5")
    assert got[1] == ["Aa", "_x", "a", "b", "g/a", "g/c", "h/#k", "ints", "u", "zz"]
    assert got[2] == ["deg", "deg", "ft", "m/s", "deg", "deg", "deg", "", "", "deg"]
    assert agree(tmp_path / "dense.h5")[1] == [f"v{k:02d}" for k in range(40)]
    agree(tmp_path / "two.h5", "q")


def test_v73_mat_files_are_transposed_back(tmp_path):
    """A v7.3 .mat: HDF5 after a 512-byte header, MATLAB's matrix stored
    transposed; vectors as 1 x n."""
    import h5py
    x = np.random.default_rng(5).normal(size=(30, 3))
    for name, write in (("matrix", lambda f: f.create_dataset("rec", data=x.T)),
                        ("vectors", lambda f: [f.create_dataset(k, data=x[:, j][None, :])
                                               for j, k in enumerate("tuy")])):
        path = tmp_path / f"{name}.mat"
        with h5py.File(path, "w", userblock_size=512) as f:
            write(f)
        with open(path, "r+b") as fh:
            fh.write(b"MATLAB 7.3 MAT-file".ljust(116) + b"\0" * 8 + b"\x00\x02IM")
        got = agree(path)
        assert same_bits(got[0], x)
    assert got[1] == ["t", "u", "y"]


def test_threads_reading_at_once_get_one_threads_tables(tmp_path):
    import h5py
    import scipy.io
    rng = np.random.default_rng(6)
    scipy.io.savemat(tmp_path / "a.mat", {"m": rng.normal(size=(200, 6))}, do_compression=True)
    scipy.io.savemat(tmp_path / "b.mat", _vectors(rng))
    with h5py.File(tmp_path / "c.h5", "w") as f:
        for k in range(12):
            f.create_dataset(f"g{k % 3}/v{k}", data=rng.normal(size=100)).attrs["units"] = "m"
    run = subprocess.run([str(DUMP), "--threads"] + [str(tmp_path / n) for n in
                                                     ("a.mat", "b.mat", "c.h5")],
                         capture_output=True, text=True, timeout=120,
                         env={"OMP_NUM_THREADS": "4"})
    assert run.returncode == 0 and run.stdout.strip() == "threads: 0 differ", run


# -- damaged files -------------------------------------------------------------

def _small_files(tmp_path):
    import h5py
    import scipy.io
    rng = np.random.default_rng(7)
    content = {"t": np.arange(20) * 0.1, "u": rng.normal(size=20).astype(np.float32),
               "y": np.arange(20, dtype=np.int16), "txt": "note"}
    scipy.io.savemat(tmp_path / "plain.mat", content)
    scipy.io.savemat(tmp_path / "packed.mat", content, do_compression=True)
    with h5py.File(tmp_path / "small.h5", "w") as f:
        for k in ("t", "u", "y"):
            f[k] = content[k]
    return [(tmp_path / n).read_bytes() for n in ("plain.mat", "packed.mat", "small.h5")]


def test_cut_files_refused_with_one_line_as_read_table_refuses_them(tmp_path):
    """Every 7th length of small v5 files (plain and compressed) and several
    of an HDF5 file: the core refuses each cut that formats.read_table
    refuses, in one line naming the file, and reads the others (a cut
    between two elements is a shorter file) as read_table reads them."""
    plain, packed, h5 = _small_files(tmp_path)
    refused = 0
    for data, name, step in ((plain, "cut.mat", 7), (packed, "cut.mat", 7), (h5, "cut.h5", 97)):
        for n in range(0, len(data), step):
            path = tmp_path / name
            path.write_bytes(data[:n])
            try:
                core(path)
            except CoreError as exc:
                refused += 1
                assert one_line(str(exc), path), str(exc)
            agree(path, same_words=False)
    assert refused > 100


def _damaged(tmp_path):
    """name -> (bytes, words of the message)."""
    plain, packed, h5 = _small_files(tmp_path)
    garbage = b"GARBAGE!" * 16 + plain[128:]
    longer = bytearray(plain)                 # the first element claims 8 bytes beyond the file
    longer[132:136] = (int.from_bytes(plain[132:136], "little") + len(plain)).to_bytes(4, "little")
    part = bytearray(plain)                    # its real part longer than its matrix
    p = 128 + 8 + 16 + 16 + 8                  # tag, flags, dims (2), name 't' (small)
    part[p + 4:p + 8] = (int.from_bytes(plain[p + 4:p + 8], "little") + 64).to_bytes(4, "little")
    zlib = bytearray(packed)
    zlib[150:160] = bytes(b ^ 0xFF for b in zlib[150:160])
    return {"garbage.mat": (garbage, "not a MATLAB file"),
            "longer.mat": (bytes(longer), "truncated at byte"),
            "part.mat": (bytes(part), "real part at byte"),
            "zlib.mat": (bytes(zlib), "zlib"),
            "cut.h5": (h5[:len(h5) // 2], "cannot be opened as HDF5"),
            "text.h5": (b"t u y\n0 1 2\n", "not an HDF5 file")}


def test_damaged_files_refused_with_one_line(tmp_path):
    """Each refused by the core, and by formats.read_table but for
    longer.mat, whose first variable scipy reads and then stops at the end
    of the file, leaving the others out without a word."""
    for name, (data, words) in _damaged(tmp_path).items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(CoreError) as got:
            core(path)
        assert one_line(str(got.value), path) and words in str(got.value), str(got.value)
        if name != "longer.mat":
            with pytest.raises(InputError):
                formats.read_table(path)


def test_damaged_files_through_mlid_batch_fail_the_case_no_crash_no_hang(tmp_path):
    """A deck that names each damaged or cut file: mlid-batch ends within the
    timeout with status 1 (a failed case, not a signal) and one line that
    names the file."""
    files = _damaged(tmp_path)
    plain = _small_files(tmp_path)[0]
    files.update({f"cut{n}.mat": (plain[:n], "") for n in range(0, len(plain), 23)})
    for name, (data, words) in files.items():
        (tmp_path / name).write_bytes(data)
        deck = tmp_path / "bad.nml"
        deck.write_text(DECK.format(file=name))
        run = subprocess.run([str(BIN / "mlid-batch"), str(deck)], capture_output=True,
                             text=True, errors="replace", timeout=60, cwd=tmp_path)
        assert run.returncode == 1, (name, run.returncode, run.stderr[-300:])
        lines = [line for line in run.stderr.splitlines()
                 if "data file " in line and f"{name}: " in line]
        assert len(lines) == 1 and words in lines[0], (name, run.stderr)


# -- both front ends -----------------------------------------------------------

def test_batch_and_run_read_binary_records_alike(tmp_path):
    """Synthetic records (v5 compressed, HDF5 vectors with units, v7.3)
    through `mlid run` (formats.py) and mlid-batch (the core): one report,
    one JSON."""
    import h5py
    import scipy.io
    t = np.arange(0, 8.001, 0.05)
    u = np.where((t % 4) < 1, 2.0, -1.0)
    y = np.zeros_like(t)
    for k in range(1, t.size):
        y[k] = y[k - 1] + 0.05 * (-2 * y[k - 1] + 1.5 * u[k - 1])
    y += np.random.default_rng(8).normal(scale=0.01, size=t.size)
    x = np.column_stack([t, u, y])
    scipy.io.savemat(tmp_path / "v5.mat", {"rec": x}, do_compression=True)
    with h5py.File(tmp_path / "vec.h5", "w") as f:
        for k, n in enumerate("tuy"):
            f.create_dataset(n, data=x[:, k]).attrs["units"] = ["s", "deg", "deg"][k]
    with h5py.File(tmp_path / "v73.mat", "w", userblock_size=512) as f:
        f.create_dataset("rec", data=x.T)
    for name in ("v5.mat", "vec.h5", "v73.mat"):
        deck = tmp_path / f"{name}.nml"
        deck.write_text(DECK.format(file=name))
        runs = run_both(deck, "--json", str(tmp_path / f"{name}.{{exe}}.json"), cwd=tmp_path)
        assert runs[0].returncode == runs[1].returncode == 0, (runs[0].stderr, runs[1].stderr)
        assert runs[0].stdout == runs[1].stdout
        py, fo = ((tmp_path / f"{name}.{e}.json").read_bytes() for e in ("mlid", "mlid-batch"))
        assert py == fo and json.loads(py)[0]["status"] == 0


@needs_data
@pytest.mark.parametrize("deck", MAT_DECKS)
def test_case_decks_on_mat_records_give_the_same_bytes(tmp_path, deck):
    deck = REPO / "cases" / deck
    runs = run_both(deck.name, "--json", str(tmp_path / "{exe}.json"), cwd=deck.parent)
    assert runs[0].returncode == runs[1].returncode == 0, (runs[0].stderr, runs[1].stderr)
    assert runs[0].stdout == runs[1].stdout and runs[0].stderr == runs[1].stderr
    assert (tmp_path / "mlid.json").read_bytes() == (tmp_path / "mlid-batch.json").read_bytes()
