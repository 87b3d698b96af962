"""Frequency responses (mlid_freq_response) and transfer-function fits
(mlid_transfer_fit): a record's response against the true one within its
stated random error, the model's response and its derivatives against
numpy and finite differences, the Cramer-Rao bands against the delta
method done independently, LOES fits recovering known transfer functions,
the Bode plot and the ``mlid bode`` command."""

import subprocess

import numpy as np
import pytest
from matplotlib.figure import Figure

import mlid
from mlid.report import plots
from mlid._bridge import api as _api, call_handle, put, results
from mlid.frequency.responses import FrequencyResponse, free_map, transfer_mismatch
from conftest import BIN

# A short-period-like pair (alpha, q) driven by the elevator: poles -2.1 +- 3.35j.
F = np.array([[-1.2, 1.0], [-12.0, -3.0]])
G = np.array([[-0.1], [-15.0]])
DT, NT, SEGMENT = 0.01, 40000, 2048
BAND = (0.2, 3.0)                  # Hz: f dt <= 0.03, so the input's linear hold
                                   # changes the sampled response by < 0.03 dB


def _truth():
    return mlid.LinearModel(F, G, np.eye(2), free=["f(1,1)", "f(1,2)", "f(2,1)", "f(2,2)",
                                                   "g(1,1)", "g(2,1)"])


def _record(noise_std, seed=1):
    t = np.arange(NT) * DT
    u = np.random.default_rng(3).standard_normal(NT) * 0.02      # white elevator noise
    data, _ = mlid.simulate(_truth(), t, u, noise_std=noise_std, seed=seed,
                            input_names=["de"], output_names=["alpha", "q"])
    return data


def _numpy_response(F, G, H, D, f):
    return np.array([H @ np.linalg.solve(2j * np.pi * x * np.eye(len(F)) - F, G) + D for x in f])


def test_record_response_without_noise_has_coherence_near_one():
    r = mlid.record_response(_record(None), "de", "q", segment=SEGMENT)
    assert r.averages == (NT - SEGMENT) // (SEGMENT // 2) + 1
    np.testing.assert_allclose(r.frequency[:3], np.arange(1, 4) / (SEGMENT * DT))
    band = r.band(*BAND)
    # what keeps it from 1 is the system's memory across segment edges (leakage)
    assert r.coherence[band].min() > 0.98
    truth = _numpy_response(F, G, np.eye(2), np.zeros((2, 1)), r.frequency[band])[:, 1, 0]
    np.testing.assert_allclose(r.gain[band], 20 * np.log10(abs(truth)), atol=0.3)


def test_record_response_within_its_random_error():
    """With measurement noise the coherence drops and the estimate scatters
    about the true response by Bendat & Piersol's random error: at the points
    of coherence >= 0.6 the normalized errors z have an rms near 1 and most
    lie within 2 sigma.  The bounds allow for ~25 points correlated by the
    window's overlap of neighbouring bins (a 2-sigma fraction of 0.954 has an
    sd near 0.06 there; 0.75 is three below)."""
    clean = mlid.record_response(_record(None), "de", "q", segment=SEGMENT)
    r = mlid.record_response(_record([0.01, 0.03]), "de", "q", segment=SEGMENT)
    band = r.band(*BAND)
    assert r.coherence[band].mean() < clean.coherence[band].mean() - 0.2
    keep = r.band(*BAND, min_coherence=0.6)
    assert keep.sum() >= 15
    true = mlid.model_response(_truth(), r.frequency[keep], "u1", "y2")
    zg = (r.gain[keep] - true.gain) / r.sigma_gain[keep]
    dp = (r.phase[keep] - true.phase + 180) % 360 - 180     # phase is defined mod 360
    zp = dp / r.sigma_phase[keep]
    for z in (zg, zp):
        assert 0.6 < np.sqrt(np.mean(z**2)) < 1.6
        assert np.mean(abs(z) < 2) >= 0.75
        assert abs(z).max() < 4.5
    # sigma as the formula says: eps = sqrt(1 - g2) / (|g| sqrt(2 nd))
    eps = np.sqrt(1 - r.coherence) / np.sqrt(r.coherence * 2 * r.averages)
    np.testing.assert_allclose(r.sigma_gain, 20 / np.log(10) * eps, rtol=1e-12)
    np.testing.assert_allclose(r.sigma_phase, np.degrees(eps), rtol=1e-12)


