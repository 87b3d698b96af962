"""The plots (python/mlid/report/plots.py), read back from the figures they return:
channels in the unit the record declared, the ±2σ band from R̂, no line
across a manoeuvre join, lags in s and spectra in Hz up to Nyquist, the
residual-input cross-correlation against a direct sum and white noise, the
measured-vs-model R² against numpy, the correlation map, modes and Bode
magnitude against numpy, the Cramér-Rao band drawn as model ± 2σ of the
delta method, the record's points with their random-error bars, the Monte
Carlo normal curve, files written whole.  A small short-period model keeps it to a few seconds."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from scipy.signal import welch  # noqa: E402

import mlid  # noqa: E402
from mlid.design.signals import input_signal  # noqa: E402
from mlid.report import plots  # noqa: E402

DT = 0.05
F0 = np.array([[-1.2, 1.0], [-6.0, -1.8]])       # alpha, q: a short-period pair
G0 = np.array([[-0.15], [-9.0]])
FREE = ["f(1,1)", "f(2,1)", "f(2,2)", "g(1,1)", "g(2,1)"]
NAMES = dict(zip(FREE, ["Z_alpha", "M_alpha", "M_q", "Z_de", "M_de"]))
NOISE = [np.radians(0.1), np.radians(0.3)]       # alpha 0.1 deg, q 0.3 deg/s
# The record as a file declares them: de and alpha in deg, q in rad/s, so that
# the Bode gain q/de carries a conversion and alpha/de does not.
HEADER = "t[s] de[deg] alpha[deg] q[rad/s]\n"
SCALE_U, SCALE_Y = np.array([np.pi / 180]), np.array([np.pi / 180, 1.0])


def _truth():
    return mlid.LinearModel(F0, G0, np.eye(2), free=FREE, names=NAMES)


def _start():
    m = _truth()
    return m.with_theta(np.where(m.free_mask == 1, 1.2 * m.theta, m.theta))


def _inputs(nt, t0=1.0):
    t = np.arange(nt) * DT
    return t, input_signal("3211", np.radians(2.0), t0, 0.6, DT, nt)[:, None]


def _record(folder, name, nt, seed, u=None):
    """A simulated record written as the file a flight-test rig would give
    (deg where declared) and loaded back; also the file's columns.  The
    input a 3211 unless u [rad] is given."""
    t, u = _inputs(nt) if u is None else (np.arange(nt) * DT, u[:, None])
    sim, _ = mlid.simulate(_truth(), t, u, noise_std=NOISE, seed=seed)
    cols = np.column_stack([t, np.degrees(sim.u[:, 0]), np.degrees(sim.y[:, 0]), sim.y[:, 1]])
    path = folder / name
    path.write_text(HEADER + "".join(" ".join(repr(float(v)) for v in r) + "\n" for r in cols))
    return mlid.FlightData.load(path, "t", ["de"], ["alpha", "q"]), cols


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("records")
    rec, cols = _record(folder, "one.dat", 201, seed=4)
    first, _ = _record(folder, "m1.dat", 120, seed=5)
    second, _ = _record(folder, "m2.dat", 90, seed=6)
    # a broadband input (smoothed white noise) for a record's response of high coherence
    noise = np.random.default_rng(3).standard_normal(1200)
    wide, _ = _record(folder, "wide.dat", 1200, seed=7,
                      u=np.radians(2.0) * np.convolve(noise, np.ones(4) / 4, mode="same"))
    return {"rec": rec, "cols": cols, "fit": mlid.fit(_start(), rec),
            "pair": [first, second], "joint": mlid.fit(_start(), [first, second]),
            "wide": mlid.fit(_start(), wide)}


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import matplotlib.pyplot as plt
    plt.close("all")


def _data_lines(ax, n):
    """The lines of ax with n points."""
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) == n]


def _span(ax):
    """(low, high) in data units of the one horizontal span on ax."""
    (p,) = [p for p in ax.patches]
    if hasattr(p, "get_height"):              # a Rectangle (matplotlib >= 3.9)
        return p.get_y(), p.get_y() + p.get_height()
    y = np.asarray(p.get_xy())[:, 1]           # a Polygon
    return y.min(), y.max()


def _written_whole(path):
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in path.parent.iterdir() if p.name.endswith(".tmp")] == []


# -- records and fits ------------------------------------------------------------

def test_time_histories_in_the_declared_units(case, tmp_path):
    rec, cols = case["rec"], case["cols"]
    fig = plots.time_histories(rec, path=tmp_path / "th.png")
    assert isinstance(fig, Figure)
    _written_whole(tmp_path / "th.png")
    axes = fig.axes
    assert [ax.get_ylabel() for ax in axes] == ["de [deg]", "alpha [deg]", "q [rad/s]"]
    assert axes[-1].get_xlabel() == "t [s]"
    for ax, k in zip(axes, (1, 2, 3)):        # the file's own numbers: deg shown as deg
        (line,) = _data_lines(ax, rec.nt)
        np.testing.assert_allclose(line.get_xdata(), cols[:, 0], rtol=0, atol=1e-12)
        np.testing.assert_allclose(line.get_ydata(), cols[:, k], rtol=1e-13, atol=1e-13)


def test_outputs_measured_and_model(case):
    res, rec = case["fit"], case["rec"]
    fig = plots.outputs(res)
    assert isinstance(fig, Figure)
    assert [ax.get_ylabel() for ax in fig.axes] == ["de [deg]", "alpha [deg]", "q [rad/s]"]
    model_deg = [np.degrees(res.yhat[:, 0]), res.yhat[:, 1]]
    for i, ax in enumerate(fig.axes[1:]):
        measured, model = _data_lines(ax, rec.nt)
        assert measured.get_marker() == "." and model.get_label() == "model"
        np.testing.assert_allclose(measured.get_ydata(), case["cols"][:, 2 + i], rtol=1e-13)
        np.testing.assert_allclose(model.get_ydata(), model_deg[i], rtol=1e-13, atol=1e-15)


def test_residual_band_is_two_sigma_of_rhat_in_the_declared_unit(case):
    res = case["fit"]
    fig = plots.residuals(res)
    assert isinstance(fig, Figure)
    assert [ax.get_ylabel() for ax in fig.axes] == ["Δalpha [deg]", "Δq [rad/s]"]
    band = 2 * np.sqrt(np.diag(res.rhat)) / SCALE_Y
    assert np.isclose(band[0], np.degrees(2 * np.sqrt(res.rhat[0, 0])))
    for i, ax in enumerate(fig.axes):
        lo, hi = _span(ax)
        np.testing.assert_allclose([lo, hi], [-band[i], band[i]], rtol=1e-13)
        (line,) = _data_lines(ax, res.data.nt)
        np.testing.assert_allclose(line.get_ydata(), res.residuals[:, i] / SCALE_Y[i],
                                   rtol=1e-13, atol=1e-15)
        outside = np.mean(np.abs(res.residuals[:, i]) > 2 * np.sqrt(res.rhat[i, i]))
        assert ax.get_title(loc="right") == f"{100 * outside:.1f}% outside ±2σ"
    # the overview's right half draws the same band
    right = fig_overview = plots.fit_overview(res, title="deck.nml case 2: middle")
    estimates, *axes = right.subfigs[1].axes      # the estimates where the inputs are
    assert isinstance(fig_overview, Figure) and len(axes) == 2
    np.testing.assert_allclose(_span(axes[0]), [-band[0], band[0]], rtol=1e-13)
    # issue 42: no empty quadrant (the estimates with their sigma) and a title
    (text,) = estimates.texts
    assert text.get_text().split("\n")[0] == "estimate ± 1σ (Cramér-Rao)"
    assert len(text.get_text().split("\n")) == 1 + len(res.names)
    assert f"{res.estimate[0]: .4g} ± {res.sigma[0]:.2g}" in text.get_text()
    assert right.get_suptitle() == "deck.nml case 2: middle"


def test_filter_error_band_is_that_of_the_innovations():
    """For filter error the residuals are innovations and rhat their mean
    covariance B̂, larger than the measurement noise R: the band is named so."""
    t, u = _inputs(201)
    m = mlid.LinearModel(F0, G0, np.eye(2), Gamma=[[1.0], [0.0]], q=[1e-4],
                         r=np.square(NOISE), free=["f(2,1)", "g(2,1)", "q(1)"])
    data, _ = mlid.simulate(m, t, u, seed=3)
    res = mlid.fit(m, data, method="filter_error")
    assert np.all(np.diag(res.rhat) > res.model.r)
    fig = plots.residuals(res)
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["±2σ (B̂)"]
    np.testing.assert_allclose(_span(fig.axes[1]), 2 * np.sqrt(res.rhat[1, 1]) * np.array([-1, 1]))
    fig = plots.outputs(res)
    labels = [t.get_text() for t in fig.axes[1].get_legend().get_texts()]
    assert labels == ["measured", "filter prediction"]
    assert fig.get_suptitle() == "measured outputs and filter predictions"


def test_manoeuvre_joins_are_not_bridged(case):
    first, second = case["pair"]
    res = case["joint"]
    n1, n = first.nt, first.nt + second.nt
    t2 = first.t[-1] + DT + (second.t - second.t[0])
    figs = [plots.time_histories([first, second]), plots.outputs(res), plots.residuals(res),
            plots.fit_overview(res)]
    checked = 0
    for fig in figs:
        for ax in fig.axes:
            if ax.texts and not ax.get_lines():      # the overview's estimates: no time axis
                continue
            assert not _data_lines(ax, n), "a line joins the manoeuvres"
            for line in _data_lines(ax, n + 1):
                x, y = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
                assert np.isnan(x[n1]) and np.isnan(y[n1])
                assert np.all(np.isfinite(x[:n1])) and np.all(np.isfinite(x[n1 + 1:]))
                np.testing.assert_allclose(x[:n1], first.t, atol=1e-12)
                np.testing.assert_allclose(x[n1 + 1:], t2, atol=1e-12)
                checked += 1
            # the join itself is marked, halfway between the two samples
            marks = [ln.get_xdata()[0] for ln in ax.get_lines()
                     if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == ln.get_xdata()[1]]
            assert np.isclose(0.5 * (first.t[-1] + t2[0]), marks).any()
    assert checked == 3 + (1 + 2 * 2) + 2 + (1 + 2 * 2 + 2)     # every channel drawn
    # the measured alpha of each manoeuvre, each in its place, in deg
    alpha = _data_lines(figs[0].axes[1], n + 1)[0].get_ydata()
    np.testing.assert_allclose(alpha[:n1], np.degrees(first.y[:, 0]), rtol=1e-13)
    np.testing.assert_allclose(alpha[n1 + 1:], np.degrees(second.y[:, 0]), rtol=1e-13)


# -- residual statistics ------------------------------------------------------------

def _acf(e, lags):
    e = e - e.mean()
    return np.array([e[k:] @ e[:len(e) - k] for k in range(lags + 1)]) / (e @ e)


def test_autocorrelation_against_lag_in_seconds(case):
    res = case["fit"]
    fig = plots.autocorrelation(res, lags=15)
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    assert fig.axes[-1].get_xlabel() == "lag [s]"
    n = res.data.nt
    for i, ax in enumerate(fig.axes):
        (dots,) = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        tau, rho = dots.get_xdata(), dots.get_ydata()
        np.testing.assert_allclose(np.diff(tau), DT, rtol=1e-12)
        assert tau[0] == 0 and len(tau) == 16
        np.testing.assert_allclose(rho, _acf(res.residuals[:, i], 15), rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(_span(ax), [-1.96 / np.sqrt(n), 1.96 / np.sqrt(n)])


def test_autocorrelation_sums_within_each_manoeuvre(case):
    res = case["joint"]
    n1 = case["pair"][0].nt
    tau, rho, _ = plots.residual_autocorrelation(res, lags=10)
    e = res.residuals - res.residuals.mean(axis=0)
    for i in range(2):
        num = [sum(s[k:] @ s[:len(s) - k] for s in (e[:n1, i], e[n1:, i])) for k in range(11)]
        np.testing.assert_allclose(rho[:, i], np.array(num) / num[0], rtol=1e-12, atol=1e-14)


# -- residual-input correlation and cross-plots ------------------------------------------

def _xcorr(e, u, lags):
    """sum_t e(t + tau) u(t) / sqrt(sum e^2 sum u^2), tau = -lags..lags, one product at a time."""
    e, u = e - e.mean(), u - u.mean()
    n = len(e)
    return np.array([sum(e[t + tau] * u[t] for t in range(max(0, -tau), min(n, n - tau)))
                     for tau in range(-lags, lags + 1)]) / np.sqrt((e @ e) * (u @ u))


def test_residual_input_correlation_against_a_direct_sum(case):
    res, rec = case["fit"], case["rec"]
    tau, r, inputs, band = plots.residual_input_correlation(res, lags=12)
    n = rec.nt
    assert inputs == [0] and r.shape == (25, 2, 1) and band == 1.96 / np.sqrt(n)
    np.testing.assert_allclose(tau, DT * np.arange(-12, 13), rtol=1e-12)
    for i in range(2):
        np.testing.assert_allclose(r[:, i, 0], _xcorr(res.residuals[:, i], rec.u[:, 0], 12),
                                   rtol=1e-10, atol=1e-14)
    fig = plots.residual_input(res, lags=12)
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    for i, ax in enumerate(fig.axes):
        (dots,) = [ln for ln in ax.get_lines() if ln.get_marker() == "o"]
        np.testing.assert_allclose(dots.get_xdata(), tau)
        np.testing.assert_allclose(dots.get_ydata(), r[:, i, 0])
        np.testing.assert_allclose(_span(ax), [-band, band])
        assert ax.get_title(loc="left") == f"Δ{('alpha', 'q')[i]} × de"
    assert fig.axes[-1].get_xlabel().startswith("lag τ [s]")
    assert fig.axes[0].get_ylabel() == "r [-]"
    assert "±1.96/√N (95%)" in [t.get_text() for t in fig.legends[0].get_texts()]
    assert f"N = {n}" in fig._suptitle.get_text()


def test_residual_input_correlation_sums_within_each_manoeuvre(case):
    res = case["joint"]
    first, second = case["pair"]
    n1 = first.nt
    _, r, _, band = plots.residual_input_correlation(res, lags=8)
    e, u = res.residuals, res.data.u[:, 0]
    assert band == 1.96 / np.sqrt(len(e))
    for i in range(2):
        parts = [(e[:n1, i], u[:n1]), (e[n1:, i], u[n1:])]
        num = sum(_xcorr(a, b, 8) * np.sqrt(((a - a.mean()) @ (a - a.mean()))
                                            * ((b - b.mean()) @ (b - b.mean())))
                  for a, b in parts)
        see = sum((a - a.mean()) @ (a - a.mean()) for a, _ in parts)
        suu = sum((b - b.mean()) @ (b - b.mean()) for _, b in parts)
        np.testing.assert_allclose(r[:, i, 0], num / np.sqrt(see * suu), rtol=1e-10, atol=1e-14)


def test_independent_white_noise_stays_within_the_band():
    """Residuals independent of the inputs keep r(tau) within +-1.96/sqrt(N)
    at about 95% of the lags (seeded: 94.9% of 6 x 101 lags here); an
    input-driven residual (a missed gain) does not."""
    rng = np.random.default_rng(7)
    n, lags = 2000, 50
    e, u = rng.standard_normal((n, 3)), rng.standard_normal((n, 2))
    r = plots.cross_correlation(e, u, lags)
    inside = np.mean(np.abs(r) <= 1.96 / np.sqrt(n))
    assert 0.92 <= inside <= 0.98, inside
    missed = e[:, :1] + 0.3 * np.roll(u[:, :1], 3, axis=0)      # 0.3 u(t - 3) left over
    r = plots.cross_correlation(missed, u[:, :1], lags)
    assert abs(r[lags + 3, 0, 0]) > 5 * 1.96 / np.sqrt(n)


def test_the_fitted_case_residuals_are_independent_of_the_input(case):
    """The simulated case's model is right: its residuals stay within the band
    at most lags."""
    _, r, _, band = plots.residual_input_correlation(case["fit"])
    assert np.mean(np.abs(r) <= band) >= 0.85


def test_measured_vs_model_r2_against_numpy(case):
    res, cols = case["fit"], case["cols"]
    r2, fit = plots.fit_statistics(res)
    y, yhat = res.data.y, res.yhat
    for i in range(2):
        want = 1 - np.sum((y[:, i] - yhat[:, i]) ** 2) / np.sum((y[:, i] - y[:, i].mean()) ** 2)
        assert r2[i] == pytest.approx(want, rel=1e-12)
        assert fit[i] == pytest.approx(100 * (1 - np.sqrt(1 - want)), rel=1e-12)
        assert r2[i] == pytest.approx(np.corrcoef(y[:, i], yhat[:, i])[0, 1] ** 2, abs=0.02)
    fig = plots.measured_vs_model(res)
    assert isinstance(fig, Figure) and len(fig.axes) == 2
    model_deg = [np.degrees(yhat[:, 0]), yhat[:, 1]]
    for i, (ax, name, unit) in enumerate(zip(fig.axes, ("alpha", "q"), ("deg", "rad/s"))):
        pts, one = ax.get_lines()
        np.testing.assert_allclose(pts.get_xdata(), cols[:, 2 + i], rtol=1e-13)
        np.testing.assert_allclose(pts.get_ydata(), model_deg[i], rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(one.get_xdata(), one.get_ydata())     # the 1:1 line
        assert ax.get_xlabel() == f"measured {name} [{unit}]"
        assert ax.get_ylabel() == f"model {name} [{unit}]"
        assert ax.get_title(loc="left") == f"{name}: R² = {r2[i]:.3f}, fit {fit[i]:.1f}%"
    assert [t.get_text() for t in fig.legends[0].get_texts()] == [f"samples (N = {len(y)})",
                                                                  "1:1"]


def test_a_fits_figures_are_written_each_under_the_case(case, tmp_path):
    """What mlid run --plots writes of a fit: the overview, the cross-plots,
    the residual-input correlation, and for a linear model the Bode plot,
    each under the case's title."""
    res = case["fit"]
    assert plots.fit_writers(res) == [plots.plot_fit, plots.plot_measured_vs_model,
                                      plots.plot_residual_input, plots.plot_bode]
    paths = plots.plot_fit_figures(res, tmp_path, "case2", "deck.nml case 2: short period")
    assert [p.name for p in paths] == ["case2_fit.png", "case2_measured_vs_model.png",
                                       "case2_residual_input.png", "case2_bode.png"]
    for p in paths:
        _written_whole(p)
    fig = plots._under("deck.nml case 2: short period", plots.residual_input)(res, None)
    assert fig._suptitle.get_text().startswith("deck.nml case 2: short period\nresidual-input")


