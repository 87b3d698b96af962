"""Units of the parameters (fortran/models/mlid_param_units.f90) from the channels'
units, in the report and JSON of both front ends."""

import json
import subprocess
from pathlib import Path

import numpy as np

import mlid
from conftest import BIN

REPO = Path(__file__).resolve().parents[1]


def linear(**kw):
    return mlid.LinearModel(F=[[-0.5, 1.0], [-5.0, -2.0]], G=[[0.6], [-7.0]], H=np.eye(2),
                            **kw)


def units_of(model, inputs, outputs):
    return dict(zip(model.element_names(), model.param_units(inputs, outputs)))


def test_linear_model_units_follow_the_states_the_outputs_show():
    u = units_of(linear(), ["rad"], ["rad", "rad/s"])
    assert (u["f(1,1)"], u["f(1,2)"], u["f(2,1)"], u["f(2,2)"]) == ("1/s", "-", "1/s2", "1/s")
    assert (u["g(1,1)"], u["g(2,1)"]) == ("1/s", "1/s2")
    assert (u["x0(1)"], u["x0(2)"], u["bias(2)"]) == ("rad", "rad/s", "rad/s")
    assert (u["r(1)"], u["r(2)"]) == ("rad2", "rad2/s2")


def test_unknown_channel_units_give_unknown_parameter_units():
    u = units_of(linear(), [""], ["rad", ""])
    assert u["f(1,1)"] == "1/s" and u["f(1,2)"] == "" and u["g(1,1)"] == ""
    assert u["x0(2)"] == "" and u["r(2)"] == ""


def test_a_state_no_output_selects_alone_has_no_unit():
    m = mlid.LinearModel(F=-np.eye(2), G=np.ones((2, 1)), H=[[1.0, 1.0], [0.0, 2.0]])
    u = units_of(m, ["rad"], ["rad", "rad/s"])
    assert u["f(1,1)"] == "" and u["f(2,2)"] == "" and u["x0(1)"] == ""


def test_mixed_units_and_compound_denominators():
    m = mlid.LinearModel(F=-np.eye(2), G=np.ones((2, 1)), H=np.eye(2))
    u = units_of(m, ["N"], ["m/s", "rad"])
    assert u["f(1,2)"] == "m/(rad.s2)" and u["f(2,1)"] == "rad/m" and u["g(1,1)"] == "m/(N.s2)"


def test_longitudinal_coefficients_per_radian_of_their_regressor():
    case = mlid.read_deck(REPO / "cases" / "hfb320" / "hfb320.nml")[0]
    u = case.model.param_units(["rad", "N"], ["m/s", "rad", "rad", "rad/s", "rad/s2", "m/s2",
                                             "m/s2"])
    labels = [case.model.names.get(e, e) for e in case.model.element_names()]
    got = dict(zip(labels, u))
    assert (got["C_D0"], got["C_DV"], got["C_Dalpha"], got["C_mq"], got["C_mde"]) == \
        ("-", "-", "1/rad", "1/rad", "1/rad")
    assert got["x0(1)"] == "m/s" and got["x0(4)"] == "rad/s" and got["bias(7)"] == "m/s2"


def test_the_fit_carries_units_for_every_manoeuvre(tmp_path):
    truth = linear()
    t = np.arange(0, 6, 0.05)
    u = np.where((t > 1) & (t < 2), 0.05, 0.0)[:, None]
    runs = []
    for seed in (1, 2):
        d, _ = mlid.simulate(truth, t, u, noise_std=[1e-3, 2e-3], seed=seed)
        runs.append(mlid.FlightData(d.t, d.u, d.y, ["de"], ["alpha", "q"], input_units=["rad"],
                                    output_units=["rad", "rad/s"]))
    start = linear(free=["f(2,1)", "g(2,1)", "x0(1)", "bias(2)"])
    res = mlid.fit(start, runs)
    assert dict(zip(res.names, res.param_units)) == {
        "f(2,1)": "1/s2", "g(2,1)": "1/s2", "x0(1)#1": "rad", "x0(1)#2": "rad",
        "bias(2)#1": "rad/s", "bias(2)#2": "rad/s"}
    assert [r["unit"] for r in res.table().rows] == res.param_units
    assert json.loads(res.json())["units"] == res.param_units
    assert "1/s2" in res.report().split("\n")[2]


def test_both_front_ends_print_the_units():
    deck = REPO / "cases" / "attas_channels" / "attas_sp.nml"
    if not (REPO.parent / "shared" / "data" / "fAttasElv1_pqrDot.asc").is_file():
        return
    py = subprocess.run([str(BIN / "mlid"), "run", str(deck)], capture_output=True, text=True,
                        cwd=deck.parent)
    first = py.stdout.split("\n case 2")[0]
    assert "M_alpha          1/s2" in first and "alpha_0          rad" in first
    fo = subprocess.run([str(BIN / "mlid-batch"), str(deck)], capture_output=True, text=True,
                        cwd=deck.parent)
    assert fo.stdout.split("\n case 2")[0] == first
