"""API misuse raises an mlid.MlidError subclass (InputError) naming the
problem, in one line, for every public function (a table of misuses first
written against an earlier front end, now on main's checks)."""

import math

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from mlid.model.point import outputs_at


def _model(nu=1):
    G = [[1.0, 0.2], [0.3, 1.0]] if nu == 2 else [[1.0], [0.3]]
    return mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], G, np.eye(2),
                            free=["f(1,1)", "f(2,1)", "g(1,1)"])


def _record():
    t = np.arange(101) * 0.02
    u = np.sin(3 * t)[:, None]
    data, _ = mlid.simulate(_model(), t, u, [0.01, 0.01], seed=3)
    return data


def _eq():
    return mlid.EquationModel({"a": "a"}, states={"a": "-a"})


def _design():
    return mlid.InputDesign([[-1.588, -0.562], [1.0, -0.737]], [[-1.66], [0.005]], np.eye(2),
                            np.diag([0.02, 0.04]), ["f(1,1)", "g(1,1)"])


T = np.arange(101) * 0.02
U1 = np.sin(3 * T)[:, None]
U2 = np.column_stack([np.sin(3 * T), np.cos(2 * T)])
NAN_U = U1.copy()
NAN_U[7, 0] = np.nan
BIG = 2**31
X2 = np.column_stack([np.sin(T), np.cos(T)])
F10 = np.linspace(0.2, 2.0, 10)

