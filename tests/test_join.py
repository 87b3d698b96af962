"""join in &data (fortran/case/mlid_channels.f90): text files whose columns extend
the data files' rows, row for row, the rows of each side read one file after
another.  A joined fit equals the fit of the same columns in one file, however
the join files split the rows; a mismatch is one line in both front ends."""

import numpy as np

from conftest import both_front_ends_json, refused_by_both

MODEL = ("&case title = 'join', job = 'estimate' /\n"
         "&model kind = 'linear', nx = 1, nu = 1, ny = 1, f = -0.5, g = 0.5, h = 1,\n"
         "    free = 'f(1,1)', 'g(1,1)' /\n")


def _records():
    """Two manoeuvres of xdot = -x + u, y = x + noise: each file t, u, y."""
    rng = np.random.default_rng(4)
    out = []
    for n, w in ((70, 1.3), (90, 0.7)):
        t = np.arange(n) * 0.1
        u = np.sign(np.sin(w * t))
        x = np.zeros(n)
        for j in range(1, n):
            x[j] = x[j - 1] + 0.1 * (-x[j - 1] + u[j - 1])
        out.append(np.column_stack([t, u, x + 0.01 * rng.standard_normal(n)]))
    return out


def _deck(data):
    return MODEL + "&data " + data + ", time_col = 't', input_cols = 'u', output_cols = 'y' /\n"


def test_a_joined_fit_is_the_fit_of_one_file_however_the_rows_are_split(tmp_path):
    recs = _records()
    for k, r in enumerate(recs):
        np.savetxt(tmp_path / f"whole{k}.dat", r, header="t u y", comments="")
        np.savetxt(tmp_path / f"tu{k}.dat", r[:, :2], header="t u", comments="")
        np.savetxt(tmp_path / f"y{k}.dat", r[:, 2:])
    np.savetxt(tmp_path / "y_all.dat", np.vstack([r[:, 2:] for r in recs]),
               header="two manoeuvres one after another", comments="# ")
    np.savetxt(tmp_path / "y_a.dat", np.vstack([r[:, 2:] for r in recs])[:100])
    np.savetxt(tmp_path / "y_b.dat", np.vstack([r[:, 2:] for r in recs])[100:])
    decks = {"whole": "file = 'whole0.dat', 'whole1.dat'",
             "per_file": "file = 'tu0.dat', 'tu1.dat', join = 'y0.dat', 'y1.dat', "
                         "join_columns = 'y'",
             "one_for_all": "file = 'tu0.dat', 'tu1.dat', join = 'y_all.dat', join_columns = 'y'",
             "any_split": "file = 'tu0.dat', 'tu1.dat', join = 'y_a.dat', 'y_b.dat', "
                          "join_columns = 'y'"}
    fits = {}
    for name, data in decks.items():
        (tmp_path / f"{name}.nml").write_text(_deck(data))
        fits[name] = both_front_ends_json(tmp_path / f"{name}.nml", tmp_path)
    for name in decks:
        assert fits[name]["estimate"] == fits["whole"]["estimate"], name
        assert fits[name]["sigma"] == fits["whole"]["sigma"], name
    assert abs(fits["whole"]["estimate"][0] + 1) < 0.05     # f = -1 recovered, not vacuous


def test_join_mismatches_are_one_line_in_both_front_ends(tmp_path):
    recs = _records()
    for k, r in enumerate(recs):
        np.savetxt(tmp_path / f"tu{k}.dat", r[:, :2], header="t u", comments="")
    y = np.vstack([r[:, 2:] for r in recs])
    np.savetxt(tmp_path / "short.dat", y[:-1])
    np.savetxt(tmp_path / "wide.dat", np.column_stack([y[:80], y[:80]]))
    np.savetxt(tmp_path / "narrow.dat", y[80:])
    files = "file = 'tu0.dat', 'tu1.dat', "
    cases = {
        files + "join = 'short.dat', join_columns = 'y'":
            "the join files have 159 rows, the data files 160",
        files + "join_columns = 'y'":
            "join_columns names the columns of join files, and join lists none",
        files + "join = 'wide.dat', 'narrow.dat', join_columns = 'y'":
            "narrow.dat: 1 columns, the first join file has 2",
        files + "join = 'short.dat', join_columns = 'y', 'z'":
            "2 join_columns named, the file has 1",
        files + "join = 'missing.dat', join_columns = 'y'": "missing.dat",
    }
    for data, message in cases.items():
        (tmp_path / "bad.nml").write_text(_deck(data))
        refused_by_both(tmp_path / "bad.nml", message, cwd=tmp_path)
