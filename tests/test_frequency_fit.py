"""Frequency-domain output error and equation error (fortran/estimation/frequency_domain/mlid_frequency.f90)
on the C-8 short-period record: analytic sensitivities against finite
differences, equation error against a least-squares solve of its own,
agreement with the time domain, insensitivity to output biases and drift,
Cramer-Rao sigmas against Monte Carlo scatter, bad input, both front ends."""

import json

import numpy as np
import pytest

import mlid
from mlid.design.signals import input_signal
from conftest import (C8_F, C8_FREE, C8_G, C8_NAMES, C8_STD, c8_record, c8_start, c8_truth,
                      run_both)

FDOE, FDEE = "frequency_output_error", "frequency_equation_error"
# A band from 0.6/T (T = 6 s) past the short period (~0.21 Hz): below 1/T the transient
# terms (mlid_frequency) keep the initial and final states out.
BAND = dict(f_min=0.1, f_max=2.0, n_freq=40)


def c8_model(values):
    """The C-8 model with the five free values given."""
    F, G = C8_F.copy(), C8_G.copy()
    F[2, 2], F[2, 3], F[3, 3], G[2, 0], G[3, 0] = values
    return mlid.LinearModel(F, G, np.eye(4), free=C8_FREE, names=C8_NAMES)


def weights(data):
    """Each frequency's weight min(1, df T): the independent frequencies of
    a grid finer than 1/T (mlid_frequency's header)."""
    df = (BAND["f_max"] - BAND["f_min"]) / (BAND["n_freq"] - 1)
    return min(1.0, df * (data.t[-1] - data.t[0]))


def basis(t, f):
    """The transient terms' transforms over the record t at f (Hz): exp(-i w
    t0), exp(-i w t1), the transform E of 1 and R of t - t0."""
    w = 2 * np.pi * f
    p0, p1 = np.exp(-1j * w * t[0]), np.exp(-1j * w * t[-1])
    e = (p0 - p1) / (1j * w)
    return p0, p1, e, (e - (t[-1] - t[0]) * p1) / (1j * w)


@pytest.mark.parametrize("method", [FDOE, FDEE])
def test_gradient_matches_finite_differences(c8_data, method):
    """The gradient is that of the cost with S and the transient terms
    re-estimated (the cost is stationary in both there), at a point off
    the optimum (the start values)."""
    theta = np.array([C8_F[2, 2], C8_F[2, 3], C8_F[3, 3], C8_G[2, 0], C8_G[3, 0]]) * \
        np.array([0.6, 1.4, 0.65, 1.35, 0.5])
    ev = mlid.frequency_evaluate(c8_model(theta), c8_data, method=method, **BAND)
    h = 1e-6 * np.maximum(np.abs(theta), 1.0)
    dcost = []
    for k in range(5):
        e = np.zeros(5)
        e[k] = h[k]
        plus, minus = (mlid.frequency_evaluate(c8_model(theta + s * e), c8_data, method=method,
                                               **BAND)["cost"] for s in (1, -1))
        dcost.append((plus - minus) / (2 * h[k]))
    g = ev["gradient"]
    assert np.max(np.abs(g - dcost)) < 1e-6 * np.max(np.abs(g))


@pytest.mark.parametrize("method", [FDOE, FDEE])
def test_information_matches_finite_differences(c8_data, method):
    """The information 2 sum c Re(dZ^* S^-1 dZ) with the transient terms
    eliminated, against dZ from central differences of the model's fitted
    transforms (whose transient terms follow theta: their projection), at
    the truth.  c: the weight min(1, df T) times the degrees-of-freedom
    factor (N - p)/N of mlid_frequency, p the free parameters and the
    transient terms estimated.  The information holds S at S-hat (as the
    time domain's output error holds R); the differences let S move with
    theta, and output error's transient terms, shared by all outputs
    through (i w I - F)^-1, are a weighted least squares that moves with S
    (our reading of why the difference does not vanish with less noise; not
    verified term by term): 0.4% of the diagonal at a thousandth of the C-8
    noise, 0.8% at the full noise.  Equation error's terms are each state equation's own,
    whose least squares S does not move: 1e-8.  Tolerance 2% (output
    error), 1e-6 (equation error)."""
    t, u = c8_data.t, c8_data.u
    quiet = mlid.simulate(c8_truth(), t, u, C8_STD * 1e-3, seed=3)[0]
    theta = np.array([C8_F[2, 2], C8_F[2, 3], C8_F[3, 3], C8_G[2, 0], C8_G[3, 0]])
    ev = mlid.frequency_evaluate(c8_model(theta), quiet, method=method, **BAND)
    h = 1e-6 * np.maximum(np.abs(theta), 1.0)
    dz = []
    for k in range(5):
        e = np.zeros(5)
        e[k] = h[k]
        plus, minus = (mlid.frequency_evaluate(c8_model(theta + s * e), quiet, method=method,
                                               **BAND)["zhat"] for s in (1, -1))
        dz.append((plus - minus) / (2 * h[k]))
    n_real = 4 * 2 * BAND["n_freq"] * weights(c8_data)
    c = weights(c8_data) * (n_real - 5 - ev["transient_terms"]) / n_real
    sinv = np.diag(1 / np.diag(ev["rhat"]))
    info = 2 * c * np.real(np.einsum("akj,jl,bkl->ab", np.conj(dz), sinv, dz))
    scale = np.sqrt(np.outer(np.diag(info), np.diag(info)))
    assert np.max(np.abs(ev["information"] - info) / scale) < (2e-2 if method == FDOE else 1e-6)