def test_residual_input_leaves_constant_inputs_out():
    res = _constant_input_fit()
    _, r, inputs, _ = plots.residual_input_correlation(res)
    assert inputs == [0] and r.shape[2] == 1
    assert [ax.get_title(loc="left") for ax in plots.residual_input(res).axes] == \
        ["Δy1 × de", "Δy2 × de"]


def test_spectra_in_hz_to_nyquist_against_scipy(case):
    res = case["fit"]
    fig = plots.spectra(res, segment=64)
    assert isinstance(fig, Figure)
    assert fig.axes[-1].get_xlabel() == "frequency [Hz]"
    assert [ax.get_ylabel() for ax in fig.axes] == ["PSD [deg²/Hz]", "PSD [(rad/s)²/Hz]"]
    nyquist = 1 / (2 * DT)
    for i, ax in enumerate(fig.axes):
        (curve,) = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]
        f, p = curve.get_xdata(), curve.get_ydata()
        assert f[-1] == pytest.approx(nyquist, rel=1e-12)
        assert ax.get_xlim()[1] == pytest.approx(nyquist, rel=1e-12)
        lo, hi = ax.get_ylim()                # labelled powers of ten, not minor ticks
        assert hi / lo >= 10 ** plots.LOG_DECADES * (1 - 1e-9)
        np.testing.assert_allclose(np.diff(f), 1 / (64 * DT), rtol=1e-9)
        # a second implementation: scipy's Welch in the declared unit
        e = res.residuals[:, i] / SCALE_Y[i]
        fw, pw = welch(e - e.mean(), fs=1 / DT, window=np.hanning(64), nperseg=64,
                       noverlap=32, detrend=False)
        np.testing.assert_allclose(f, fw[1:], rtol=1e-12)
        np.testing.assert_allclose(p, pw[1:], rtol=1e-9)
        # the dashed white-noise level of the same variance: 2 R̂ dt, one-sided
        (white,) = [ln for ln in ax.get_lines() if ln.get_linestyle() == "--"]
        assert white.get_ydata()[0] == pytest.approx(2 * res.rhat[i, i] * DT / SCALE_Y[i] ** 2)


