"""mlid.report.reference: the textbook software's reference files read in one place,
and a fit compared with one."""


import numpy as np
import pytest

import mlid
from mlid.report.reference import compare, read_reference

TEXT = """# a model
# Result: converged after 5 Gauss-Newton iterations; det(R) = 1.5e-10
#   diag(R) (residual variances, output order above): 1e-3 2e-4
# Octave wall time: 2.5 s for ml_oem2
# name  estimate  crb_std
a  -1.0  0.1
b   2.0  0.5
"""


class Fit:
    names, param_units = ["a", "1+b"], ["1/s", "-"]
    estimate, sigma, det_r = np.array([-0.95, 3.1]), np.array([0.11, 0.5]), 1.5e-10


def test_read_and_compare(tmp_path):
    (tmp_path / "r.txt").write_text(TEXT)
    ref = read_reference(tmp_path / "r.txt")
    assert ref.estimates == {"a": (-1.0, 0.1), "b": (2.0, 0.5)}
    assert ref.det_r == 1.5e-10 and ref.seconds == 2.5 and list(ref.diag_r) == [1e-3, 2e-4]
    out = compare(Fit(), ref, names={"1+b": "b"}, shift={"1+b": 1.0})
    (_, unit, ours, theirs, z, ratio), (_, _, _, theirs_b, z_b, _) = out["rows"]
    assert unit == "1/s" and z == pytest.approx(0.5) and ratio == pytest.approx(1.1)
    assert theirs_b == 3.0 and z_b == pytest.approx(0.2)
    assert "largest |difference| 0.5 sigma" in out["lines"][-1]


def test_bad_files_are_one_line(tmp_path):
    with pytest.raises(mlid.InputError, match="reference .*missing.txt"):
        read_reference(tmp_path / "missing.txt")
    (tmp_path / "bad.txt").write_text("# x\na 1.0\n")
    with pytest.raises(mlid.InputError, match="line 2: expected 'name value sigma'"):
        read_reference(tmp_path / "bad.txt")
    (tmp_path / "r.txt").write_text(TEXT)
    with pytest.raises(mlid.InputError, match="has no value for c"):
        compare(type("F", (Fit,), {"names": ["c", "a"]})(), read_reference(tmp_path / "r.txt"))
