"""ATTAS aerodynamic coefficients by regression (cases/aero_coefficients,
FVSysID test case 23): an equations model without states against the
reference fit."""

import sys

import numpy as np
import pytest

import mlid
from mlid.reference import read_reference
from conftest import REPO

CASE = REPO / "cases" / "aero_coefficients"
sys.path.insert(0, str(CASE))
import tc23  # noqa: E402

needs_data = pytest.mark.skipif(not tc23.REF.is_file() or not tc23.COEFFS.is_file(),
                                reason="the reference or its derived file is not in ../shared/data")


@needs_data
def test_regression_reproduces_the_reference():
    """Within 0.1 sigma, sigma within 5%, det R within 1% (the issue's
    targets; measured 1.4e-7 sigma, 1e-6, 3.5e-8)."""
    ref = read_reference(tc23.REF)
    res = mlid.fit(tc23.model(), tc23.record(), noise="diagonal", max_iter=50)
    assert res.converged and res.model.nx == 0
    for name, value, sigma in zip(res.names, res.estimate, res.sigma):
        assert abs(value - ref.estimates[name][0]) < 0.1 * ref.estimates[name][1], name
        assert abs(sigma / ref.estimates[name][1] - 1) < 0.05, name
    assert abs(np.linalg.det(res.rhat) / ref.det_r - 1) < 0.01
