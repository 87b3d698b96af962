"""Output time delays (fortran/numerics/mlid_delay.f90): a parameter like any other,
recovered within the Cramer-Rao bound, refused where it has no meaning
(filter error, a delay as long as the manoeuvre), and the same deck in both
front ends.  The sensitivities against central differences are in
tests/fortran/test_numerics.f90."""

import numpy as np
import pytest

import mlid
from conftest import both_front_ends_json, refused_by_both

F = [[-1.0, 0.9], [-4.0, -1.5]]
G = [[-0.1], [-6.0]]
FREE = ["f(2,1)", "f(2,2)", "g(2,1)", "delay(2)"]


def record(seed, delay=(0.0, 0.07), udelay=(0.0,), nt=501, dt=0.02):
    """The short period's record with a delayed q sensor (and elevator), its
    elevator three pulses."""
    t = np.arange(nt) * dt
    u = np.zeros((nt, 1))
    u[(t > 1) & (t < 1.5), 0] = 0.05
    u[(t > 1.5) & (t < 2), 0] = -0.05
    u[(t > 4) & (t < 4.3), 0] = 0.05
    truth = mlid.LinearModel(F=F, G=G, H=np.eye(2), delay=list(delay), udelay=list(udelay))
    d, _ = mlid.simulate(truth, t, u, noise_std=[2e-3, 5e-3], seed=seed,
                         output_names=["alpha", "q"], input_names=["de"])
    return d


def start(**kw):
    return mlid.LinearModel(F=np.array(F) * [[1.0], [0.8]], G=G, H=np.eye(2), free=FREE, **kw)


@pytest.mark.parametrize("delay", [0.07, -0.013])
def test_a_delay_is_recovered_within_the_bound(delay):
    """From zero, 3.5 samples late or 0.65 early: within 3 Cramer-Rao sigma
    on each of 5 seeds (a 3-sigma miss on 5 draws has probability 1.3%)."""
    for seed in range(5):
        res = mlid.fit(start(), record(seed, (0.0, delay)))
        assert res.converged
        k = res.names.index("delay(2)")
        assert abs(res.estimate[k] - delay) < 3 * res.sigma[k], (seed, res.estimate[k], res.sigma[k])


def test_a_fixed_delay_shifts_the_outputs_by_interpolation():
    """A delay of exactly two samples moves the noise-free output two samples
    later; half a sample is the mean of the neighbours; the first samples
    hold the manoeuvre's first value."""
    t = np.arange(101) * 0.05
    u = np.sin(t)[:, None]
    ys = [mlid.simulate(mlid.LinearModel(F=F, G=G, H=np.eye(2), delay=[0.0, tau]), t, u)[0].y[:, 1]
          for tau in (0.0, 0.1, 0.025)]
    np.testing.assert_allclose(ys[1][2:], ys[0][:-2], atol=1e-13)
    np.testing.assert_allclose(ys[1][:2], ys[0][0], atol=1e-13)
    np.testing.assert_allclose(ys[2][1:], 0.5 * (ys[0][1:] + ys[0][:-1]), atol=1e-13)


def test_delays_are_refused_with_the_filter_and_when_too_long():
    d = record(1)
    with pytest.raises(mlid.MlidError, match="time delays are for output error"):
        mlid.fit(start(q=[0.0], Gamma=[[0.0], [1.0]], delay=[0.0, 0.02]), d, method="filter_error")
    with pytest.raises(mlid.MlidError, match=r"delay\(2\) = 12\.00 s is not shorter than manoeuvre 1"):
        mlid.fit(start(delay=[0.0, 12.0]), d)
    with pytest.raises(mlid.MlidError, match=r"delay\(2\) = -2\.000E-02 s leads by a sample or more"):
        mlid.fit(start(delay=[0.0, -0.02]), d)
    with pytest.raises(mlid.MlidError, match="equation-error start-up takes the measured states"):
        mlid.fit(start(delay=[0.0, 0.02]), d, startup="equation_error")


def test_reductions_and_rebuilt_models_keep_the_delays():
    m = mlid.LinearModel(F=F, G=G, H=np.eye(2), delay=[0.0, 0.05], free=["f(2,1)", "delay(2)"])
    r = mlid.reduce_measured_state(m, state=1, output=1)
    assert list(r.delay) == [0.05] and "delay(1)" in r.free
    with pytest.raises(mlid.InputError, match="output 2 has a time delay"):
        mlid.reduce_measured_state(m, state=2, output=2)


DECK = """
&case title = 'late q sensor', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, 0.9, -3.2, -1.2,   g = -0.1, -6.0,   h = 1, 0, 0, 1,
    delay = {delay},
    free = 'f(2,1)', 'f(2,2)', 'g(2,1)', 'delay(2)', names = 'M_a', 'M_q', 'M_de', 'tau_q',
    output_names = 'alpha', 'q' /
&data file = 'r.dat', time_col = 1, input_cols = 2, output_cols = 3, 4,
    units = 'u1 = rad', 'y1 = rad', 'y2 = rad/s', columns = 't', 'u1', 'y1', 'y2' /
"""


