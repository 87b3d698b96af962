"""Export to DAVE-ML 2.0 (python/mlid/export/daveml.py), read back by a
second implementation written here from the standard (MathML-2 content
markup, gridded tables listed with the last variable fastest, linear
interpolation held at the end breakpoints): it must give mlid's own
outputs along a simulated record, the file's check cases (computed by the
core), and a fit's sigma; the elements in the order DAVE-ML 2.0 sets."""

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import mlid
from mlid.errors import InputError
from mlid.model.tables import Table
from mlid.model.point import derivatives_at, outputs_at
from test_export_jsbsim import OUTPUTS, STATES, sixdof
from test_tables import NAMES, START, table_model, table_record

D = "{http://daveml.org/2010/DAVEML}"
M = "{http://www.w3.org/1998/Math/MathML}"
DATE = "2026-12-08"


# the second implementation ------------------------------------------------
def _number_list(text):
    return np.array([float(v) for v in text.replace(",", " ").split()])


class Reader:
    """A DAVE-ML file's variables evaluated at a point."""

    def __init__(self, text):
        self.root = ET.fromstring(text.split("\n", 2)[2])      # past the XML and DOCTYPE lines
        self.vars = self.root.findall(D + "variableDef")
        bps = {b.get("bpID"): _number_list(b.find(D + "bpVals").text)
               for b in self.root.findall(D + "breakpointDef")}
        tables = {}
        for g in self.root.findall(D + "griddedTableDef"):
            axes = [bps[r.get("bpID")] for r in g.find(D + "breakpointRefs")]
            shape = tuple(a.size for a in axes)
            tables[g.get("gtID")] = (axes, _number_list(g.find(D + "dataTable").text)
                                     .reshape(shape))
        self.functions = {}
        for f in self.root.findall(D + "function"):
            ins = [r.get("varID") for r in f.findall(D + "independentVarRef")]
            gt = f.find(D + "functionDefn").find(D + "griddedTableRef").get("gtID")
            self.functions[f.find(D + "dependentVarRef").get("varID")] = (ins, *tables[gt])

    def evaluate(self, given):
        v = dict(given)
        for var in self.vars:
            name = var.get("varID")
            if name in v:
                continue
            calc = var.find(D + "calculation")
            if name in self.functions:
                ins, axes, data = self.functions[name]
                v[name] = _interpolate(axes, data, [v[i] for i in ins])
            elif calc is not None:
                v[name] = _math(list(calc.find(M + "math"))[0], v)
            elif var.get("initialValue") is not None:
                v[name] = float(var.get("initialValue"))
            else:
                raise KeyError(f"no value for the input {name}")
        return v


def _interpolate(axes, data, point):
    out = data
    for b, x in zip(axes, point):
        x = min(max(x, b[0]), b[-1])                             # held beyond the ends
        i = min(np.searchsorted(b, x, side="right") - 1, b.size - 2)
        f = (x - b[i]) / (b[i + 1] - b[i])
        out = (1 - f) * out[i] + f * out[i + 1]
    return float(out)


_OPS = {"plus": sum, "times": math.prod, "divide": lambda a: a[0] / a[1],
        "power": lambda a: a[0] ** a[1], "sin": lambda a: math.sin(a[0]),
        "cos": lambda a: math.cos(a[0]), "tan": lambda a: math.tan(a[0]),
        "arcsin": lambda a: math.asin(a[0]), "arccos": lambda a: math.acos(a[0]),
        "arctan": lambda a: math.atan(a[0]), "root": lambda a: math.sqrt(a[0]),
        "abs": lambda a: abs(a[0]), "exp": lambda a: math.exp(a[0]),
        "ln": lambda a: math.log(a[0]), "tanh": lambda a: math.tanh(a[0]),
        "min": min, "max": max,
        "minus": lambda a: -a[0] if len(a) == 1 else a[0] - a[1]}