def test_equation_error_is_least_squares_per_state_equation(c8_data):
    """Equation error with S diagonal and each state equation's parameters
    (and transient terms) its own is least squares per equation on the
    transforms: here solved from mlid.fourier_transform of the mean-removed
    channels with numpy, against the Newton iteration's (a quadratic cost:
    one step, then one to see nothing changes)."""
    fit = mlid.fit(c8_start(), c8_data, method=FDEE, **BAND)
    assert fit.converged and fit.iterations <= 2
    d = c8_data
    f = np.linspace(BAND["f_min"], BAND["f_max"], BAND["n_freq"])
    x = mlid.fourier_transform(d.t, d.y - d.y.mean(0), f)            # the measured states
    u = mlid.fourier_transform(d.t, d.u[:, 0] - d.u[:, 0].mean(), f)
    jw = 2j * np.pi * f
    p0, p1, e, ramp = basis(d.t, f)
    nuisance = [p0, -p1, e, ramp]
    # q equation: jw q - 0.003 u = f33 q + f34 alpha + g31 de + transients
    lhs_q = jw * x[:, 2] - C8_F[2, 0] * x[:, 0]
    # alpha equation: jw alpha - (-0.004 u + q) = f44 alpha + g41 de + transients
    lhs_a = jw * x[:, 3] - C8_F[3, 0] * x[:, 0] - x[:, 2]
    a_q = np.column_stack([x[:, 2], x[:, 3], u] + nuisance)
    a_a = np.column_stack([x[:, 3], u] + nuisance)

    def solve(a, b):
        return np.linalg.lstsq(np.vstack([a.real, a.imag]), np.concatenate([b.real, b.imag]),
                               rcond=None)[0]

    ours = np.concatenate([solve(a_q, lhs_q)[:3], solve(a_a, lhs_a)[:2]])[[0, 1, 3, 2, 4]]
    np.testing.assert_allclose(fit.estimate, ours, rtol=1e-7)
    # the residuals the result holds are those of the state equations
    sol = solve(a_q, lhs_q)
    np.testing.assert_allclose(fit.residuals[:, 2], lhs_q - a_q @ sol,
                               atol=1e-7 * np.max(np.abs(lhs_q)))


@pytest.mark.parametrize("method", [FDOE, FDEE])
def test_agrees_with_time_domain(c8_data, method):
    """The same record fitted in both domains: every estimate within the
    combined sigma of the two (they see the same noise, so closer still)."""
    td = mlid.fit(c8_start(), c8_data)
    fd = mlid.fit(c8_start(), c8_data, method=method, **BAND)
    assert fd.converged and np.all(fd.sigma > 0)
    assert np.all(np.abs(fd.estimate - td.estimate) < np.hypot(fd.sigma, td.sigma))
    assert fd.frequencies.shape == (BAND["n_freq"],) and fd.residuals.shape == (40, 4)
    report = fd.report()
    assert report.startswith(" frequency-domain ") and "band 0.100000 to 2.00000 Hz, 40 " \
        "frequencies" in report.splitlines()[0]