def test_spectra_of_several_manoeuvres_keep_the_variance(case):
    """Parseval: the integral of the Welch PSD is the windowed mean square of
    the residuals, averaged over the windows of both manoeuvres."""
    res = case["joint"]
    n1 = case["pair"][0].nt
    f, psd = plots.residual_spectra(res, segment=32)
    w = np.hanning(32)
    e = res.residuals / SCALE_Y
    for i in range(2):
        ms = [np.sum((w * (s[a:a + 32] - s.mean())) ** 2) / np.sum(w ** 2)
              for s in (e[:n1, i], e[n1:, i]) for a in range(0, len(s) - 31, 16)]
        assert np.sum(psd[:, i]) * (f[1] - f[0]) == pytest.approx(np.mean(ms), rel=1e-12)


# -- estimates ------------------------------------------------------------------------

def test_correlation_map_is_the_covariance_normalised(case):
    res = case["fit"]
    fig = plots.correlation(res)
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    (im,) = ax.get_images()
    sd = np.sqrt(np.diag(res.covariance))
    np.testing.assert_allclose(im.get_array(), res.covariance / np.outer(sd, sd), rtol=1e-12)
    assert im.get_clim() == (-1, 1)
    assert [t.get_text() for t in ax.get_xticklabels()] == list(res.names)
    assert [t.get_text() for t in ax.get_yticklabels()] == list(res.names)
    values = np.array([float(t.get_text()) for t in ax.texts]).reshape(5, 5)
    np.testing.assert_allclose(values, res.covariance / np.outer(sd, sd), atol=0.005)
    assert fig.axes[1].get_ylabel() == "correlation [-]"      # the colour bar


