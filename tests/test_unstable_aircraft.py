"""The simulated unstable aircraft (cases/unstable_aircraft, FVSysID test cases
6 to 10): each deck against its reference fit, in both front ends; filter
error on test case 8's model against tc06 and tc07; the stabilized output
error's sensitivities against central differences."""

import numpy as np
import pytest

import mlid
from mlid.reference import read_reference
from conftest import REPO, assert_reproduces, both_front_ends_json

DATA = REPO.parent / "shared" / "data"
HERE = REPO / "cases" / "unstable_aircraft"
REFS = {"tc06": "unstab_ac_tc06_regstart_fvsysid_octave.txt",
        "tc07": "unstab_ac_tc07_eqdecoup_fvsysid_octave.txt",
        "tc08": "unstab_ac_tc08_oem_fvsysid_octave.txt",
        "tc09": "unstab_ac_tc09_stabilized_fvsysid_octave.txt",
        "tc10": "unstab_ac_tc10_eigtransf_fvsysid_octave.txt"}
needs_data = pytest.mark.skipif(not (DATA / "unStabAC_sim.asc").is_file(),
                                reason="the simulated record is not in ../shared/data")


@needs_data
@pytest.mark.parametrize("deck", sorted(REFS))
def test_each_deck_reproduces_its_reference_in_both_front_ends(deck, tmp_path):
    """Within 0.1 sigma, sigma within 5%, det R within 1% (measured: 0.018
    sigma, 0.2%, 1e-6 at worst); tc08 is the book's failure, reproduced as
    such (a stable model), and its deck names no reference; tc09 keeps the
    unstable model (M_w > 0) by its stabilizing gain."""
    path = HERE / f"{deck}.nml"
    assert ("! reference:" in path.read_text()) == (deck != "tc08")
    assert_reproduces(both_front_ends_json(path, tmp_path), read_reference(DATA / "refs" / REFS[deck]))
    if deck in ("tc08", "tc09"):           # tc08: the wrong, stable model of the book's example
        case = mlid.read_deck(path)[0]
        _, res = mlid.deck.run_case(case)
        assert np.all(np.linalg.eigvals(res.model.F).real < 0) == (deck == "tc08")


FE_DECK = HERE / "tc08_filter_error.nml"


@needs_data
def test_filter_error_keeps_the_unstable_plant_in_both_front_ends(tmp_path):
    """Filter error on tc08's model, data and start values (where output
    error settles on a stable model) converges to the unstable plant, the
    same in both front ends (report and JSON).  The tolerance: tc06 and
    tc07 disagree with each other by 153 sigma_tc07 and 1e5 sigma_tc06
    (Zde), since on a record this nearly noise-free their sigma measure the
    rounding of the file, not each formulation's model error; so neither
    reference's sigma can bound ours.  Ours is judged by its own Cramer-Rao
    sigma corrected for the innovations' colour (sigma_c): every derivative
    within 3 sigma_c of tc06 (measured: 2.7, Mq), the pitching-moment ones
    within 3 sigma_c of tc07 too (1.3), Zw and Zde (which the az equation
    pins, as in tc06's regression) within 0.1 sigma_tc06 of tc06 (0.003);
    and far from tc08's stable model (Mw: 54 sigma_tc08)."""
    fit = both_front_ends_json(FE_DECK, tmp_path)
    assert fit["converged"] and fit["status"] == 0
    est = dict(zip(fit["parameters"], fit["estimate"]))
    sig_c = dict(zip(fit["parameters"], fit["sigma_corrected"]))
    lam = np.sort(np.linalg.eigvals([[est["Zw"], 44.5695 - 1.4768], [est["Mw"], est["Mq"]]]).real)
    assert lam[1] > 0 > lam[0]
    ref = {d: read_reference(DATA / "refs" / REFS[d]).estimates for d in ("tc06", "tc07", "tc08")}
    for name in ("Zw", "Zde", "Mw", "Mq", "Mde"):
        assert abs(est[name] - ref["tc06"][name][0]) < 3 * sig_c[name], name
    for name in ("Mw", "Mq", "Mde"):
        assert abs(est[name] - ref["tc07"][name][0]) < 3 * sig_c[name], name
    for name in ("Zw", "Zde"):
        assert abs(est[name] - ref["tc06"][name][0]) < 0.1 * ref["tc06"][name][1], name
    assert est["Mw"] - ref["tc08"]["Mw"][0] > 10 * ref["tc08"]["Mw"][1]


