"""The plots (python/mlid/report/plots.py), read back from the figures they return:
channels in the unit the record declared, the ±2σ band from R̂, no line
across a manoeuvre join, lags in s and spectra in Hz up to Nyquist, the
correlation map, modes and Bode magnitude against numpy, the Cramér-Rao
band against the delta method, the Monte Carlo normal curve, files written
whole.  A small short-period model keeps it to a few seconds."""

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


def _record(folder, name, nt, seed):
    """A simulated record written as the file a flight-test rig would give
    (deg where declared) and loaded back; also the file's columns."""
    t, u = _inputs(nt)
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
    return {"rec": rec, "cols": cols, "fit": mlid.fit(_start(), rec),
            "pair": [first, second], "joint": mlid.fit(_start(), [first, second])}


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
    assert b["unit"] == "Hz"
    pick = [0, 75, 150, 225, 299]
    m = res.model
    g = _response(m.F, m.G, m.H, m.D, 2 * np.pi * b["freq"][pick])
    g = g * SCALE_U[None, None, :] / SCALE_Y[None, :, None]     # core to declared units
    np.testing.assert_allclose(b["mag"][pick], 20 * np.log10(np.abs(g)), rtol=1e-10)
    dphase = (b["phase"][pick] - np.degrees(np.angle(g)) + 180) % 360 - 180
    np.testing.assert_allclose(dphase, 0, atol=1e-8)
    # up to the Nyquist frequency of the record, no further
    assert b["freq"][-1] <= 1 / (2 * DT) * (1 + 1e-12)
    fig = plots.bode(res)
    assert isinstance(fig, Figure)
    titles = [ax.get_title(loc="left") for ax in fig.axes if ax.get_title(loc="left")]
    assert titles == ["de → alpha  [deg/deg]", "de → q  [(rad/s)/deg]"]
    assert fig.axes[-1].get_xlabel() == "frequency [Hz]"
    (est,) = [ln for ln in fig.axes[2].get_lines() if ln.get_label() == "estimate"]
    np.testing.assert_allclose(est.get_ydata(), b["mag"][:, 1, 0])


def test_bode_band_is_the_cramer_rao_spread(case):
    """The sampled band against the delta method: half its width is 1.96 sigma
    of the magnitude, sigma^2 = g' C g with g the gradient of |G| [dB] over
    the free parameters (central differences).  300 draws put the 2.5 and
    97.5 percentiles within about 6% (one sd) of a normal's: 20% is 3 sd."""
    res = case["fit"]
    b = plots.bode_data(res)
    m = res.model
    pos = [m.element_names().index(f) for f in FREE]
    assert list(res.names) == [NAMES[f] for f in FREE]
    pick = [60, 150, 240]
    omega = 2 * np.pi * b["freq"][pick]

    def mag(theta):
        x = m.with_theta(theta)
        return 20 * np.log10(np.abs(_response(x.F, x.G, x.H, x.D, omega)[:, :, 0]))

    grads = []
    for k in pos:
        h = 1e-6 * max(abs(m.theta[k]), 1.0)
        e = np.zeros_like(m.theta)
        e[k] = h
        grads.append((mag(m.theta + e) - mag(m.theta - e)) / (2 * h))
    grads = np.array(grads)                                   # (nf, npick, ny)
    sigma = np.sqrt(np.einsum("aij,ab,bij->ij", grads, res.covariance, grads))
    half = 0.5 * (b["mag_band"][1] - b["mag_band"][0])[pick][:, :, 0]
    np.testing.assert_allclose(half / (1.96 * sigma), 1.0, atol=0.2)
    assert np.all(b["mag_band"][0] <= b["mag"]) and np.all(b["mag"] <= b["mag_band"][1])


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
                 plots.s_plane):
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


def test_a_constant_input_gets_no_panel():
    """Issue 42: a constant input ('one', for a bias or trim term) had a
    flat panel of its own in every time figure."""
    t = 0.02 * np.arange(200)
    u = np.column_stack([np.where((t > 1) & (t < 2), 1.0, 0.0), np.ones_like(t)])
    m = mlid.LinearModel([[-1.0, 0.5], [-0.8, -2.0]], [[1.0, 0.05], [0.3, 0.0]], np.eye(2),
                         free=["f(1,1)", "g(1,1)", "g(1,2)"])
    data, _ = mlid.simulate(m, t, u, [0.01, 0.01], seed=2)
    data.input_names = ["de", "one"]
    res = mlid.fit(m, data)
    assert plots.drawn_inputs(data) == [0]
    ylabels = [ax.get_ylabel() for ax in plots.time_histories(data).axes]
    assert not any(lab.startswith("one") for lab in ylabels) and len(ylabels) == 3
    left = plots.fit_overview(res).subfigs[0].axes
    assert len(left) == 3 and left[0].get_ylabel().startswith("de")