# -- linear models -----------------------------------------------------------------------

def test_modes_are_the_eigenvalues_of_the_identified_f(case):
    res = case["fit"]
    F = res.model.F
    (mode,) = plots.modes(res.model)                    # one complex pair
    wn = np.sqrt(np.linalg.det(F))                      # 2x2: wn^2 = det, 2 zeta wn = -trace
    assert mode["omega_n"] == pytest.approx(wn, rel=1e-12)
    assert mode["zeta"] == pytest.approx(-np.trace(F) / (2 * wn), rel=1e-12)
    assert mode["f_n"] == pytest.approx(wn / (2 * np.pi), rel=1e-12)
    lam = np.linalg.eigvals(F)
    assert mode["eigenvalue"] == pytest.approx(lam[lam.imag > 0][0], rel=1e-12)
    assert mode["time_constant"] is None
    fig = plots.s_plane(res)
    assert isinstance(fig, Figure)
    (marks,) = [ln for ln in fig.axes[0].get_lines() if ln.get_marker() == "x"]
    got = np.sort_complex(np.asarray(marks.get_xdata()) + 1j * np.asarray(marks.get_ydata()))
    np.testing.assert_allclose(got, np.sort_complex(lam), rtol=1e-12)


def test_modes_close_the_state_feedback_and_refuse_nonlinear_models():
    K = np.array([[0.0, 0.2]])                           # pitch damper: de += 0.2 q
    m = mlid.LinearModel(F0, G0, np.eye(2), K=K)
    lam = np.linalg.eigvals(F0 + G0 @ K)
    (mode,) = plots.modes(m)
    assert mode["omega_n"] == pytest.approx(abs(lam[0]), rel=1e-12)
    assert mode["zeta"] == pytest.approx(-lam[0].real / abs(lam[0]), rel=1e-12)
    real = plots.modes(mlid.LinearModel([[-2.0, 0.0], [0.0, -0.5]], [[1.0], [1.0]], np.eye(2)))
    assert [r["time_constant"] for r in real] == pytest.approx([2.0, 0.5])
    from test_hfb320 import COEFFS, _hfb_like
    with pytest.raises(mlid.InputError, match="linear model"):
        plots.modes(_hfb_like(COEFFS))