MISUSE = {
    # fit / evaluate
    "fit model None": (lambda d: mlid.fit(None, d), "model must be a mlid model.*None"),
    "fit model path": (lambda d: mlid.fit("c8.nml", d), r"model must be a mlid model \(LinearModel, Longitu"),
    "fit data None": (lambda d: mlid.fit(_model(), None), r"data must be a FlightData or a list of them \(Fli"),
    "fit data path": (lambda d: mlid.fit(_model(), "c8.dat"), "FlightData.load"),
    "fit empty list": (lambda d: mlid.fit(_model(), []), r"data must be a FlightData or a list of them \(Fli"),
    "fit list with a string": (lambda d: mlid.fit(_model(), [d, "b.dat"]), r"data must be a FlightData or a list of them \(Fli"),
    "fit data with too few outputs": (lambda d: mlid.fit(_model(), mlid.FlightData(d.t, d.u, d.y[:, :1])),
                            "1 output columns, the model has 2"),
    "fit max_iter huge": (lambda d: mlid.fit(_model(), d, max_iter=2**40), r"option max_iter takes a whole number within \+\-21"),
    "fit max_iter negative": (lambda d: mlid.fit(_model(), d, max_iter=-1), r"max_iter must lie in 0 to 10000, got \-1"),
    "fit max_iter float": (lambda d: mlid.fit(_model(), d, max_iter=2.5), "whole number"),
    "fit rank_min huge": (lambda d: mlid.fit(_model(), d, rank_min=BIG), r"option rank_min takes a whole number within \+\-21"),
    "fit method typo": (lambda d: mlid.fit(_model(), d, method="fliter_error"),
                        r"option method must be one of output_error filter"),
    "fit tol nan": (lambda d: mlid.fit(_model(), d, tol_cost=math.nan), r"option tol_cost takes a finite number, got 'nan'"),
    "fit bounds not a pair": (lambda d: mlid.fit(_model(), d, bounds={"f(1,1)": 3.0}),
                              "pair"),
    "fit bounds crossed": (lambda d: mlid.fit(_model(), d, bounds={"f(1,1)": (1.0, -1.0)}),
                           "'f\\(1,1\\)': lower bound above upper bound"),
    "fit prior list": (lambda d: mlid.fit(_model(), d, prior=[1.0, 2.0]), "prior must be a dict"),
    "fit initial_states str": (lambda d: mlid.fit(_model(), [d, d], initial_states="x0"),
                               "initial_states must be a list"),
    "fit biases wrong size": (lambda d: mlid.fit(_model(), [d, d], biases=[[0.0], [0.0, 0.0]]),
                              "biases: each needs 2 values"),
    "fit biases NaN": (lambda d: mlid.fit(_model(), [d, d], biases=[[0.0, math.nan], [0, 0]]),
                       r"biases\[0\] has a value that is not finite"),
    "fit bounds NaN": (lambda d: mlid.fit(_model(), d, bounds={"f(1,1)": (math.nan, None)}),
                       r"^'f\(1,1\)': lower bound is not a number$"),   # as the decks say
    "diagnose data None": (lambda d: mlid.diagnose(_model(), None), "data must be"),
    "diagnose alpha": (lambda d: mlid.diagnose(_model(), d, alpha=5), r"alpha must lie in \(0, 1\), got 5"),
    "evaluate model None": (lambda d: mlid.evaluate(None, d), "model must be"),
    "evaluate noise typo": (lambda d: mlid.evaluate(_model(), d, noise="ful"), r"option noise must be one of diagonal full, got '"),
    # simulate
    "simulate model None": (lambda d: mlid.simulate(None, T, U1), "model must be"),
    "simulate model str": (lambda d: mlid.simulate("model", T, U1), r"model must be a mlid model \(LinearModel, Longitu"),
    "simulate u transposed": (lambda d: mlid.simulate(_model(2), T, U2.T),
                              r"u has shape \(2, 101\); expected \(nt, nu\) = \(101, "),
    "simulate u too short": (lambda d: mlid.simulate(_model(), T, U1[:50]), r"u has shape \(50, 1\); expected \(nt, nu\) = \(101, n"),
    "simulate u None": (lambda d: mlid.simulate(_model(), T, None), r"u must be an array of inputs \(one row per sample"),
    "simulate u NaN": (lambda d: mlid.simulate(_model(), T, NAN_U), r"data: input 1 is NaN or infinite at sample 8 \(t "),
    "simulate t None": (lambda d: mlid.simulate(_model(), None, U1), r"t must be an array of times, got NoneType"),
    "simulate t decreasing": (lambda d: mlid.simulate(_model(), T[::-1], U1), r"data: time does not increase at sample 2, t = 1\."),
    "simulate seed huge": (lambda d: mlid.simulate(_model(), T, U1, seed=BIG), r"seed must lie in 0 to 2147483647, got 2147483648"),
    "simulate seed negative": (lambda d: mlid.simulate(_model(), T, U1, seed=-1), r"seed must lie in 0 to 2147483647, got \-1"),
    "simulate seed str": (lambda d: mlid.simulate(_model(), T, U1, seed="3"), "whole number"),
    "simulate noise count": (lambda d: mlid.simulate(_model(), T, U1, [0.1]), r"noise_std needs 2 values \(one per output\), got 1"),
    "simulate noise NaN": (lambda d: mlid.simulate(_model(), T, U1, [math.nan, 0.1]), r"noise_std has a value that is not finite"),
    "simulate noise negative": (lambda d: mlid.simulate(_model(), T, U1, [-0.1, 0.1]), ">= 0"),
    "simulate timing typo": (lambda d: mlid.simulate(_model(), T, U1, timing="back"),
                             "'forward', 'backward'"),
    # monte_carlo
    "monte_carlo start None": (lambda d: mlid.monte_carlo(_model(), None, T, U1), "start must be"),
    "monte_carlo runs huge": (lambda d: mlid.monte_carlo(_model(), _model(), T, U1, runs=BIG),
                              r"runs must lie in 1 to 10000000, got 2147483648"),
    "monte_carlo runs zero": (lambda d: mlid.monte_carlo(_model(), _model(), T, U1, runs=0),
                              r"runs must lie in 1 to 10000000, got 0"),
    "monte_carlo seed overflow": (lambda d: mlid.monte_carlo(_model(), _model(), T, U1, runs=5,
                                                             seed=BIG - 2), r"seed must lie in 0 to 2147483643, got 2147483646"),
    "monte_carlo memory": (lambda d: mlid.monte_carlo(_model(), _model(), T, U1, runs=BIG - 1),
                           r"runs must lie in 1 to 10000000, got 2147483647"),
    # input_signal
    "input_signal shape typo": (lambda d: input_signal("dublet", 1, 0, 0.5, 0.02, 10),
                                r"unknown input shape 'dublet': use none, step, pu"),
    "input_signal shape None": (lambda d: input_signal(None, 1, 0, 0.5, 0.02, 10),
                                r"shape must be a name .*got NoneType"),
    "input_signal nt huge": (lambda d: input_signal("step", 1, 0, 0.5, 0.02, BIG),
                             r"nt must lie in 1 to 10000000, got 2147483648"),
    "input_signal nt zero": (lambda d: input_signal("step", 1, 0, 0.5, 0.02, 0),
                             r"nt must lie in 1 to 10000000, got 0"),
    "input_signal dt zero": (lambda d: input_signal("step", 1, 0, 0.5, 0.0, 10),
                             "dt must be > 0"),
    "input_signal amplitude nan": (lambda d: input_signal("step", math.nan, 0, 0.5,
                                                                    0.02, 10), "amplitude"),
    # check_jacobians
    "check_jacobians model path": (lambda d: mlid.check_jacobians("user.f90", [0, 0], [0]),
                                   "model must be"),
    "check_jacobians x wrong": (lambda d: mlid.check_jacobians(_model(), [0, 0, 0], [0]),
                                r"x and u have 3 and 1 values, the model has 2 sta"),
    "check_jacobians u None": (lambda d: mlid.check_jacobians(_model(), [0, 0], None), r"u must hold real numbers, got object"),
    # a model's outputs at a point; DAVE-ML
    "outputs_at model path": (lambda d: outputs_at("user.f90", [0, 0], [0]), "model must be"),
    "outputs_at x wrong": (lambda d: outputs_at(_model(), [0, 0, 0], [0]),
                           r"x, u and t have 3, 1 and 1 values; the model has 2 states"),
    "outputs_at x nan": (lambda d: outputs_at(_model(), [0, math.nan], [0]), "finite"),
    "outputs_at two times": (lambda d: outputs_at(_model(), [0, 0], [0], t=[0, 1]), "t is one time"),
    "daveml linear model": (lambda d: mlid.export.daveml_text(_model()), "written as equations"),
    "daveml check not a state": (lambda d: mlid.export.daveml_text(_eq(), checks=[{"a": 1, "b": 2}]),
                                 "check case 1: b is not a state or input"),
    "daveml bad date": (lambda d: mlid.export.daveml_text(_eq(), date="2026-13-01"), "YYYY-MM-DD"),
    # input design
    "design F None": (lambda d: mlid.InputDesign(None, [[1.0]], [[1.0]], [[1.0]], ["g(1,1)"]),
                      r"F must hold real numbers, got object"),
    "design F not square": (lambda d: mlid.InputDesign(np.ones((2, 3)), np.ones((2, 1)),
                                                       np.eye(2), np.eye(2), ["g(1,1)"]),
                            r"F \(2, 3\), G \(2, 1\), H \(2, 2\) and R \(2, 2\) do not"),
    "design R wrong": (lambda d: mlid.InputDesign(np.eye(2), np.ones((2, 1)), np.eye(2),
                                                  np.eye(3), ["g(1,1)"]),
                       r"F \(2, 2\), G \(2, 1\), H \(2, 2\) and R \(3, 3\) do not"),
    "design F NaN": (lambda d: mlid.InputDesign([[math.nan]], [[1.0]], [[1.0]], [[1.0]],
                                                ["g(1,1)"]), r"F has a value that is not finite"),
    "design unknowns string": (lambda d: mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]],
                                                          "g(1,1)"), "list of names"),
    "design unknown outside": (lambda d: mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]],
                                                          ["f(3,1)"]), r"unknown 'f\(3,1\)' is no element of F, G or H within "
                                                                       r"the dimensions"),
    "design unknown in no design block": (
        lambda d: mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]], ["x0(1)"]),
        r"unknown 'x0\(1\)' is no element of F, G or H \(the design's unknowns are\)"),
    "design unknown twice": (lambda d: mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]],
                                                        ["g(1,1)", "G(1,1)"]), "twice"),
    "design weights count": (lambda d: mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]],
                                                        ["g(1,1)"], weights=[1, 2]),
                             "one per unknown"),
    "design solver typo": (lambda d: _design().critical_length(0.2, "ricatti"),
                           "method must be one of 'riccati', 'transition'"),
    "design mu method typo": (lambda d: _design().mu_max(1.0, method="opperator"),
                              r"method must be 'operator' or 'riccati', got 'opp"),
    "design input method typo": (lambda d: _design().optimal_input(4.0, 1.0, method="transitoin"),
                                 r"method must be 'operator' or 'transition', got '"),
    "design cells huge": (lambda d: _design().mu_max(1.0, cells=BIG), r"cells must lie in 4 to 1000000, got 2147483648"),
    "design cells memory": (lambda d: _design().mu_max(1.0, cells=10**6), r"cells x inputs must be <= 2000 \(the operator mat"),
    "design T nan": (lambda d: _design().mu_max(math.nan), r"T must be > 0, got nan"),
    "design T str": (lambda d: _design().mu_max("1.0"), r"T must be > 0, got 1\.0"),
    "rank energy and peak": (lambda d: _design().rank_inputs(1.0, energy=1.0, peak=1.0),
                             "give one of energy and peak"),
    "rank candidate typo": (lambda d: _design().rank_inputs(1.0, energy=1.0, candidates=["dublet"]),
                            "candidates: unknown candidate 'dublet'"),
    "rank candidates string": (lambda d: _design().rank_inputs(1.0, energy=1.0, candidates="prbs"),
                               "candidates must be a list"),
    "rank odd cells": (lambda d: _design().rank_inputs(1.0, energy=1.0, cells=51),
                       "cells must be even"),
    "rank band": (lambda d: _design().rank_inputs(1.0, energy=1.0, f_band=(1.0, 0.5)),
                  "the band needs f_max > f_min"),
    "design information u shape": (lambda d: _design().information(1.0, np.ones((4, 3))),
                                   r"expected \(cells, 1\)"),
    "design summary not square": (lambda d: mlid.design.input_design.summary(np.ones((2, 3))),
                                  "square"),
    # parallel
    "parallel truth None": (lambda d: mlid.monte_carlo_parallel(None, _model(), T, U1),
                            "truth must be"),
    "parallel runs huge": (lambda d: mlid.monte_carlo_parallel(_model(), _model(), T, U1,
                                                               runs=2**40), r"runs must lie in 1 to 10000000, got 109951162777"),
    "parallel workers zero": (lambda d: mlid.monte_carlo_parallel(_model(), _model(), T, U1,
                                                                  workers=0), r"workers must lie in 1 to 4096, got 0"),
    "parallel scheduler": (lambda d: mlid.monte_carlo_parallel(_model(), _model(), T, U1,
                                                               scheduler=42), r"scheduler must be an address such as 'tcp://127\."),
    "parallel u transposed": (lambda d: mlid.monte_carlo_parallel(_model(2), _model(2), T, U2.T,
                                                                  workers=1),
                              r"given nu x nt: transpose it"),
    # masked arrays (issue 41, class 8): the mask was dropped, and the hidden samples fitted
    "FlightData y masked": (lambda d: mlid.FlightData(d.t, d.u, np.ma.masked_greater(d.y, 0.1)),
                            r"^y is a masked array with \d+ masked values: cut the samples or "
                            r"fill them \(np\.ma\.filled, or interpolate\) before passing it$"),
    "FlightData t masked": (lambda d: mlid.FlightData(np.ma.masked_equal(d.t, d.t[3]), d.u, d.y),
                            r"^t is a masked array with 1 masked value: cut"),
    "simulate u masked": (lambda d: mlid.simulate(_model(), T, np.ma.masked_greater(U1, 0.9)),
                          r"^u is a masked array with \d+ masked values"),
    "model matrix masked": (lambda d: mlid.LinearModel(np.ma.masked_equal([[-1.0, 0.5], [-0.8, -2.0]], 0.5),
                                                       [[1.0], [0.3]], np.eye(2)),
                            r"^F is a masked array with 1 masked value"),
    # online estimation and model structure (issue 45)
    "rls X 1-D": (lambda d: mlid.online.rls(np.sin(T), np.sin(T)), r"X must be \(n, np\) and y \(n,\)"),
    "rls forgetting 0": (lambda d: mlid.online.rls(X2, np.sin(T), forgetting=0.0),
                         r"forgetting factor must be in \(0, 1\], not 0"),
    "rls forgetting NaN": (lambda d: mlid.online.rls(X2, np.sin(T), forgetting=math.nan),
                           r"forgetting factor must be in \(0, 1\], not NaN"),
    "rls p0 negative": (lambda d: mlid.online.rls(X2, np.sin(T), p0=-1.0), "P0 .* must be > 0"),
    "rls names count": (lambda d: mlid.online.rls(X2, np.sin(T), names=["a"]), "1 names for 2 regressors"),
    "ftr every 0": (lambda d: mlid.online.ftr(T, d.y, d.u, F10, every=0), "every must be a whole number >= 1"),
    "ftr x short": (lambda d: mlid.online.ftr(T, d.y[:50], d.u, F10), "need one row per sample"),
    "ftr forgetting 2": (lambda d: mlid.online.ftr(T, d.y, d.u, F10, forgetting=2.0),
                         r"forgetting factor must be in \(0, 1\]"),
    "ftr negative frequency": (lambda d: mlid.online.ftr(T, d.y, d.u, -F10), "frequencies must be > 0"),
    "ftr too few frequencies": (lambda d: mlid.online.ftr(T, d.y, d.u, [0.5]), "more frequencies than parameters"),
    "ekf data list": (lambda d: mlid.online.ekf(_model(), [d, d]), "data must be one FlightData"),
    "ekf model None": (lambda d: mlid.online.ekf(None, d), "model must be a mlid model"),
    "ekf p0 NaN": (lambda d: mlid.online.ekf(_model(), d, p0=math.nan), "p0 has a value that is not finite"),
    "ekf free unknown": (lambda d: mlid.online.ekf(_model(), d, free=["M_x"]), "parameter 'M_x' does not exist"),
    "ukf beta inf": (lambda d: mlid.online.ukf(_model(), d, beta=math.inf, r=[1, 1]), "beta and kappa must be finite"),
    "efrls forgetting 0": (lambda d: mlid.online.efrls(_model(), d, forgetting=0.0, r=[1, 1]),
                           r"forgetting factor must be in \(0, 1\], 1 for none"),
    "stepwise method typo": (lambda d: mlid.stepwise(X2, np.sin(T), method="forwards"),
                             "method must be 'forward', 'backward' or 'mof', not 'forwards'"),
    "stepwise y short": (lambda d: mlid.stepwise(X2, np.sin(T[:50])), r"X must be \(N, m\) and y \(N,\)"),
    "stepwise F_in negative": (lambda d: mlid.stepwise(X2, np.sin(T), f_in=-1.0), "F_in and F_out must be > 0"),
    "stepwise forced unknown": (lambda d: mlid.stepwise(X2, np.sin(T), forced=["zz"], names=["a", "b"]),
                                "forced terms .'zz'. are not among the candidates"),
    "candidates of a FlightData": (lambda d: mlid.stepwise_candidates(d, ["alpha"]),
                                   "data must be a pandas DataFrame or a dict"),
    "candidates ragged": (lambda d: mlid.stepwise_candidates({"a": np.sin(T), "b": T[:50]}, ["a", "b"]),
                          "one sample count, got a 101, b 50"),
    "candidates degree 0": (lambda d: mlid.stepwise_candidates({"a": np.sin(T)}, ["a"], degree=0),
                            "degree and the spline degree must be at least 1"),
    "candidates knots NaN": (lambda d: mlid.stepwise_candidates({"a": np.sin(T)}, ["a"], knots={"a": [math.nan]}),
                             "knots of a has a value that is not finite"),
    # the candidates' names are the core's, one a line
    "stepwise candidates two-line name": (
        lambda d: mlid.stepwise_candidates({"a\nb": T}, ["a\nb"]),
        "a variable's name must be text of one line"),
    # the two-step table fit (mlid.fit_tables)
    "fit_tables results empty": (lambda d: mlid.fit_tables([], _TAB, []),
                                 "results must be a list of FitResults, at least one"),
    "fit_tables result not a fit": (lambda d: mlid.fit_tables(["fit"], _TAB, [{"a": 0}]),
                                    r"results\[0\] must be a FitResult, got str"),
    "fit_tables tables a list": (lambda d: mlid.fit_tables(_local(d), [_TAB["M_a"]], [{"a": 0}]),
                                 r"tables must be a dict \{quantity name: Table\}"),
    "fit_tables table not a Table": (lambda d: mlid.fit_tables(_local(d), {"M_a": [0, 1]}, [{"a": 0}]),
                                     r"tables\['M_a'\] must be a mlid.model.tables.Table, got list"),
    "fit_tables conditions count": (lambda d: mlid.fit_tables(_local(d), _TAB, [{"a": 0}] * 2),
                                    "conditions: one for each of the 1 results, got 2"),
    "fit_tables condition missing": (lambda d: mlid.fit_tables(_local(d), _TAB, [{"b": 0}]),
                                     "manoeuvre 'manoeuvre 1' has no value of a .a variable of table M_a"),
    "fit_tables condition NaN": (lambda d: mlid.fit_tables(_local(d), _TAB, [{"a": math.nan}]),
                                 r"conditions\[0\]\['a'\] has a value that is not finite"),
    "fit_tables condition a number": (lambda d: mlid.fit_tables(_local(d), _TAB, [0.1]),
                                      r"conditions\[0\] must be a dict \{variable: value\} or a deck case"),
    "fit_tables level 1.5": (lambda d: mlid.fit_tables(_local(d), _TAB, [{"a": 0}], level=1.5),
                             "the level must be between 0 and 1"),
    "fit_tables no tabled quantity": (lambda d: mlid.fit_tables(_local(d), {"M_q": _TAB["M_a"]}, [{"a": 0}]),
                                      r"manoeuvre 'manoeuvre 1' estimates none of the tabled quantities \(M_q\)"),
    "fit_tables quantity no name": (lambda d: mlid.fit_tables([mlid.fit(_model(), d)], {"f(2,1)": _TAB["M_a"]}, [{"a": 0}]),
                                    r"tables: 'f\(2,1\)' is not a name a table can have"),
    "fit_tables labels count": (lambda d: mlid.fit_tables(_local(d), _TAB, [{"a": 0}], labels=["x", "y"]),
                                "labels: one for each of the 1 results, got 2"),
    "fit_tables bad breakpoints": (lambda d: mlid.fit_tables(_local(d), {"M_a": mlid.model.tables.Table("a", [1, 0])}, [{"a": 0}]),
                                   "breakpoints of a: the breakpoints must increase"),
    "fit_tables curve of no table": (lambda d: mlid.fit_tables(_local(d), _TAB, [{"a": 0.0}]).curve("M_q", [[0.1]]),
                                     r"no table 'M_q' \(tables: M_a\)"),
}


