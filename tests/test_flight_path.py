"""Flight-path reconstruction on three real ATTAS manoeuvres
(cases/flight_path, FVSysID test case 22): the deck against its reference
fit, in both front ends."""

import json
import subprocess

import pytest

from mlid.reference import read_reference
from conftest import BIN, REPO

DATA = REPO.parent / "shared" / "data"
HERE = REPO / "cases" / "flight_path"
REFS = {"tc22": "attas_fpr_tc22_fvsysid_octave.txt",
        "tc22b": "attas_fpr_tc22b_albe_fvsysid_octave.txt"}
needs_data = pytest.mark.skipif(not (DATA / "fAttasElv1_pqrDot.asc").is_file(),
                                reason="the ATTAS records are not in ../shared/data")


@needs_data
@pytest.mark.parametrize("deck", sorted(REFS))
def test_each_deck_reproduces_its_reference_in_both_front_ends(deck, tmp_path):
    """Within 0.1 sigma, sigma within 5%, det R within 1% (the issue's
    targets; measured in README.md)."""
    path = HERE / f"{deck}.nml"
    assert "! reference:" in path.read_text()
    runs = [subprocess.run([str(BIN / exe), *pre, str(path), "--json", str(tmp_path / f"{exe}.json")],
                           capture_output=True, text=True) for exe, pre in (("mlid", ["run"]),
                                                                           ("mlid-batch", []))]
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    py, fo = (json.loads((tmp_path / f"{exe}.json").read_text())[0]
              for exe in ("mlid", "mlid-batch"))
    assert py == fo
    ref = read_reference(DATA / "refs" / REFS[deck])
    assert sorted(py["parameters"]) == sorted(ref.estimates)
    for name, value, sigma in zip(py["parameters"], py["estimate"], py["sigma"]):
        assert abs(value - ref.estimates[name][0]) < 0.1 * ref.estimates[name][1], name
        assert abs(sigma / ref.estimates[name][1] - 1) < 0.05, name
    assert abs(py["det_R"] / ref.det_r - 1) < 0.01