def test_bias_and_drift_leave_frequency_domain_estimates(c8_data):
    """Constant biases and linear drifts on every measured output: the
    frequency-domain estimates do not move (the transient terms hold an
    offset and a drift rate per output: exact, to rounding), while the
    time-domain fit without bias parameters is pulled off by many sigma.
    A slow sinusoidal drift (period 10 T, below the band) moves them by a
    fraction of sigma only."""
    t = c8_data.t
    bias = np.array([1.0, 0.02, 0.005, 0.02])              # ft/s, rad, rad/s, rad
    drift = np.array([0.5, 0.01, 0.002, 0.01]) / t[-1]     # the same units per second
    spoiled = mlid.FlightData(t, c8_data.u, c8_data.y + bias + np.outer(t, drift))
    wavy = mlid.FlightData(t, c8_data.u, c8_data.y + np.outer(np.sin(2 * np.pi * t / 60.0),
                                                             drift * t[-1]))
    td, td2 = (mlid.fit(c8_start(), d) for d in (c8_data, spoiled))
    assert np.max(np.abs(td2.estimate - td.estimate) / td.sigma) > 10
    for method in (FDOE, FDEE):
        fd, fd2, fd3 = (mlid.fit(c8_start(), d, method=method, **BAND)
                        for d in (c8_data, spoiled, wavy))
        assert np.max(np.abs(fd2.estimate - fd.estimate) / fd.sigma) < 1e-6, method
        assert np.max(np.abs(fd3.estimate - fd.estimate) / fd.sigma) < 0.3, method


def test_output_error_sigma_matches_monte_carlo_scatter():
    """50 seeded records: the scatter of the frequency-domain output-error
    estimates against their mean Cramer-Rao sigma.  The sample standard
    deviation of 50 normal draws has a relative standard error of
    1/sqrt(98) = 0.10: the ratio must lie within 3 of them of 1."""
    t, u = c8_record().t, c8_record().u
    mc = mlid.monte_carlo(c8_truth(), c8_start(), t, u, noise_std=C8_STD, runs=50, seed=11,
                          method=FDOE, **BAND)
    assert np.all(mc["status"] == 0)
    ratio = mc["estimates"].std(0, ddof=1) / mc["sigma"].mean(0)
    assert np.all(np.abs(ratio - 1) < 0.3), ratio


def test_bad_input(c8_data):
    with pytest.raises(mlid.InputError, match="Nyquist"):
        mlid.fit(c8_start(), c8_data, method=FDOE, f_min=1.0, f_max=30.0)
    with pytest.raises(mlid.InputError, match="0 < f_min < f_max"):
        mlid.fit(c8_start(), c8_data, method=FDOE, f_min=2.0, f_max=1.0)
    with pytest.raises(mlid.InputError, match="0 < f_min < f_max"):
        mlid.fit(c8_start(), c8_data, method=FDEE)
    with pytest.raises(mlid.InputError, match="band of the frequency-domain methods"):
        mlid.fit(c8_start(), c8_data, f_min=0.2, f_max=2.0)
    with pytest.raises(mlid.InputError, match="band of the frequency-domain methods"):
        mlid.fit(c8_start(), c8_data, n_freq=20)         # not silently ignored
    with pytest.raises(mlid.InputError, match="input_hold = 'zoh' is not for"):
        zoh = c8_start()
        zoh.input_hold = "zoh"
        mlid.fit(zoh, c8_data, method=FDOE, f_min=0.2, f_max=2.0)
    with pytest.raises(mlid.InputError, match="n_freq must lie"):
        mlid.fit(c8_start(), c8_data, method=FDOE, f_min=0.2, f_max=2.0, n_freq=1)
    with pytest.raises(mlid.InputError, match="initial state x0 has no meaning"):
        mlid.fit(mlid.LinearModel(C8_F, C8_G, np.eye(4), free=C8_FREE + ["x0(1)"]), c8_data,
                 method=FDOE, **BAND)
    with pytest.raises(mlid.InputError, match="output bias has no meaning"):
        mlid.fit(mlid.LinearModel(C8_F, C8_G, np.eye(4), free=C8_FREE + ["bias(2)"]), c8_data,
                 method=FDEE, **BAND)
    with pytest.raises(mlid.InputError, match="equation_error.* time-domain start"):
        mlid.fit(c8_start(), c8_data, method=FDOE, startup="equation_error", **BAND)
    with pytest.raises(mlid.InputError, match="every state measured"):
        m = mlid.LinearModel(C8_F, C8_G, np.eye(4)[[0, 2, 3]], free=C8_FREE)
        mlid.fit(m, mlid.FlightData(c8_data.t, c8_data.u, c8_data.y[:, [0, 2, 3]]), method=FDEE,
                 **BAND)
    eq = mlid.EquationModel(states={"x": "a*x + u"}, outputs={"y": "x"}, inputs=["u"],
                            params={"a": -1.0}, free=["a"])
    with pytest.raises(mlid.InputError, match="linear model kind"):
        mlid.fit(eq, mlid.FlightData(c8_data.t, c8_data.u, c8_data.y[:, :1]), method=FDOE, **BAND)
    with pytest.raises(mlid.InputError, match="time domain|frequency_evaluate"):
        mlid.evaluate(c8_start(), c8_data, method=FDOE, **BAND)


