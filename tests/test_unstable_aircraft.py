"""The simulated unstable aircraft (cases/unstable_aircraft, FVSysID test cases
6, 7, 8): each deck against its reference fit, in both front ends."""

import numpy as np
import pytest

import mlid
from mlid.reference import read_reference
from conftest import REPO, assert_reproduces, both_front_ends_json

DATA = REPO.parent / "shared" / "data"
HERE = REPO / "cases" / "unstable_aircraft"
REFS = {"tc06": "unstab_ac_tc06_regstart_fvsysid_octave.txt",
        "tc07": "unstab_ac_tc07_eqdecoup_fvsysid_octave.txt",
        "tc08": "unstab_ac_tc08_oem_fvsysid_octave.txt"}
needs_data = pytest.mark.skipif(not (DATA / "unStabAC_sim.asc").is_file(),
                                reason="the simulated record is not in ../shared/data")


@needs_data
@pytest.mark.parametrize("deck", sorted(REFS))
def test_each_deck_reproduces_its_reference_in_both_front_ends(deck, tmp_path):
    """Within 0.1 sigma, sigma within 5%, det R within 1% (measured: 0.018
    sigma, 0.2%, 1e-6 at worst); tc08 is the book's failure, reproduced as
    such (a stable model), and its deck names no reference."""
    path = HERE / f"{deck}.nml"
    assert ("! reference:" in path.read_text()) == (deck != "tc08")
    assert_reproduces(both_front_ends_json(path, tmp_path), read_reference(DATA / "refs" / REFS[deck]))
    if deck == "tc08":                     # the wrong, stable model of the book's example
        case = mlid.read_deck(path)[0]
        _, res = mlid.deck.run_case(case)
        assert np.all(np.linalg.eigvals(res.model.F).real < 0)
