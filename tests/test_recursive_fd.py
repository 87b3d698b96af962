"""Recursive frequency-domain equation error over a moving window
(fortran/estimation/frequency_domain/mlid_recursive_fd.f90): over the whole record it is fit()'s
frequency equation error; over moving windows it follows a derivative that
changes during the record."""

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import C8_F, C8_G, C8_FREE, C8_NAMES, C8_STD, c8_start

BAND = dict(f_min=0.1, f_max=2.0, n_freq=40)


def test_whole_record_window_is_the_batch_fit(c8_data):
    """One window over all 301 samples: the running sums give the batch
    transform, and the per-equation least squares the batch Newton fit's
    estimates and Cramer-Rao sigmas."""
    rec = mlid.recursive_frequency_fit(c8_start(), c8_data, window=len(c8_data.t), **BAND)
    batch = mlid.fit(c8_start(), c8_data, method="frequency_equation_error", **BAND)
    assert rec["estimates"].shape == (1, 5) and rec["t_end"][0] == c8_data.t[-1]
    order = [rec["names"].index(n) for n in batch.names]
    np.testing.assert_allclose(rec["estimates"][0, order], batch.estimate, rtol=1e-7)
    np.testing.assert_allclose(rec["sigma"][0, order], batch.sigma, rtol=1e-6)


def changing_record(seed=4):
    """40 s of doublets every 4 s; the control power M_delta (g(3,1)) halves
    at 20 s (the second half simulated from the first half's last state)."""
    dt = 0.02
    t = np.arange(0, 20.0, dt)
    u = sum(input_signal("doublet", 0.05, t0, 0.5, dt, len(t)) for t0 in range(1, 20, 4))
    first = mlid.LinearModel(C8_F, C8_G, np.eye(4))
    y1, x1 = mlid.simulate(first, t, u[:, None], C8_STD, seed=seed)
    g2 = C8_G.copy()
    g2[2, 0] *= 0.5
    second = mlid.LinearModel(C8_F, g2, np.eye(4), x0=x1[-1])
    y2, _ = mlid.simulate(second, t + 20.0, u[:, None], C8_STD, seed=seed + 1)
    return mlid.FlightData(np.concatenate([t, t + 20.0]), np.concatenate([u, u])[:, None],
                           np.vstack([y1.y, y2.y])), C8_G[2, 0], g2[2, 0]


def test_moving_window_follows_a_change():
    """10 s windows every 1 s: those wholly before the change estimate the
    first M_delta, those wholly after it the second, within 4 sigma each,
    and each is more than 3 of its sigma from the other value: every window
    tells the two apart."""
    data, before, after = changing_record()
    rec = mlid.recursive_frequency_fit(c8_start(), data, window=500, stride=50, **BAND)
    k = rec["names"].index("M_delta")
    est, sig, t_end = rec["estimates"][:, k], rec["sigma"][:, k], rec["t_end"]
    assert len(t_end) == (len(data.t) - 500) // 50 + 1
    pre = t_end < 20.0
    post = t_end - 10.0 + 0.02 >= 20.0
    assert pre.sum() >= 5 and post.sum() >= 5
    assert np.all(np.abs(est[pre] - before) < 4 * sig[pre])
    assert np.all(np.abs(est[post] - after) < 4 * sig[post])
    assert np.all(np.abs(est[pre] - after) > 3 * sig[pre])
    assert np.all(np.abs(est[post] - before) > 3 * sig[post])


def test_bad_input(c8_data):
    with pytest.raises(mlid.InputError, match="window"):
        mlid.recursive_frequency_fit(c8_start(), c8_data, window=2, **BAND)
    with pytest.raises(mlid.InputError, match="F and G"):
        m = mlid.LinearModel(C8_F, C8_G, np.eye(4), free=C8_FREE + ["x0(1)"], names=C8_NAMES)
        mlid.recursive_frequency_fit(m, c8_data, window=200, **BAND)
    with pytest.raises(mlid.InputError, match="states as the outputs"):
        m = mlid.LinearModel(C8_F, C8_G, np.eye(4)[:3], free=C8_FREE)
        mlid.recursive_frequency_fit(m, mlid.FlightData(c8_data.t, c8_data.u, c8_data.y[:, :3]),
                                     window=200, **BAND)
    with pytest.raises(mlid.InputError, match="Nyquist"):
        mlid.recursive_frequency_fit(c8_start(), c8_data, window=200, f_min=1.0, f_max=30.0)
    with pytest.raises(mlid.InputError, match="no ties, input feedback K or delays"):
        m = c8_start()
        m.K = np.ones((1, 4))
        mlid.recursive_frequency_fit(m, c8_data, window=200, **BAND)