def _math(node, v):
    tag = node.tag.replace(M, "")
    if tag == "cn":
        return float(node.text)
    if tag == "ci":
        return v[node.text.strip()]
    if tag == "pi":
        return math.pi
    assert tag == "apply", tag
    op, *args = list(node)
    name = op.tag.replace(M, "")
    if name == "csymbol":
        assert op.text == "atan2" and "daveml.org" in op.get("definitionURL")
        return math.atan2(*[_math(a, v) for a in args])
    if name == "log":
        base = args[0]
        assert base.tag == M + "logbase"
        return math.log(_math(args[1], v), _math(list(base)[0], v))
    return _OPS[name]([_math(a, v) for a in args])


# the checks ----------------------------------------------------------------
def flown_record():
    """The six-degree-of-freedom model with tables (test_export_jsbsim's),
    flown 6 s on elevator, aileron and rudder doublets."""
    m = sixdof()
    t = np.arange(601) * 0.01
    u = np.zeros((t.size, 3))
    u[(t > 0.5) & (t < 1.5), 0], u[(t > 1.5) & (t < 2.5), 0] = -0.06, 0.06
    u[(t > 3) & (t < 4), 1], u[(t > 4) & (t < 5), 2] = 0.04, -0.04
    m.x0 = [62.0, 0.0, 2.6, 0.0, 0.0, 0.0, 0.0, 0.05, 0.0, 1500.0]
    d, x = mlid.simulate(m, t, u, noise_std=np.zeros(m.ny))
    return m, d, x


def test_a_second_reader_gives_mlids_outputs_along_a_record():
    """Every sample of a simulated record: the file's y_NAME at the
    sample's states and inputs are mlid's outputs to 1e-12 (relative); alpha
    crosses breakpoints of the two-variable table."""
    m, d, x = flown_record()
    reader = Reader(mlid.export.daveml_text(m, date=DATE))
    alpha = d.y[:, 0]
    assert alpha.min() < 0.05 < alpha.max()                      # crosses a breakpoint
    worst = 0.0
    for k in range(0, d.t.size, 5):
        given = dict(zip(STATES, x[k]), de=d.u[k, 0], da=d.u[k, 1], dr=d.u[k, 2])
        v = reader.evaluate(given)
        got = np.array([v[f"y_{n}"] for n in OUTPUTS])
        worst = max(worst, float(np.max(np.abs(got - d.y[k]) / np.maximum(1, np.abs(d.y[k])))))
    assert worst < 1e-12, worst


def test_check_cases_are_the_cores_and_the_reader_meets_them():
    """Two check cases (one beyond the table's end in alpha): the file's
    outputs with their tolerance, met by the second reader, derivatives
    included; the state derivatives also agree with the simulation's slope."""
    m, d, x = flown_record()
    shots = [dict(zip(STATES, x[150]), de=d.u[150, 0], da=d.u[150, 1], dr=d.u[150, 2]),
             dict(zip(STATES, [55.0, 2.0, 12.0, 0.1, 0.05, -0.02, 0.2, 0.3, 0.1, 900.0]),
                  de=0.02, da=-0.01, dr=0.01)]
    assert math.atan2(12.0, 55.0) > 0.15                       # beyond the last breakpoint
    text = mlid.export.daveml_text(m, checks=shots, date=DATE)
    reader = Reader(text)
    shots_xml = reader.root.find(D + "checkData").findall(D + "staticShot")
    assert len(shots_xml) == 2
    for shot in shots_xml:
        given = {s.find(D + "signalName").text: float(s.find(D + "signalValue").text)
                 for s in shot.find(D + "checkInputs")}
        v = reader.evaluate(given)
        outs = shot.find(D + "checkOutputs").findall(D + "signal")
        assert {s.find(D + "signalName").text for s in outs} >= {"d_u", "d_q", "y_alpha"}
        for s in outs:
            want, tol = float(s.find(D + "signalValue").text), float(s.find(D + "tol").text)
            assert abs(v[s.find(D + "signalName").text] - want) <= tol, s.find(D + "signalName").text
    # d_q at sample 150 against the simulated q's central difference
    v = reader.evaluate(shots[0])
    slope = (x[151, 4] - x[149, 4]) / 0.02
    assert abs(v["d_q"] - slope) < 1e-3 * max(1.0, abs(slope)), (v["d_q"], slope)