def test_record_response_spectra_are_densities():
    """The one-sided input density of white noise of variance s^2 sampled at
    dt is 2 s^2 dt; averaged over the band it is that within a few percent."""
    r = mlid.record_response(_record(None), "de", "q", segment=SEGMENT)
    mid = r.band(1.0, 40.0)
    assert r.input_spectrum[mid].mean() == pytest.approx(2 * 0.02**2 * DT, rel=0.03)


def test_record_response_refuses_bad_input():
    d = _record(None)
    with pytest.raises(mlid.InputError, match="segments of"):
        mlid.record_response(d, 0, 0, segment=NT + 1)
    with pytest.raises(mlid.InputError, match="no output channel 'r'"):
        mlid.record_response(d, 0, "r")
    with pytest.raises(mlid.InputError, match="overlap"):
        mlid.record_response(d, 0, 0, overlap=1.0)


def _feedback_model():
    """Two inputs, three outputs, feedback K, D, input and output delays and
    a tie: every path of the analytic derivatives."""
    G2 = np.column_stack([G, [0.3, -2.0]])
    H3 = np.array([[1.0, 0.0], [0.2, 1.0], [0.5, 0.1]])
    D3 = np.array([[0.0, 0.0], [0.4, 0.0], [0.1, -0.2]])
    m = mlid.LinearModel(F, G2, H3, D=D3,
                         free=["f(1,1)", "f(2,1)", "f(2,2)", "g(2,1)", "g(1,2)", "h(2,1)",
                               "h(3,2)", "d(2,1)", "d(3,2)", "k(2,1)", "k(1,2)", "udelay(1)",
                               "udelay(2)", "delay(2)"],
                         ties={"f(1,2)": "0.5 + 2*f(1,1)"})
    return m.with_theta(_set(m, {"k(1,1)": 0.3, "k(1,2)": -0.2, "k(2,1)": 0.1,
                                 "udelay(1)": 0.03, "udelay(2)": 0.01, "delay(2)": 0.02}))


def _set(model, values):
    theta = model.theta
    names = model.element_names()
    for k, v in values.items():
        theta[names.index(k)] = v
    return model.tied(theta)


def test_model_response_against_numpy_with_feedback_and_delays():
    m = _feedback_model()
    f = np.logspace(-1, 1, 7)
    A = m.F + m.G @ m.K
    C = m.H + m.D @ m.K
    w = 2 * np.pi * f
    for i, j in ((0, 1), (1, 2), (1, 0)):
        r = mlid.model_response(m, f, i, j)
        direct = _numpy_response(A, m.G, C, m.D, f)[:, j, i] * np.exp(
            -1j * w * (m.udelay[i] + m.delay[j]))
        np.testing.assert_allclose(r.response, direct, rtol=1e-12)
        np.testing.assert_allclose(r.gain, 20 * np.log10(abs(direct)), rtol=1e-12)
        dphase = (r.phase - np.degrees(np.angle(direct)) + 180) % 360 - 180
        np.testing.assert_allclose(dphase, 0, atol=1e-9)
        assert np.all(abs(np.diff(r.phase)) < 180)          # unwrapped


def test_model_response_derivatives_against_finite_differences():
    m = _feedback_model()
    f = np.array([0.05, 0.4, 2.0, 9.0])
    free = m.free_indices()                  # the order of free, as the derivatives
    terms = m.tie_terms()
    for i, j in ((0, 1), (1, 2)):
        r = mlid.model_response(m, f, i, j)
        for c, k in enumerate(free):
            h = 1e-6 * max(1.0, abs(m.theta[k]))
            out = []
            for sign in (1, -1):
                theta = m.theta
                theta[k] += sign * h
                out.append(mlid.model_response(m.with_theta(m.tied(theta, terms)), f, i,
                                               j).response)
            fd = (out[0] - out[1]) / (2 * h)
            np.testing.assert_allclose(r.derivatives[:, c], fd, rtol=1e-6,
                                       atol=1e-7 * max(abs(fd).max(), abs(r.response).max()),
                                       err_msg=f"{m.element_names()[k]} ({i}, {j})")


