"""Output time delays (fortran/mlid_delay.f90): a parameter like any other,
recovered within the Cramer-Rao bound, refused where it has no meaning
(filter error, a delay as long as the manoeuvre), and the same deck in both
front ends.  The sensitivities against central differences are in
tests/fortran/test_numerics.f90."""

import subprocess

import numpy as np
import pytest

import mlid
from conftest import BIN, both_front_ends_json

F = [[-1.0, 0.9], [-4.0, -1.5]]
G = [[-0.1], [-6.0]]
FREE = ["f(2,1)", "f(2,2)", "g(2,1)", "delay(2)"]


def record(seed, delay=(0.0, 0.07), nt=501, dt=0.02):
    t = np.arange(nt) * dt
    u = np.zeros((nt, 1))
    u[(t > 1) & (t < 1.5), 0] = 0.05
    u[(t > 1.5) & (t < 2), 0] = -0.05
    u[(t > 4) & (t < 4.3), 0] = 0.05
    truth = mlid.LinearModel(F=F, G=G, H=np.eye(2), delay=list(delay))
    d, _ = mlid.simulate(truth, t, u, noise_std=[2e-3, 5e-3], seed=seed,
                         output_names=["alpha", "q"], input_names=["de"])
    return d


def start(**kw):
    return mlid.LinearModel(F=np.array(F) * [[1.0], [0.8]], G=G, H=np.eye(2), free=FREE, **kw)


@pytest.mark.parametrize("delay", [0.07, -0.03])
def test_a_delay_is_recovered_within_the_bound(delay):
    """From zero, 3.5 samples late or 1.5 early: within 3 Cramer-Rao sigma
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
    with pytest.raises(mlid.MlidError, match="output time delays are for output error"):
        mlid.fit(start(q=[0.0], Gamma=[[0.0], [1.0]], delay=[0.0, 0.02]), d, method="filter_error")
    with pytest.raises(mlid.MlidError, match=r"delay\(2\) = 12\.00 s is not shorter than manoeuvre 1"):
        mlid.fit(start(delay=[0.0, 12.0]), d)


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
    for exe, pre in (("mlid", ["run"]), ("mlid-batch", [])):
        bad = subprocess.run([str(BIN / exe), *pre, str(tmp_path / "bad.nml")],
                             capture_output=True, text=True, cwd=tmp_path)
        assert bad.returncode == 1 and "delay has 3 values, it needs 2" in bad.stderr, bad.stderr