def _response(F, G, H, D, omega):
    """H (jw I - F)^-1 G + D, one frequency at a time."""
    return np.array([H @ np.linalg.inv(1j * w * np.eye(len(F)) - F) @ G + D for w in omega])


def test_bode_magnitude_and_phase_against_numpy(case):
    res = case["fit"]
    b = plots.bode_data(res)
    assert b["unit"] == "Hz" and b["inputs"] == [0]
    pick = [0, 75, 150, 225, 299]
    m = res.model
    g = _response(m.F, m.G, m.H, m.D, 2 * np.pi * b["freq"][pick])
    g = g * SCALE_U[None, None, :] / SCALE_Y[None, :, None]     # core to declared units
    np.testing.assert_allclose(b["mag"][pick], 20 * np.log10(np.abs(g)), rtol=1e-10)
    dphase = (b["phase"][pick] - np.degrees(np.angle(g)) + 180) % 360 - 180
    np.testing.assert_allclose(dphase, 0, atol=1e-8)
    # to the Nyquist frequency of the record (the record's response reaches it), no further
    np.testing.assert_allclose(b["freq"][-1], 1 / (2 * DT), rtol=1e-12)
    fig = plots.bode(res)
    assert isinstance(fig, Figure)
    titles = [ax.get_title(loc="left") for ax in fig.axes if ax.get_title(loc="left")]
    assert titles == ["de → alpha  [deg/deg]", "de → q  [(rad/s)/deg]"]
    assert fig.axes[-1].get_xlabel() == "frequency [Hz]"
    assert [ax.get_ylabel() for ax in fig.axes] == ["gain [dB]", "phase [deg]"] * 2
    (est,) = [ln for ln in fig.axes[2].get_lines() if ln.get_label() == "identified model"]
    np.testing.assert_allclose(est.get_ydata(), b["mag"][:, 1, 0])
    rad = plots.bode_data(res, hz=False, measured=False)
    assert rad["unit"] == "rad/s" and rad["measured"] is None
    assert rad["freq"][-1] <= np.pi / DT * (1 + 1e-12)