def test_model_response_refuses_a_nonlinear_model():
    from test_hfb320 import COEFFS, _hfb_like
    with pytest.raises(mlid.InputError, match="must be linear"):
        mlid.model_response(_hfb_like(COEFFS), [1.0])


@pytest.fixture(scope="module")
def fitted():
    """A fit to 3000 samples of the record, the elevator declared in deg
    (the core's values stay in rad) and q shown in rad/s."""
    d = _record([0.01, 0.03])
    data = mlid.FlightData(d.t, d.u, d.y, d.input_names, d.output_names, input_units=["rad"],
                           output_units=["rad", "rad/s"],
                           input_display=[("deg", np.pi / 180, 0.0)],
                           output_display=[("deg", np.pi / 180, 0.0), ("rad/s", 1.0, 0.0)])
    start = _truth().with_theta(_truth().theta * 0.8)
    return mlid.fit(start, data.head(3000))


def test_model_bands_are_the_delta_method_of_the_cramer_rao_covariance(fitted):
    """sigma^2 = g' P g with g from central differences of gain and phase
    over the free parameters, independently of the core's derivatives."""
    res = fitted
    f = np.array([0.1, 0.5, 1.0, 3.0])
    r = mlid.model_response(res, f, "de", "q")
    assert (r.input_name, r.output_name) == ("de", "q")
    m = res.model
    grads = []
    for k in m.free_indices():                # the covariance's order
        h = 1e-6 * max(1.0, abs(m.theta[k]))
        out = []
        for sign in (1, -1):
            theta = m.theta
            theta[k] += sign * h
            x = mlid.model_response(m.with_theta(theta), f, 0, 1)
            out.append(np.array([x.gain, x.phase]))
        grads.append((out[0] - out[1]) / (2 * h))
    grads = np.array(grads)                                  # (nf, 2, nfreq)
    sigma = np.sqrt(np.einsum("aij,ab,bij->ij", grads, res.covariance, grads))
    np.testing.assert_allclose(r.sigma_gain, sigma[0], rtol=1e-5)
    np.testing.assert_allclose(r.sigma_phase, sigma[1], rtol=1e-5)
    assert np.all(r.sigma_gain > 0)


def test_free_map_of_several_manoeuvres_skips_their_own_entries():
    data = _record([0.01, 0.03])
    res = mlid.fit(_truth().with_free(_truth().free + ["x0(1)"]),
                   [data.head(1500), data.head(2000)])
    jac = free_map(res)
    assert jac.shape == (res.model.theta.size, len(res.names))
    assert jac.sum() == 6                          # the six shared model parameters
    r = mlid.model_response(res, [0.5], "de", "q")
    assert r.sigma_gain[0] > 0


def _tf_response(b, a, tau, f, gain_noise=0.0, phase_noise=0.0, seed=0):
    s = 2j * np.pi * f
    T = np.polyval(b, s) / np.polyval(a, s) * np.exp(-tau * s)
    rng = np.random.default_rng(seed)
    return FrequencyResponse(
        frequency=f, gain=20 * np.log10(abs(T)) + gain_noise * rng.standard_normal(f.size),
        phase=np.degrees(np.unwrap(np.angle(T))) + phase_noise * rng.standard_normal(f.size),
        sigma_gain=0 * f, sigma_phase=0 * f, input_name="de", output_name="q",
        input_unit="rad", output_unit="rad/s", source="test")


# q/de = K (s + 1/T_t2) e^-ts / (s^2 + 2 z w s + w^2): K 3, 1/T_t2 1.5, z 0.35, w 4, t 0.08
PITCH_B, PITCH_A, PITCH_TAU = [3.0, 4.5], [1.0, 2.8, 16.0], 0.08