@needs_data
def test_filter_error_without_the_floor_on_r_names_the_noise_free_outputs():
    """The deck's lower bounds on r are what gives the likelihood a maximum:
    without them (q >= 0 kept) r(1) and r(3) fall without end, the fit
    does not converge, and the message names them."""
    case = mlid.read_deck(FE_DECK)[0]
    opts = case.options()
    opts["bounds"] = {k: v for k, v in opts["bounds"].items() if k.startswith("q(")}
    res = mlid.fit(case.model, case.record(), **opts)
    assert not res.converged
    assert "r(1)" in res.message and "r(3)" in res.message and "no maximum" in res.message
    assert res.model.value("r(1)") < 1e-20 and res.model.value("r(3)") < 1e-20


F9 = [[-1.4268, 43.0927], [0.2170, -3.7201]]
G9 = [[-6.1711], [-12.8148]]
K9 = [[0.0, 0.05, 0.0], [0.0, 0.0, 0.0]]


@needs_data
@pytest.mark.parametrize("name", ["f(2,1)", "g(2,1)", "x0(1)", "bias(2)"])
def test_stabilized_sensitivities_against_central_differences(name):
    """x <- x + K (z - y) after each sample moves the sensitivities by
    -K dy: the core's against central differences of the outputs, on the
    record of tc09 with its gain (and a larger one)."""
    case = mlid.read_deck(HERE / "tc09.nml")[0]
    data = case.record()
    for gain in (K9, [[0.0, 0.3, 0.0], [0.0, 0.0, 0.2]]):
        m = mlid.LinearModel(F=F9, G=G9, H=[[-1.4268, -1.4768], [1, 0], [0, 1]],
                             D=[[-6.1711], [0], [0]], stab=gain, x0=[0.1, 0.0])
        ev = mlid.evaluate(m.with_free([name]), data)
        got = np.einsum("pq,qi->ip", ev["rhat"], ev["weighted_sensitivity"][:, :, 0])
        h = 1e-6
        k = m.element_names().index(name)
        ys = []
        for s in (1, -1):
            theta = m.theta.copy()
            theta[k] += s * h
            ys.append(mlid.evaluate(m.with_theta(theta), data)["yhat"])
        fd = (ys[0] - ys[1]) / (2 * h)
        assert np.max(np.abs(got - fd)) < 1e-6 * max(1.0, np.max(np.abs(fd))), (name, gain)


def test_the_stabilizing_gain_is_a_setting():
    m = mlid.LinearModel(F=F9, G=G9, H=np.eye(2), stab=np.eye(2) * 0.1)
    with pytest.raises(mlid.MlidError, match="stab, the gain of the stabilized output error, is "
                                             "a setting"):
        mlid.fit(m.with_free(["f(1,1)", "stab(1,1)"]), _tiny_record())
    with pytest.raises(mlid.MlidError, match="takes no output time delays"):
        mlid.fit(mlid.LinearModel(F=F9, G=G9, H=np.eye(2), stab=np.eye(2) * 0.1, delay=[0, 0.01],
                                  free=["f(1,1)"]), _tiny_record())
    with pytest.raises(mlid.MlidError, match="runs only against its measured outputs"):
        mlid.simulate(m, np.arange(10) * 0.05, np.zeros((10, 1)))
    with pytest.raises(mlid.InputError, match="the stabilizing gain feeds output 1 back"):
        mlid.reduce_measured_state(mlid.LinearModel(F=F9, G=G9, H=np.eye(2),
                                                    stab=[[0.0, 0.0], [0.1, 0.0]]), 1, 1)
    with pytest.raises(mlid.MlidError, match="is for output error; the filter has its own"):
        mlid.fit(mlid.LinearModel(F=F9, G=G9, H=np.eye(2), stab=np.eye(2) * 0.1,
                                  Gamma=[[1.0], [0.0]], q=[1e-3], r=[1e-4, 1e-4],
                                  free=["f(1,1)"]), _tiny_record(), method="filter_error")


def _tiny_record():
    t = np.arange(100) * 0.05
    u = np.sin(t)[:, None]
    y = np.column_stack([np.cos(t), np.sin(2 * t)]) * 0.1
    return mlid.FlightData(t, u, y)