def _band(ax):
    """The one filled band on ax."""
    (band,) = [c for c in ax.collections if c.get_label() == "model ±2σ (Cramér-Rao)"]
    return band


def _band_edges(ax):
    """(x, lower, upper) of the one filled band on ax (fill_between's polygon)."""
    band = _band(ax)
    v = band.get_paths()[0].vertices
    n = (len(v) - 3) // 2
    lower, upper = v[1:n + 1], v[n + 2:2 * n + 2][::-1]
    np.testing.assert_array_equal(lower[:, 0], upper[:, 0])
    return lower[:, 0], lower[:, 1], upper[:, 1]


def test_bode_band_is_two_cramer_rao_sigma_drawn_and_stated(case):
    """The band is the model's ±2σ (BAND_SIGMAS) with σ of the delta method,
    σ² = g' C g, g the gradient of the gain [dB] or phase [deg] over the free
    parameters (central differences here, the core's analytic derivatives
    in the plot); the figure draws exactly those edges, says ±2σ in its
    legend, and states the widest half-width above each axis."""
    assert plots.BAND_SIGMAS == 2
    res = case["fit"]
    b = plots.bode_data(res)
    m = res.model
    pos = [m.element_names().index(f) for f in FREE]
    assert list(res.names) == [NAMES[f] for f in FREE]
    pick = [60, 150, 240]
    omega = 2 * np.pi * b["freq"][pick]

    def response(theta):
        x = m.with_theta(theta)
        return _response(x.F, x.G, x.H, x.D, omega)[:, :, 0]

    grads = []
    for k in pos:
        h = 1e-6 * max(abs(m.theta[k]), 1.0)
        e = np.zeros_like(m.theta)
        e[k] = h
        ratio = response(m.theta + e) / response(m.theta - e)     # no wrap of the phase
        grads.append(np.concatenate([20 * np.log10(np.abs(ratio)),
                                     np.degrees(np.angle(ratio))], axis=1) / (2 * h))
    grads = np.array(grads)                                   # (nf, npick, 2 ny)
    sigma = np.sqrt(np.einsum("aij,ab,bij->ij", grads, res.covariance, grads))
    np.testing.assert_allclose(b["mag_sigma"][pick][:, :, 0], sigma[:, :2], rtol=1e-4)
    np.testing.assert_allclose(b["phase_sigma"][pick][:, :, 0], sigma[:, 2:], rtol=1e-4)
    for key in ("mag", "phase"):
        np.testing.assert_allclose(b[f"{key}_band"], b[key] + np.array([-2, 2])[:, None, None, None]
                                   * b[f"{key}_sigma"], rtol=1e-13, atol=1e-12)
    fig = plots.bode(res)
    for k, ax in enumerate(fig.axes):
        i, key, unit = k // 2, ("mag", "phase")[k % 2], ("dB", "deg")[k % 2]
        x, lo, hi = _band_edges(ax)
        np.testing.assert_allclose(x, b["freq"], rtol=1e-13)
        np.testing.assert_allclose(lo, b[key][:, i, 0] - 2 * b[f"{key}_sigma"][:, i, 0],
                                   rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(hi, b[key][:, i, 0] + 2 * b[f"{key}_sigma"][:, i, 0],
                                   rtol=1e-12, atol=1e-12)
        band = _band(ax)
        assert band.get_alpha() >= 0.2 and band.get_linewidth() > 0      # seen, and edged
        assert ax.get_title(loc="right") == \
            f"±2σ ≤ {2 * b[f'{key}_sigma'][:, i, 0].max():.2g} {unit}"
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "model ±2σ (Cramér-Rao)" in legend and "measured ±2σ (random error)" in legend


def test_bode_measured_points_have_their_random_error_bars(case):
    """The record's response (mlid.record_response: Bendat & Piersol's σ)
    as points with ±2σ error bars where the coherence is 0.6 or more,
    in the declared units (alpha/de in deg/deg: the core's dB), and hollow
    points without bars below; the same in bode_measured."""
    res = case["wide"]
    rec = res.data
    b = plots.bode_data(res)
    fig = plots.bode(res)
    shift = 20 * np.log10(SCALE_U[0] / SCALE_Y)
    for i, name in enumerate(("alpha", "q")):
        r = mlid.record_response(rec, "de", name)
        good = r.coherence >= plots.COHERENCE_SHOWN
        assert 3 <= good.sum() < len(good)               # both kinds are drawn
        for ax, y, s in ((fig.axes[2 * i], r.gain + shift[i], r.sigma_gain),
                         (fig.axes[2 * i + 1], None, r.sigma_phase)):
            (bars,) = ax.containers
            points, _, (lines,) = bars
            np.testing.assert_allclose(points.get_xdata(), r.frequency[good], rtol=1e-13)
            if y is not None:
                np.testing.assert_allclose(points.get_ydata(), y[good], rtol=1e-12)
            else:                    # the phase, moved by whole turns onto the model's branch
                turns = (np.asarray(points.get_ydata()) - r.phase[good]) / 360
                np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)
            seg = np.array(lines.get_segments())
            np.testing.assert_allclose(seg[:, 1, 1] - seg[:, 0, 1], 4 * s[good], rtol=1e-12)
            (hollow,) = [ln for ln in ax.get_lines() if ln.get_mfc() == "none"]
            np.testing.assert_allclose(hollow.get_xdata(), r.frequency[~good], rtol=1e-13)
        np.testing.assert_allclose(b["measured"]["mag_sigma"][:, i, 0], r.sigma_gain)
    one = plots.bode_measured(res, "de", "q")
    r = mlid.record_response(rec, "de", "q")
    good = r.coherence >= plots.COHERENCE_SHOWN
    (bars,) = one.axes[0].containers
    seg = np.array(bars[2][0].get_segments())
    np.testing.assert_allclose(seg[:, 1, 1] - seg[:, 0, 1], 4 * r.sigma_gain[good], rtol=1e-12)
    x, lo, hi = _band_edges(one.axes[0])
    mod = mlid.model_response(res, x, "de", "q")
    np.testing.assert_allclose(hi - lo, 4 * mod.sigma_gain, rtol=1e-10, atol=1e-12)