def test_the_deck_gives_the_same_fit_in_both_front_ends(tmp_path):
    record(2).save(tmp_path / "r.dat")
    (tmp_path / "ok.nml").write_text(DECK.format(delay="0.0, 0.0"))
    fit = both_front_ends_json(tmp_path / "ok.nml", tmp_path)
    k = fit["parameters"].index("tau_q")
    assert fit["units"][k] == "s"
    assert abs(fit["estimate"][k] - 0.07) < 3 * fit["sigma"][k]
    (tmp_path / "bad.nml").write_text(DECK.format(delay="0.0, 0.0, 1.0"))
    refused_by_both(tmp_path / "bad.nml", "delay has 3 values, it needs 2", cwd=tmp_path)


# -- input delays ----------------------------------------------------------

def _output_sensitivity(model, data, name):
    """d yhat / d(name) (nt, ny) as the core computes it: R-hat times the
    weighted sensitivity of the evaluation."""
    ev = mlid.evaluate(model.with_free([name]), data)
    dy = np.einsum("pq,qif->pif", ev["rhat"], ev["weighted_sensitivity"])
    return dy[:, :, 0].T


EQ = dict(states={"alpha": "Za*alpha + q + Zd*de",
                  "q": "Ma*alpha + Ma3*alpha^3 + Mq*q + Md*tanh(3*de)/3"},
          outputs={"alpha": "alpha", "q": "q", "az": "80*(Za*alpha + Zd*de)"}, inputs=["de"],
          params={"Za": -1.0, "Zd": -0.1, "Ma": -4.0, "Ma3": -20.0, "Mq": -1.5, "Md": -6.0})


@pytest.mark.parametrize("kind", ["linear", "equations"])
def test_input_delay_sensitivities_against_central_differences(kind):
    """Both kinds that give input Jacobians (df/du, dh/du: the linear model's
    G and D, the equations model's reverse sweep), a delay of 1.55 samples
    and a lead of 0.4: the analytic sensitivity against central differences
    of the outputs."""
    d = record(4)
    if kind == "equations":
        d = mlid.FlightData(d.t, d.u, np.column_stack([d.y, d.y[:, 0]]))
    for tau in (0.031, -0.008):
        if kind == "linear":
            m = mlid.LinearModel(F=F, G=G, H=np.eye(2), D=[[0.3], [-0.2]], udelay=[tau])
        else:
            m = mlid.EquationModel(**EQ, udelay=[tau])
        h = 1e-6
        ys = [mlid.evaluate(m.with_theta(_shifted(m, h * s)), d)["yhat"] for s in (1, -1)]
        fd = (ys[0] - ys[1]) / (2 * h)
        got = _output_sensitivity(m, d, "udelay(1)")
        assert np.max(np.abs(got - fd)) < 1e-6 * max(1.0, np.max(np.abs(fd))), tau


def _shifted(model, h):
    theta = model.theta.copy()
    theta[model.element_names().index("udelay(1)")] += h
    return theta


@pytest.mark.parametrize("delay", [0.06, -0.011])
def test_an_input_delay_is_recovered_within_the_bound(delay):
    """A surface recorded 3 samples early (or 0.55 late), from zero: within 3
    Cramer-Rao sigma on each of 5 seeds."""
    for seed in range(5):
        d = record(seed, delay=(0.0, 0.0), udelay=(delay,))
        start = mlid.LinearModel(F=np.array(F) * [[1.0], [0.8]], G=G, H=np.eye(2),
                                 free=["f(2,1)", "f(2,2)", "g(2,1)", "udelay(1)"])
        res = mlid.fit(start, d)
        k = res.names.index("udelay(1)")
        assert res.converged and abs(res.estimate[k] - delay) < 3 * res.sigma[k], \
            (seed, res.estimate[k], res.sigma[k])


def test_input_delays_are_refused_where_they_cannot_be_differentiated():
    d = record(1)
    with pytest.raises(mlid.MlidError, match="time delays are for output error"):
        mlid.fit(start(q=[0.0], Gamma=[[0.0], [1.0]], udelay=[0.02]), d, method="filter_error")
    with pytest.raises(mlid.MlidError, match=r"udelay\(1\) = -2\.000E-02 s leads by a sample"):
        mlid.fit(start(udelay=[-0.02]), d)
    user = mlid.X22Model(p=np.zeros(23), free=["udelay(1)"])
    t = np.arange(50) * 0.05
    x22 = mlid.FlightData(t, np.zeros((50, 1)), np.zeros((50, 7)) + np.arange(7) * 1e-3)
    with pytest.raises(mlid.MlidError, match="a free input time delay needs the model's input "
                                             "Jacobians"):
        mlid.fit(user, x22)


def test_an_input_delay_in_a_deck_gives_the_same_fit_in_both_front_ends(tmp_path):
    record(3, delay=(0.0, 0.0), udelay=(0.05,)).save(tmp_path / "r.dat")
    deck = DECK.format(delay="0.0, 0.0").replace("'delay(2)'", "'udelay(1)'").replace(
        "'tau_q'", "'tau_de'")
    (tmp_path / "u.nml").write_text(deck)
    fit = both_front_ends_json(tmp_path / "u.nml", tmp_path)
    k = fit["parameters"].index("tau_de")
    assert fit["units"][k] == "s" and abs(fit["estimate"][k] - 0.05) < 3 * fit["sigma"][k]