def _local(d):
    """A one-manoeuvre campaign: the local fit of _model() to d."""
    m = _model()
    return [mlid.fit(mlid.LinearModel(m.F, m.G, m.H, free=m.free, names={"f(2,1)": "M_a"}), d)]


_TAB = {"M_a": mlid.model.tables.Table("a", [0.0, 1.0])}


@pytest.fixture(scope="module")
def record():
    return _record()


@pytest.mark.parametrize("name", sorted(MISUSE))
def test_api_misuse_raises_an_mlid_error(name, record):
    call, phrase = MISUSE[name]
    with pytest.raises(mlid.MlidError, match=phrase) as info:
        call(record)
    assert isinstance(info.value, mlid.InputError)
    assert "\n" not in str(info.value)


def test_there_are_enough_misuse_cases():
    assert len(MISUSE) >= 25


def test_right_calls_still_work(record):
    """The checks take what the functions took before: 1-D u for one input,
    numpy integers, a tuple of records, an upper-case input shape."""
    data, _ = mlid.simulate(_model(), T, U1[:, 0], seed=np.int64(3))
    assert data.u.shape == (101, 1)
    u = input_signal("DOUBLET", 1.0, 0.2, 0.2, 0.02, np.int32(101))
    assert u.shape == (101,) and np.abs(u).max() == 1.0
    res = mlid.fit(_model(), (record,), max_iter=np.int64(10), tol_cost=1e-9)
    assert res.converged
    assert set(mlid.check_jacobians(_model(), np.zeros(2), 0.0)) >= {"df/dx", "dh/dp"}
    # a masked array with nothing masked is its data
    same = mlid.FlightData(np.ma.masked_array(record.t), record.u, np.ma.masked_array(record.y))
    assert np.array_equal(same.y, record.y) and not np.ma.isMaskedArray(same.y)