DECK = """
&case title = 'C-8: simulate', job = 'simulate' /
&model kind = 'linear', nx = 4, nu = 1, ny = 4,
    f = -0.02, -32.2, 0.0, 33.74,  0.0, 0.0, 1.0, 0.0,  0.003, 0.0, -1.588, -0.562,
        -0.004, 0.0, 1.0, -0.737,
    g = 0.0, 0.0, -1.658, 0.005, h = 1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1 /
&simulate out = 'c8.dat', t_end = 6.0, dt = 0.02, seed = 1,
    noise_std = 0.35355339, 0.0061706707, 0.0061706707, 0.0087266463,
    input_shape = 'doublet', amplitude = 0.08, t_start = 1.0, pulse_width = 0.5 /

&case title = 'C-8: {method}', job = 'estimate' /
&model kind = 'linear', nx = 4, nu = 1, ny = 4,
    f = -0.02, -32.2, 0.0, 33.74,  0.0, 0.0, 1.0, 0.0,  0.003, 0.0, -0.9528, -0.7868,
        -0.004, 0.0, 1.0, -0.47905,
    g = 0.0, 0.0, -2.2383, 0.0025, h = 1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1,
    free = 'f(3,3)', 'f(3,4)', 'f(4,4)', 'g(3,1)', 'g(4,1)' /
&data file = 'c8.dat', time_col = 1, input_cols = 2, output_cols = 3, 4, 5, 6 /
&estimate method = '{method}', {band} /
"""


@pytest.mark.parametrize("method", [FDOE, FDEE])
def test_deck_both_front_ends(tmp_path, method):
    """A deck's frequency-domain case: the same report and JSON from `mlid
    run` and mlid-batch, the report naming method and band, the estimates
    those of mlid.fit on the same record."""
    deck = tmp_path / "fd.nml"
    deck.write_text(DECK.format(method=method, band="f_min = {f_min}, f_max = {f_max}, "
                                "n_freq = {n_freq}".format(**BAND)))
    runs = run_both(deck, "--json", str(tmp_path / "{exe}.json"))
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    assert "band 0.100000 to 2.00000 Hz, 40 frequencies" in runs[0].stdout
    py, fo = (json.loads((tmp_path / f"{exe}.json").read_text()) for exe in ("mlid", "mlid-batch"))
    assert py == fo
    data = mlid.FlightData.load(tmp_path / "c8.dat", time_col=1, input_cols=[2],
                                output_cols=[3, 4, 5, 6])
    fit = mlid.fit(c8_start(), data, method=method, **BAND)
    np.testing.assert_allclose(py[1]["estimate"], fit.estimate, rtol=1e-9)


def test_json_records_method_and_band(tmp_path):
    """The JSON of a fit names its method and, for the frequency domain, its
    band (f_min, f_max in Hz, n_freq), byte for byte the same from both
    front ends; a time-domain fit's band is null.  FitResult.as_dict says
    the same."""
    deck = tmp_path / "fd.nml"
    time_domain = DECK[DECK.index("&case title = 'C-8: {method}'"):]
    deck.write_text(DECK.format(method=FDOE, band="f_min = 0.15, f_max = 1.75, n_freq = 33")
                    + time_domain.format(method="output_error", band="noise = 'diagonal'"))
    runs = run_both(deck, "--json", str(tmp_path / "{exe}.json"))
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    text = [(tmp_path / f"{exe}.json").read_bytes() for exe in ("mlid", "mlid-batch")]
    assert text[0] == text[1]
    fits = [obj for obj in json.loads(text[0]) if obj["job"] == "estimate"]
    assert [f["method"] for f in fits] == [FDOE, "output_error"]
    assert fits[0]["band"] == {"f_min": 0.15, "f_max": 1.75, "n_freq": 33}
    assert fits[1]["band"] is None
    data = mlid.FlightData.load(tmp_path / "c8.dat", time_col=1, input_cols=[2],
                                output_cols=[3, 4, 5, 6])
    own = mlid.fit(c8_start(), data, method=FDOE, f_min=0.15, f_max=1.75, n_freq=33).as_dict()
    assert (own["method"], own["band"]) == (FDOE, fits[0]["band"])


@pytest.mark.parametrize("band, message", [
    ("f_min = 0.2, f_max = 30.0", "Nyquist"),
    ("f_min = 2.0, f_max = 0.2", "0 < f_min < f_max"),
])
def test_deck_bad_band(tmp_path, band, message):
    deck = tmp_path / "fd.nml"
    deck.write_text(DECK.format(method=FDOE, band=band))
    for run in run_both(deck):
        assert run.returncode == 1
        line = [ln for ln in run.stderr.splitlines() if message in ln]
        assert line and "fd.nml" in line[0] and "case 2" in line[0] and "line 11" in line[0], \
            run.stderr