def test_a_fit_carries_each_free_values_sigma():
    """A fitted table: each free value's sigma is the table's additive
    normal uncertainty (one sigma) at its place, the others 0; the values
    are the estimates."""
    d = table_record()
    res = mlid.fit(table_model(values=START, x0=[0.09, 0.0], free=NAMES[:5]), d)
    root = Reader(mlid.export.daveml_text(res, date=DATE)).root
    g = root.find(D + "griddedTableDef")
    values = _number_list(g.find(D + "dataTable").text)
    bounds = _number_list(g.find(D + "uncertainty").find(D + "normalPDF").find(D + "bounds")
                          .find(D + "dataTable").text)
    assert g.find(D + "uncertainty").get("effect") == "additive"
    assert g.find(D + "uncertainty").find(D + "normalPDF").get("numSigmas") == "1"
    np.testing.assert_allclose(values[:5], res.estimate, rtol=1e-15)
    np.testing.assert_allclose(bounds[:5], res.sigma, rtol=1e-15)
    assert bounds[5] == 0 and values[5] == START[5]


def test_a_tied_value_gets_its_sigma_through_the_tie_and_an_unreached_one_none(tmp_path):
    """CLt[5] tied to CLt[4] has CLt[4]'s sigma (scale 1), not 0; a free
    value no sample reaches (CLt[6], rank-deficient fit) gets NaN and is
    named in the table's description, never a sigma of 0 (known)."""
    d = table_record()
    m = table_model(values=START, x0=[0.09, 0.0], free=NAMES[:4] + ["CLt[6]"],
                    ties={"CLt[5]": "CLt[4] + 0.15"})
    res = mlid.fit(m, d, rank_min=1)
    cov = res.covariance_of(["CLt[4]", "CLt[5]", "CLt[6]", "x0(1)"])
    assert cov[1, 1] == pytest.approx(cov[0, 0], rel=1e-12) and cov[1, 1] > 0
    assert np.isnan(cov[2, 2]) and cov[3, 3] == 0
    g = Reader(mlid.export.daveml_text(res, date=DATE)).root.find(D + "griddedTableDef")
    bounds = g.find(D + "uncertainty").find(D + "normalPDF").find(D + "bounds") \
        .find(D + "dataTable").text
    sig = np.array([float(v) for v in bounds.replace(",", " ").split()])
    np.testing.assert_allclose(sig[:4], np.sqrt(np.diag(res.covariance))[:4], rtol=1e-12)
    assert sig[4] == pytest.approx(sig[3], rel=1e-12) and np.isnan(sig[5])
    assert "CLt[6]" in g.find(D + "description").text
    # the table set says the same: CLt[5] a sigma, CLt[6] none (null)
    table = json.loads(mlid.export.tables(res, tmp_path / "t.json"))["tables"][0]
    assert table["sigma"][4] == pytest.approx(sig[4]) and table["sigma"][5] is None


def test_the_point_is_evaluated_not_integrated():
    """outputs_at and derivatives_at evaluate h and f where they are, even
    where one step of integration would diverge (a' = -a^3 at a = 1e60)."""
    m = mlid.EquationModel({"y": "2*a"}, states={"a": "-a^3"})
    assert outputs_at(m, [1e60], [])[0] == 2e60
    assert derivatives_at(m, [2.0], [])[0] == -8.0