def test_bode_leaves_constant_inputs_out():
    res = _constant_input_fit()
    b = plots.bode_data(res)
    assert b["inputs"] == [0] and b["mag"].shape[2] == 1
    fig = plots.bode(res)
    assert all(ax.get_title(loc="left").startswith("de") for ax in fig.axes
               if ax.get_title(loc="left"))


# -- Monte Carlo ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def mc():
    t, u = _inputs(201)
    return mlid.monte_carlo(_truth(), _start(), t, u, noise_std=NOISE, runs=40, seed=1,
                            progress=False)


def _normal_curve(ax):
    (line,) = [ln for ln in ax.get_lines() if ln.get_label().startswith("N(truth")]
    return np.asarray(line.get_xdata()), np.asarray(line.get_ydata())


def test_monte_carlo_normal_curve_has_the_cramer_rao_sigma(mc, tmp_path):
    ok = mc["status"] == 0
    assert ok.all()
    sigma = np.sqrt(np.diag(np.linalg.inv(mc["information"].mean(axis=0))))
    units = ["1/s", "1/s2", "1/s", "1/s", "1/s2"]
    fig = plots.monte_carlo_histograms(mc, units=units, path=tmp_path / "mc.png")
    assert isinstance(fig, Figure)
    _written_whole(tmp_path / "mc.png")
    assert len(fig.axes) == 5
    for k, ax in enumerate(fig.axes):
        x, y = _normal_curve(ax)
        s, truth = sigma[k], mc["truth"][k]
        np.testing.assert_allclose(y, np.exp(-0.5 * ((x - truth) / s) ** 2)
                                   / (s * np.sqrt(2 * np.pi)), rtol=1e-9)
        assert ax.get_xlabel() == f"{mc['names'][k]} [{units[k]}]"
        assert f"CR σ {s:.3g}" in ax.get_title()
        heights = np.array([p.get_height() for p in ax.patches])
        widths = np.array([p.get_width() for p in ax.patches])
        assert np.sum(heights * widths) == pytest.approx(1.0)     # a density
    # the sigma given is the one drawn
    given = 2 * sigma
    fig = plots.monte_carlo_histograms(mc, cr_sigma=given)
    x, y = _normal_curve(fig.axes[0])
    assert y.max() == pytest.approx(1 / (given[0] * np.sqrt(2 * np.pi)), rel=1e-3)


def test_monte_carlo_leaves_out_failed_runs(mc):
    bad = {**mc, "status": mc["status"].copy(), "estimates": mc["estimates"].copy()}
    bad["status"][0] = 3
    bad["estimates"][0] = 1e6
    fig = plots.monte_carlo_histograms(bad)
    ax = fig.axes[0]
    assert max(p.get_x() + p.get_width() for p in ax.patches) < 1e3
    assert any("39 runs" == t.get_text() for t in ax.get_legend().get_texts())
    bad["status"][:] = 1
    with pytest.raises(mlid.InputError, match="no Monte Carlo run succeeded"):
        plots.monte_carlo_histograms(bad)