def test_fit_plot(c8_data, tmp_path):
    """The fit figure of a frequency-domain fit: the transforms against
    frequency, written whole."""
    from mlid.report.plots import plot_fit
    fit = mlid.fit(c8_start(), c8_data, method=FDOE, **BAND)
    path = plot_fit(fit, tmp_path, "fd")
    assert path.exists() and path.stat().st_size > 10000


def test_ties_prior_and_bounds(c8_data):
    """The time domain's machinery on a frequency-domain fit: an affine tie
    holds, a bound the unbounded estimate lies beyond is where the estimate
    stops, a heavy a priori weight holds its parameter at the a priori value."""
    free = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)"]
    tied = mlid.LinearModel(C8_F, C8_G, np.eye(4), free=free, ties={"g(4,1)": "-0.003*g(3,1)"})
    fit = mlid.fit(tied, c8_data, method=FDOE, **BAND)
    assert fit.converged
    assert fit.model.G[3, 0] == pytest.approx(-0.003 * fit.model.G[2, 0], rel=1e-12)
    free_fit = mlid.fit(c8_start(), c8_data, method=FDOE, **BAND)
    z_alpha = free_fit.estimate[2]
    bounded = mlid.fit(c8_start(), c8_data, method=FDOE, bounds={"Z_alpha": (z_alpha + 0.05, 0.0)},
                       **BAND)
    assert bounded.estimate[2] == pytest.approx(z_alpha + 0.05, abs=1e-9)
    pinned = mlid.fit(c8_start(), c8_data, method=FDOE, prior={"M_q": -1.5},
                      prior_weight={"M_q": 1e8}, **BAND)
    assert abs(pinned.estimate[0] + 1.5) < 1e-3 * free_fit.sigma[0]


@pytest.mark.parametrize("method", [FDOE, FDEE])
def test_nothing_free_evaluates(c8_data, method):
    """With no parameter free the frequency-domain likelihood still gives
    its residual spectrum S-hat (the same as with the C-8 parameters free at
    the same values: the free set changes only the cost's (N - p)/N
    weighting), an empty gradient and an empty information matrix."""
    theta = np.array([C8_F[2, 2], C8_F[2, 3], C8_F[3, 3], C8_G[2, 0], C8_G[3, 0]])
    some = mlid.frequency_evaluate(c8_model(theta), c8_data, method=method, **BAND)
    model = c8_model(theta)
    none = mlid.frequency_evaluate(mlid.LinearModel(model.F, model.G, np.eye(4), free=[]),
                                   c8_data, method=method, **BAND)
    assert none["gradient"].shape == (0,) and none["information"].shape == (0, 0)
    assert np.isfinite(none["cost"])
    np.testing.assert_allclose(none["rhat"], some["rhat"], rtol=1e-12)


@pytest.mark.parametrize("method", [FDOE, FDEE])
def test_nearly_noise_free_with_offsets_and_drift(method):
    """Noise 1e-8 of the C-8 record's, output offsets and a drift: the
    transient terms take nearly all of the residuals, so the weighted
    products that the alternation forms S from cancel; S is then taken from
    the residuals themselves, and the likelihood at the truth with a full S
    is evaluated (not refused as singular), its S-hat positive definite and
    the mean of Re(V V^*) of the residuals it returns (equal weights here)."""
    t = np.arange(301) * 0.02
    u = input_signal("doublet", 0.08, 1.0, 0.5, 0.02, len(t))
    data, _ = mlid.simulate(c8_truth(), t, u[:, None], 1e-8 * np.asarray(C8_STD), seed=3)
    y = data.y + np.array([0.01, -0.02, 0.005, 0.03]) + np.outer(t, [1e-3, 0, -2e-3, 5e-4])
    data = mlid.FlightData(data.t, data.u, y)
    truth = np.array([C8_F[2, 2], C8_F[2, 3], C8_F[3, 3], C8_G[2, 0], C8_G[3, 0]])
    ev = mlid.frequency_evaluate(c8_model(truth), data, method=method, noise="full", **BAND)
    assert np.all(np.linalg.eigvalsh(ev["rhat"]) > 0)
    v = ev["z"] - ev["zhat"]
    np.testing.assert_allclose(ev["rhat"], (v.T @ v.conj()).real / len(v), rtol=1e-6,
                               atol=1e-6 * np.max(np.diag(ev["rhat"])))
