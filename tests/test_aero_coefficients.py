"""ATTAS aerodynamic coefficients by regression (cases/aero_coefficients,
FVSysID test cases 23, 24, 27): equations models without states against the
reference fits, from Python and from each case's deck (the records joined to
the reference's derived file) in both front ends."""

import sys

import numpy as np
import pytest

import mlid
from conftest import REPO, assert_reproduces, both_front_ends_json

sys.path.insert(0, str(REPO / "cases" / "aero_coefficients"))
import aero_coefficients as aero  # noqa: E402

needs_data = pytest.mark.skipif(not (aero.REFS / "derived").is_dir(),
                                reason="the references are not in ../shared/data")


@needs_data
@pytest.mark.parametrize("case", sorted(aero.CASES))
def test_regression_reproduces_the_reference(case):
    """Within 0.1 sigma, sigma within 5%, det R within 1% (the issue's
    targets; measured in README.md)."""
    res = mlid.fit(aero.model(case), aero.record(case), noise="diagonal", max_iter=50)
    assert res.converged and res.model.nx == 0
    assert_reproduces(res.as_dict(), aero.reference(case))

@needs_data
@pytest.mark.parametrize("case", sorted(aero.CASES))
def test_each_deck_reproduces_the_reference_and_the_script_in_both_front_ends(case, tmp_path):
    """The deck joins the records to the derived file row for row; its fit is
    the script's (which stacks the same columns itself) to rounding."""
    path = REPO / "cases" / "aero_coefficients" / f"{case}.nml"
    assert "! reference:" in path.read_text()
    fit = both_front_ends_json(path, tmp_path)
    assert_reproduces(fit, aero.reference(case))
    res = mlid.fit(aero.model(case), aero.record(case), noise="diagonal", max_iter=50)
    ours = dict(zip(fit["parameters"], zip(fit["estimate"], fit["sigma"])))
    for name, value, sigma in zip(res.names, res.estimate, res.sigma):
        assert abs(ours[name][0] - value) < 1e-6 * sigma, name
        assert abs(ours[name][1] / sigma - 1) < 1e-6, name