# -- files ----------------------------------------------------------------------------------

def test_files_are_written_whole_or_not_at_all(case, tmp_path):
    path = tmp_path / "fig.nosuchformat"
    path.write_text("old\n")
    with pytest.raises(ValueError):                 # matplotlib knows no such format
        plots.residuals(case["fit"], path=path)
    assert path.read_text() == "old\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.nosuchformat"]
    out = plots.plot_fit(case["fit"], tmp_path / "deep" / "er", "case1")
    assert out == tmp_path / "deep" / "er" / "case1_fit.png"
    _written_whole(out)
    for make in (plots.autocorrelation, plots.spectra, plots.correlation, plots.bode,
                 plots.s_plane, plots.residual_input, plots.measured_vs_model):
        target = tmp_path / f"{make.__name__}.png"
        assert isinstance(make(case["fit"], path=target), Figure)
        _written_whole(target)


def test_windows_of_one_flight_are_drawn_on_their_own_time(case):
    """Issue 42: the second window of a multi-window fit was drawn on the
    first one's time axis (140-170 s shown at 110-140 s); windows that
    follow one another keep their own times, the join still broken."""
    first, _ = case["pair"]
    later = mlid.FlightData(first.t + first.t[-1] + 10.0, first.u, first.y,
                            first.input_names, first.output_names,
                            input_units=first.input_units, output_units=first.output_units)
    res = mlid.fit(_start(), [first, later])
    n1 = first.nt
    for fig in (plots.outputs(res), plots.fit_overview(res)):
        x = np.asarray(_data_lines(fig.axes[0], 2 * n1 + 1)[0].get_xdata())
        np.testing.assert_allclose(x[:n1], first.t, atol=1e-12)
        assert np.isnan(x[n1])
        np.testing.assert_allclose(x[n1 + 1:], later.t, atol=1e-12)


def _constant_input_fit():
    """A fit whose second input is the constant 'one' of a bias term."""
    t = 0.02 * np.arange(200)
    u = np.column_stack([np.where((t > 1) & (t < 2), 1.0, 0.0), np.ones_like(t)])
    m = mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], [[1.0, 0.05], [0.3, 0.0]], np.eye(2),
                         free=["f(1,1)", "g(1,1)", "g(1,2)"])
    data, _ = mlid.simulate(m, t, u, [0.01, 0.01], seed=2)
    data.input_names = ["de", "one"]
    return mlid.fit(m, data)


def test_a_constant_input_gets_no_panel():
    """Issue 42: a constant input ('one', for a bias or trim term) had a
    flat panel of its own in every time figure."""
    res = _constant_input_fit()
    data = res.data
    assert plots.drawn_inputs(data) == [0]
    ylabels = [ax.get_ylabel() for ax in plots.time_histories(data).axes]
    assert not any(lab.startswith("one") for lab in ylabels) and len(ylabels) == 3
    left = plots.fit_overview(res).subfigs[0].axes
    assert len(left) == 3 and left[0].get_ylabel().startswith("de")


def test_mlid_run_plots_writes_every_figure_of_a_fit(tmp_path):
    """`mlid run --plots` writes each figure of fit_writers for the fit
    (case 2 of a linear model) and names each on stdout."""
    import subprocess

    from conftest import BIN, two_case_deck
    (tmp_path / "d.nml").write_text(two_case_deck())
    run = subprocess.run([str(BIN / "mlid"), "run", "d.nml", "--plots", "p"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    names = ["case2_fit.png", "case2_measured_vs_model.png", "case2_residual_input.png",
             "case2_bode.png"]
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == sorted(names)
    said = [ln.split("plot: ")[1] for ln in run.stdout.splitlines() if "plot: " in ln]
    assert [Path(s).name for s in said] == names
    for name in names:
        _written_whole(tmp_path / "p" / name)


def test_frequency_fit_figure_draws_each_manoeuvre_on_its_own(case):
    """A frequency-domain fit of two manoeuvres: each one's transforms a line
    of its own, rising in frequency (sorted together they zigzagged
    between the two), each output named with its unit (core unit times s)."""
    res = mlid.fit(_start(), case["pair"], method="frequency_output_error", f_min=0.1,
                   f_max=2.0, n_freq=30)
    fig = plots.frequency_overview(res)
    assert [ax.get_ylabel() for ax in fig.axes] == ["|Y alpha| [rad·s]", "|Y q| [(rad/s)·s]"]
    assert fig.axes[-1].get_xlabel() == "frequency [Hz]"
    for i, ax in enumerate(fig.axes):
        model = [ln for ln in ax.get_lines() if ln.get_label().startswith("model")]
        assert [ln.get_label() for ln in model] == ["model (manoeuvre 1)", "model (manoeuvre 2)"]
        for k, ln in enumerate(model):
            f = np.asarray(ln.get_xdata())
            assert len(f) == 30 and np.all(np.diff(f) > 0)
            np.testing.assert_allclose(ln.get_ydata(), np.abs(res.zhat[30 * k:30 * (k + 1), i]))