def test_elements_come_in_the_order_dave_ml_sets():
    """DAVEfunc: fileHeader, variableDef+, breakpointDef*, griddedTableDef*,
    function*, checkData?; a variableDef's parts in the standard's order;
    every varID once, every reference to one defined."""
    m, d, x = flown_record()
    shot = dict(zip(STATES, x[0]), de=0.0, da=0.0, dr=0.0)
    root = Reader(mlid.export.daveml_text(m, checks=[shot], date=DATE)).root
    order = ["fileHeader", "variableDef", "breakpointDef", "griddedTableDef", "function",
             "checkData"]
    seen = [order.index(c.tag.replace(D, "")) for c in root]
    assert seen == sorted(seen) and seen[0] == 0 and seen.count(5) == 1
    # DAVE-ML 2.0's variableDef: description?, (provenance)?, calculation?,
    # (isInput | isControl | isDisturbance)?, isState?, isStateDeriv?,
    # isOutput?, isStdAIAA?, uncertainty?
    parts = ["description", "calculation", "isInput", "isState", "isStateDeriv", "isOutput",
             "uncertainty"]
    ids = [v.get("varID") for v in root.findall(D + "variableDef")]
    assert len(ids) == len(set(ids))
    for v in root.findall(D + "variableDef"):
        idx = [parts.index(c.tag.replace(D, "")) for c in v]
        assert idx == sorted(idx), v.get("varID")
        assert v.get("units"), v.get("varID")
    refs = [r.get("varID") for r in root.iter(D + "independentVarRef")] + \
        [r.get("varID") for r in root.iter(D + "dependentVarRef")] + \
        [c.text.strip() for c in root.iter(M + "ci")]
    assert set(refs) <= set(ids)
    header = root.find(D + "fileHeader")
    assert header.find(D + "author").get("org") and \
        header.find(D + "creationDate").get("date") == DATE


def test_units_are_stated_or_said_unknown():
    """A state, an input and a sixdof coefficient get their units; a
    quantity the export cannot know says so, and units given are used."""
    m = sixdof()
    root = Reader(mlid.export.daveml_text(m, date=DATE, units={"Cmq": "nd"})).root
    units = {v.get("varID"): v.get("units") for v in root.findall(D + "variableDef")}
    assert units["u"] == "m_s" and units["de"] == "rad" and units["Cma"] == "nd"
    assert units["CLa"] == "unknown" and units["Cmq"] == "nd" and units["d_q"] == "rad_s2"


def test_bad_requests_are_refused_and_write_nothing(tmp_path):
    m = sixdof()
    path = tmp_path / "m.dml"
    with pytest.raises(InputError, match="check case 1: no value for de"):
        mlid.export.daveml(m, path, checks=[dict(zip(STATES, np.ones(10)))])
    with pytest.raises(InputError, match="YYYY-MM-DD"):
        mlid.export.daveml(m, path, date="8 Dec 2026")
    with pytest.raises(InputError, match="written as equations"):
        mlid.export.daveml(mlid.LinearModel(np.eye(1), np.zeros((1, 1)), np.eye(1),
                                            np.zeros((1, 1))), path)
    assert not path.exists()
    text = mlid.export.daveml(m, path, date=DATE)
    assert path.read_text() == text


def test_a_table_over_three_variables_is_listed_last_fastest():
    """A three-variable table: the dataTable's order is C order of
    values[i, j, k], and the reader's interpolation at an inner point is
    the model's."""
    rng = np.random.default_rng(3)
    b1, b2, b3 = [0.0, 0.1, 0.2], [0.3, 0.6], [0.0, 1.0]
    vals = rng.normal(size=(3, 2, 2))
    m = mlid.EquationModel(states={"a": "-a + T3"}, outputs={"T": "T3"}, inputs=["M", "f"],
                           definitions={"T3": Table(["a", "M", "f"], [b1, b2, b3], vals)})
    reader = Reader(mlid.export.daveml_text(m, date=DATE))
    data = _number_list(reader.root.find(D + "griddedTableDef").find(D + "dataTable").text)
    np.testing.assert_array_equal(data, vals.ravel(order="C"))
    point = {"a": 0.13, "M": 0.41, "f": 0.7}
    want = outputs_at(m, [point["a"]], [point["M"], point["f"]])[0]
    assert abs(reader.evaluate(point)["y_T"] - want) < 1e-14
