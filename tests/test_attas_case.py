"""cases/attas_channels: real ATTAS records fitted from their raw files
(named and derived channels, units converted, a window) in both front ends,
and FVSysID test case 11 reproduced from the two .mat records."""

import json
import subprocess

import numpy as np
import pytest

import mlid
from mlid.report.reference import read_reference
from conftest import BIN, REPO

DECK = REPO / "cases" / "attas_channels" / "attas_sp.nml"
DATA = REPO.parent / "shared" / "data"
REF = DATA / "refs" / "attas_sp_tc11_fvsysid_octave.txt"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason="real flight data not beside the checkout")
REF_NAMES = {"Z_alpha": "Zal", "1+Z_q": "Zq", "M_alpha": "Mal", "M_q": "Mq", "Z_de": "Zde",
             "Z_0": "Z0", "M_de": "Mde", "M_0": "M0"}


def test_text_and_mat_cases_are_the_same_in_both_front_ends(tmp_path):
    """The .mat cases too: mlid-batch reads .mat records in the core."""
    py = subprocess.run([str(BIN / "mlid"), "run", str(DECK), "--json", str(tmp_path / "p.json")],
                        capture_output=True, text=True)
    fo = subprocess.run([str(BIN / "mlid-batch"), str(DECK), "--json", str(tmp_path / "f.json")],
                        capture_output=True, text=True)
    assert py.returncode == 0, py.stderr
    assert fo.returncode == 0, fo.stderr
    p, f = (json.loads((tmp_path / n).read_text()) for n in ("p.json", "f.json"))
    assert p == f and p[0]["status"] == 0 and p[0]["converged"]
    assert py.stdout == fo.stdout


def test_test_case_11_matches_the_reference():
    """Estimates within 0.01 sigma of the reference, sigma within 0.1%, det R
    within 1e-6 relative (the reference's sensitivities are forward
    differences; ours analytic)."""
    case = mlid.read_deck(DECK)[1]
    records = case.record()
    assert [r.nt for r in records] == [626, 626]
    assert records[0].output_units == ["rad", "rad/s"]
    res = mlid.fit(case.model, records, **case.options())
    ref = read_reference(REF)
    det_r = ref.det_r
    for name, value, sigma in zip(res.names, res.estimate, res.sigma):
        ref_value, ref_sigma = ref.estimates[REF_NAMES[name]]
        ref_value += 1.0 if name == "1+Z_q" else 0.0
        assert abs(value - ref_value) < 0.01 * ref_sigma, name
        assert abs(sigma / ref_sigma - 1) < 1e-3, name
    assert abs(res.det_r / det_r - 1) < 1e-6


def test_elevator_2_is_predicted_by_the_fit_of_elevator_1():
    """The validate case: the prediction of the second manoeuvre is the
    deck's own (mlid.validate on the same records), close (Theil U below
    0.1) and worse than the fit's residuals (rms/sigma above 1), as a
    prediction of data not fitted is."""
    case = mlid.read_deck(DECK)[2]
    assert case.job == "validate" and case.holdout == [2]
    from mlid.cli.deck import run_case
    out, res = run_case(case)
    v = res.validation
    assert out["validation"]["theil"] == v.theil.tolist()
    assert np.all(v.theil < 0.1) and np.all(v.rms_over_sigma > 1.0)
    again = mlid.validate(res, case.record()[1], holdout=[2])
    np.testing.assert_array_equal(again.theil, v.theil)