def test_transfer_fit_recovers_an_exact_response():
    f = np.logspace(-1, 1, 60)
    fit = mlid.fit_transfer_function(_tf_response(PITCH_B, PITCH_A, PITCH_TAU, f), 1, 2)
    assert fit.names == ["b0", "b1", "a0", "a1", "tau"]
    np.testing.assert_allclose(fit.numerator, PITCH_B, rtol=1e-8)
    np.testing.assert_allclose(fit.denominator, PITCH_A, rtol=1e-8)
    assert fit.delay == pytest.approx(PITCH_TAU, rel=1e-8)
    assert fit.mismatch < 1e-12
    (zeta, wn), = fit.second_order()
    assert (zeta, wn) == (pytest.approx(0.35, rel=1e-8), pytest.approx(4.0, rel=1e-8))
    assert "pole pair: zeta 0.3500" in fit.report()


def test_transfer_fit_with_a_fixed_integrator():
    """theta/de: the pitch form over s (a0 held at 0)."""
    f = np.logspace(-1, 1, 50)
    a = np.polymul(PITCH_A, [1.0, 0.0])
    fit = mlid.fit_transfer_function(_tf_response(PITCH_B, a, PITCH_TAU, f), 1, 3,
                                     fixed={"a0": 0.0})
    assert fit.value("a0") == 0.0 and fit.sigma[fit.names.index("a0")] == 0.0
    np.testing.assert_allclose(fit.denominator, a, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(fit.numerator, PITCH_B, rtol=1e-8)



def test_transfer_fit_holds_a_fixed_delay_at_its_value():
    """A fixed tau is the value given, not the delay search's start."""
    f = np.logspace(-1, 1, 50)
    fit = mlid.fit_transfer_function(_tf_response(PITCH_B, PITCH_A, PITCH_TAU, f), 1, 2,
                                     fixed={"tau": PITCH_TAU})
    assert fit.delay == PITCH_TAU
    np.testing.assert_allclose(fit.numerator, PITCH_B, rtol=1e-8)
    np.testing.assert_allclose(fit.denominator, PITCH_A, rtol=1e-8)

def test_transfer_fit_of_a_noisy_response_within_its_sigma():
    """Gain noise 0.2 dB and phase noise 0.2/sqrt(0.01745) deg weigh alike in
    the mismatch, so its residuals are homoscedastic and the least-squares
    sigma s^2 (J'J)^-1 is the estimates' spread: each within 3.5 sigma, and
    s^2 = mismatch / (2n - np) near 20/n 0.2^2."""
    f = np.logspace(-1, 1, 80)
    sg = 0.2
    resp = _tf_response(PITCH_B, PITCH_A, PITCH_TAU, f, sg, sg / np.sqrt(0.01745), seed=5)
    fit = mlid.fit_transfer_function(resp, 1, 2)
    truth = np.array([4.5, 3.0, 16.0, 2.8, PITCH_TAU])
    z = (fit.estimate - truth) / fit.sigma
    assert np.all(abs(z) < 3.5), z
    s2 = fit.mismatch / (2 * f.size - 5)
    assert s2 == pytest.approx(20 / f.size * sg**2, rel=0.3)


def test_transfer_mismatch_is_the_handling_qualities_cost():
    f = np.logspace(-0.5, 0.8, 40)
    meas = _tf_response(PITCH_B, PITCH_A, PITCH_TAU, f, 0.5, 3.0, seed=2)
    coh = np.linspace(0.3, 1.0, f.size)
    meas.coherence = coh
    for weighted in (False, True):
        fit = mlid.fit_transfer_function(meas, 1, 2, coherence_weighting=weighted)
        model = fit.response(f)
        dg = model.gain - meas.gain
        dp = (model.phase - meas.phase + 180) % 360 - 180
        w = (1.58 * (1 - np.exp(-coh)))**2 if weighted else 1.0
        cost = 20 / f.size * np.sum(w * (dg**2 + 0.01745 * dp**2))
        assert fit.mismatch == pytest.approx(cost, rel=1e-10)
        assert transfer_mismatch(fit, meas, weighted) == pytest.approx(cost, rel=1e-10)


def test_transfer_residual_jacobian_against_finite_differences():
    f = np.logspace(-1, 1, 12)
    meas = _tf_response(PITCH_B, PITCH_A, PITCH_TAU, f, 0.5, 3.0, seed=1)
    x = np.array([4.0, 2.5, 14.0, 3.1, 0.05, ])
    args = dict(w=2 * np.pi * f, gain=meas.gain, phase=meas.phase, coh=np.full(f.size, 0.8),
                use_coh=1, m=1, n=2, delay=1)
    handle = call_handle()

    def residuals(x):
        """The core's residuals and their Jacobian at x."""
        put(handle, x=x, **args)
        status, _ = _api.mlid_tf_residuals(handle.value)
        assert status == 0
        out = results(handle)
        return out["residuals"].copy(), out["jacobian"].copy()

    _, jr = residuals(x)
    for k in range(x.size):
        h = 1e-6 * max(1.0, abs(x[k]))
        e = np.zeros_like(x)
        e[k] = h
        fd = (residuals(x + e)[0] - residuals(x - e)[0]) / (2 * h)
        np.testing.assert_allclose(jr[:, k], fd, rtol=1e-6, atol=1e-8)


def test_transfer_fit_refuses_bad_input():
    f = np.logspace(-1, 1, 3)
    resp = _tf_response(PITCH_B, PITCH_A, PITCH_TAU, f)
    with pytest.raises(mlid.InputError, match="too few"):
        mlid.fit_transfer_function(resp, 2, 3)
    with pytest.raises(mlid.InputError, match="no parameter 'c1'"):
        mlid.fit_transfer_function(resp, 1, 1, fixed={"c1": 0})
    with pytest.raises(mlid.InputError, match="coherence weighting"):
        mlid.fit_transfer_function(resp, 1, 1, coherence_weighting=True)


def test_bode_measured_plot(fitted, tmp_path):
    meas = mlid.record_response(fitted.data, "de", "q", segment=512)
    loes = mlid.fit_transfer_function(meas, 1, 2, f_min=0.2, f_max=5, min_coherence=0.5)
    out = tmp_path / "bode.png"
    fig = plots.bode_measured(fitted, "de", "q", measured=meas, loes=loes, path=out)
    assert isinstance(fig, Figure) and out.stat().st_size > 10000
    ag, ap, ac = fig.axes[:3]
    assert ag.get_title(loc="left") == "de → q  [(rad/s)/deg]"
    assert [ax.get_ylabel() for ax in (ag, ap, ac)] == ["gain [dB]", "phase [deg]",
                                                         "coherence γ²"]
    labels = [ln.get_label() for ln in ag.get_lines() if not ln.get_label().startswith("_")]
    assert labels == ["identified model", "measured, γ² < 0.6 (no bar)", "LOES (1/2, delay)"]
    good = meas.coherence >= plots.COHERENCE_SHOWN
    (bars,) = ag.containers                      # the trusted points, with their error bars
    assert bars.get_label() == "measured ±2σ (random error)"
    np.testing.assert_allclose(bars[0].get_xdata(), meas.frequency[good])
    model_line = ag.get_lines()[0]
    ref = mlid.model_response(fitted, model_line.get_xdata(), "de", "q")
    # in the declared units: (q [rad/s]) / (de [deg]) = (q/de in core units) * pi/180
    np.testing.assert_allclose(model_line.get_ydata(), ref.gain + 20 * np.log10(np.pi / 180))
    assert (ref.input_unit, ref.output_unit) == ("rad", "rad/s")
    np.testing.assert_allclose(ac.get_lines()[0].get_ydata(), meas.coherence)
    plots.close(fig)


DECK = """&case title = 'short period, white elevator noise', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 1, ny = 2,
    f = -1.0, -10.0, 0.8, -2.5,  g = -0.1, -12.0,  h = 1, 0, 0, 1,
    free = 'f(1,1)', 'f(2,1)', 'f(1,2)', 'f(2,2)', 'g(1,1)', 'g(2,1)',
    input_names = 'de', output_names = 'alpha', 'q' /
&data file = 'rec.dat', time_col = 1, input_cols = 2, output_cols = 3, 4 /
&estimate max_iter = 20 /
"""


def test_cli_bode(tmp_path):
    _record([0.01, 0.03]).head(3000).save(tmp_path / "rec.dat")
    (tmp_path / "sp.nml").write_text(DECK)
    out = tmp_path / "q.png"
    run = subprocess.run([BIN / "mlid", "bode", tmp_path / "sp.nml", "--input", "de", "--output",
                          "q", "--out", out, "--segment", "512", "--loes", "1,2",
                          "--band", "0.2,5"], capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert "q/de, 10 averages of 512 samples" in run.stdout
    assert "pole pair" in run.stdout and out.stat().st_size > 10000
    bad = subprocess.run([BIN / "mlid", "bode", tmp_path / "sp.nml", "--case", "2", "--out", out],
                         capture_output=True, text=True)
    assert bad.returncode == 1 and bad.stderr.strip().endswith("the deck has 1 cases")
    alone = subprocess.run([BIN / "mlid", "bode", tmp_path / "sp.nml", "--out", out, "--band",
                            "0.2,5"], capture_output=True, text=True)
    assert alone.returncode == 1 and "give --loes" in alone.stderr


def test_record_spectra_against_scipy():
    """A second implementation: scipy.signal's csd and welch with the same
    periodic Hann window, overlap, mean removal and one-sided densities."""
    signal = pytest.importorskip("scipy.signal")
    d = _record([0.01, 0.03]).head(5000)
    r = mlid.record_response(d, "de", "q", segment=512, overlap=0.5)
    u, y = d.u[:, 0], d.y[:, 1]
    kw = dict(fs=1 / DT, window="hann", nperseg=512, noverlap=256, detrend="constant")
    f, guy = signal.csd(u, y, **kw)
    _, guu = signal.welch(u, **kw)
    _, gyy = signal.welch(y, **kw)
    np.testing.assert_allclose(r.frequency, f[1:], rtol=1e-12)
    np.testing.assert_allclose(r.input_spectrum, guu[1:], rtol=1e-9)
    np.testing.assert_allclose(r.output_spectrum, gyy[1:], rtol=1e-9)
    np.testing.assert_allclose(r.response, guy[1:] / guu[1:], rtol=1e-9)
    np.testing.assert_allclose(r.coherence, abs(guy[1:])**2 / (guu[1:] * gyy[1:]), rtol=1e-9)


def test_record_response_of_several_manoeuvres_averages_their_segments():
    """No segment spans a join: the spectra of two manoeuvres together are
    those of each, weighted by their numbers of segments."""
    d = _record([0.01, 0.03])
    a, b = d.head(3000), d.head(5000)
    b = mlid.FlightData(b.t[1700:] - b.t[1700], b.u[1700:], b.y[1700:], b.input_names,
                        b.output_names)
    ra, rb = (mlid.record_response(x, "de", "q", segment=512) for x in (a, b))
    both = mlid.record_response([a, b], "de", "q", segment=512)
    assert both.averages == ra.averages + rb.averages == 10 + 11
    for key in ("input_spectrum", "output_spectrum"):
        mean = (ra.averages * getattr(ra, key) + rb.averages * getattr(rb, key)) / both.averages
        np.testing.assert_allclose(getattr(both, key), mean, rtol=1e-12)
    cross = (ra.averages * ra.response * ra.input_spectrum
             + rb.averages * rb.response * rb.input_spectrum) / both.averages
    np.testing.assert_allclose(both.response * both.input_spectrum, cross, rtol=1e-10)
    with pytest.raises(mlid.InputError, match=r"at least that many \(100 in manoeuvre 2\)"):
        mlid.record_response([a, b.head(100)], "de", "q", segment=512)
