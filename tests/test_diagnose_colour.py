"""The discrepancy workflow under coloured measurement noise and outside its
library (issue 47 items 1 and 3): AR(1) nulls clean (nothing accepted, or
the colour named as measurement noise), a gust still named as turbulence,
and effects no candidate expresses reported as not explained, by channel
and frequency, with no wrong effect accepted.

The scenario generators are this file's own (tests/scenarios.py is the
shared set): AR(1) measurement noise of stationary sd scenarios.NOISE on
the lateral null record; a 2.7 Hz structural mode on the q gyro of the
linear longitudinal record; a dead-zone on the aileron of the lateral
record flown with an aileron sweep (a 3-2-1-1 has two levels, which a
dead-zone only scales)."""

import math

import numpy as np
import pytest

import mlid
import scenarios

#: fixed seeds of the AR(1) nulls
AR1_SEEDS = tuple(range(1, 11))
#: the structural mode on q: frequency [Hz], damping, and its gain on the
#: elevator's rate [rad/s per rad/s] (ours)
MODE_HZ, MODE_ZETA, MODE_GAIN = 2.7, 0.03, 0.5
#: the aileron's dead-zone half-width [deg] and the sweep's amplitude (ours)
DEAD_ZONE, SWEEP_AMPLITUDE = 0.5, 2.0


def ar1_null(seed, phi):
    """The lateral null record (no effect) with AR(1) measurement noise of
    factor phi on every output, stationary sd scenarios.NOISE."""
    t, u = scenarios.inputs()
    F, G = scenarios.matrices(scenarios.BASE)
    data, x = mlid.simulate(mlid.LinearModel(F, G, np.eye(4)), t, u, seed=seed)
    rng = np.random.default_rng(seed)
    sd = np.asarray(scenarios.NOISE)
    e = np.empty_like(x)
    e[0] = rng.normal(size=4) * sd
    w = rng.normal(size=x.shape) * sd * math.sqrt(1 - phi * phi)
    for k in range(1, len(e)):
        e[k] = phi * e[k - 1] + w[k]
    return scenarios.analysis_model(), mlid.FlightData(
        t, u, x + e, ["delta_a", "delta_r"], ["p", "r", "beta", "phi"])


def structural_mode(seed):
    """The linear longitudinal record (no bias on V-dot) with a lightly
    damped MODE_HZ mode read by the q gyro, excited by the elevator's rate
    (no static gain: nothing a derivative or bias of the model can take)."""
    model, data = scenarios.longitudinal_linear(seed, v_dot_bias=0.0)
    wn = 2 * math.pi * MODE_HZ
    dt = scenarios.LON_DT
    rate = np.gradient(data.u[:, 0], dt)
    s = np.zeros(2)
    mode = np.empty(data.nt)
    sub = 20
    for k in range(data.nt):
        mode[k] = s[0]
        for _ in range(sub):
            acc = MODE_GAIN * wn * rate[k] - 2 * MODE_ZETA * wn * s[1] - wn * wn * s[0]
            s = s + dt / sub * np.array([s[1], acc])
    y = data.y.copy()
    y[:, 2] += mode
    return model, mlid.FlightData(data.t, data.u, y, data.input_names, data.output_names)


def dead_zone(seed):
    """The lateral record flown with an aileron sweep (0.2 to 1.5 Hz) and the
    rudder doublet; the aileron moves only beyond DEAD_ZONE of its command
    (the record holds the command)."""
    t, u = scenarios.inputs()
    f = 0.2 + (1.5 - 0.2) * t / t[-1]
    u = u.copy()
    u[:, 0] = SWEEP_AMPLITUDE * np.sin(2 * math.pi * np.cumsum(f) * scenarios.DT)
    surf = u.copy()
    surf[:, 0] = np.sign(u[:, 0]) * np.maximum(np.abs(u[:, 0]) - DEAD_ZONE, 0.0)
    F, G = scenarios.matrices(scenarios.BASE)
    data, _ = mlid.simulate(mlid.LinearModel(F, G, np.eye(4), r=np.square(scenarios.NOISE)),
                            t, surf, seed=seed)
    return scenarios.analysis_model(), mlid.FlightData(
        t, u, data.y, ["delta_a", "delta_r"], ["p", "r", "beta", "phi"])


def clean(d):
    """Nothing accepted, or only the colour named as measurement noise."""
    return not d.effects


@pytest.mark.parametrize("phi", [0.3, 0.6, 0.8])
def test_ar1_nulls_are_clean(phi):
    """At least 9 of 10 fixed seeds accept nothing (issue 47 measured 8, 0
    and 0 of 10 before the colour factor and the noise-colour candidate)."""
    ok = [clean(mlid.diagnose(*ar1_null(seed, phi))) for seed in AR1_SEEDS]
    assert sum(ok) >= 9, (phi, ok)


def test_a_gust_beats_coloured_measurement_noise():
    """The gust record: the gust is named, and coloured measurement noise on
    beta, its competitor, is refitted and rejected."""
    model, data = scenarios.make("gust", 2)
    d = mlid.diagnose(model, data)
    assert [e.name for e in d.effects] == ["first-order gust on beta"], d.report()
    colour = [c for c in d.rounds[0]["candidates"] if c.family == "measurement-noise colour"]
    assert colour and colour[0].decision.startswith("rejected"), d.report()
    assert d.colour is None


def test_coloured_noise_is_named_on_a_strongly_coloured_null():
    """Where turbulence leads an AR(1) null (phi 0.8, seed 2), coloured
    measurement noise explains the colour at least as well: named, in the
    report, the JSON and the HTML, and nothing accepted."""
    d = mlid.diagnose(*ar1_null(2, 0.8))
    assert not d.effects, d.report()
    if d.colour is None:               # nothing led: nothing to name
        pytest.skip("no process-noise candidate led on this record")
    assert d.colour.family == "measurement-noise colour"
    assert "coloured measurement noise on" in d.report()
    js = d.as_dict()
    assert js["noise_colour"]["family"] == "measurement-noise colour"
    assert "coloured measurement noise" in d._repr_html_()


def test_a_structural_mode_is_not_explained():
    """A 2.7 Hz mode on q: said as a q residual peak within one bin of 2.7
    Hz, not explained, in the report, the JSON and the HTML; no effect
    accepted whose channel is q."""
    for seed in (1, 2, 3):
        model, data = structural_mode(seed)
        d = mlid.diagnose(model, data)
        peaks = [s for s in d.unexplained if s.kind == "spectral peak" and s.channel == "q"]
        assert peaks, d.report()
        bin_hz = 1.0 / (scenarios.LON_DT * 128)
        assert abs(peaks[0].frequency - MODE_HZ) <= 1.5 * bin_hz, d.report()
        assert not d.effects, d.report()
        assert "q residual peak at" in d.report() and "not explained" in d.report()
        js = d.as_dict()
        assert any(s["channel"] == "q" and s["kind"] == "spectral peak"
                   for s in js["not_explained"])
        assert "mlid-not-explained" in d._repr_html_()


def test_a_dead_zone_is_not_explained():
    """A dead-zone on the aileron: said as the p residual correlated with
    the aileron's small values, not explained (a dead-zone or backlash is
    outside the library), and no wrong effect accepted."""
    for seed in (1, 2, 3):
        model, data = dead_zone(seed)
        d = mlid.diagnose(model, data)
        found = [s for s in d.unexplained if s.kind == "input correlation"]
        assert found and found[0].channel == "p", d.report()
        assert "delta_a" in found[0].text and "dead-zone" in found[0].text
        assert not d.effects, d.report()


def test_the_peak_test_is_quiet_on_white_and_coloured_noise():
    """The spectral-peak test alone (structure.peaks) on the residuals of
    the white null and of AR(1) nulls: no peak at 5% over all bins and
    outputs on most seeds (its stated rate)."""
    from mlid.discrepancy import structure
    hits = 0
    for seed in range(1, 11):
        for phi in (0.0, 0.8):
            model, data = ar1_null(seed, phi) if phi else scenarios.make("null", seed)
            hits += bool(structure.peaks(mlid.fit(model, data)))
    assert hits <= 2


def test_the_colour_factor_is_one_under_white_noise_and_large_under_ar1():
    """colour_factor: about 1 for a bias refit on the white null, about
    (1 + phi) / (1 - phi) = 9 for it under AR(1) noise of phi 0.8."""
    from mlid.discrepancy.diagnose import colour_factor
    for phi, low, high in ((0.0, 1.0, 1.5), (0.8, 4.0, 15.0)):
        model, data = ar1_null(3, phi) if phi else scenarios.make("null", 3)
        m = model.with_free(list(model.free) + ["bias(3)"])
        res = mlid.fit(m, data)
        k = colour_factor(res, ["bias(3)"], {})
        assert low <= k <= high, (phi, k)


def test_the_score_for_colour():
    """score_corrected (the generalised score test, the core's coloured
    bracket): within 30% of the plain score on the white null, at most a
    third of it for the leading candidates under AR(1) noise of phi 0.8;
    in the JSON with the colour factor and the stated rule."""
    d = mlid.diagnose(*scenarios.make("null", 3))
    top = max((c for c in d.rounds[0]["candidates"] if c.score and not c.confounded
               and c.score_corrected is not None), key=lambda c: c.score)
    assert top.score_corrected == pytest.approx(top.score, rel=0.3)
    d = mlid.diagnose(*ar1_null(3, 0.8))
    lead = sorted((c for c in d.rounds[0]["candidates"] if c.score and not c.confounded
                   and c.score_corrected is not None), key=lambda c: -c.score)[:3]
    assert all(c.score_corrected < c.score / 3 for c in lead), [
        (c.name, c.score, c.score_corrected) for c in lead]
    js = d.as_dict()
    assert "colour factor" in js["colour_rule"]
    listed = [c for r in js["rounds"] for c in r["listed"]]
    assert any(c["score_corrected"] is not None for c in listed)
    assert any(c["colour_factor"] and c["colour_factor"] > 1 for c in listed)


def hfb_residual_null(k):
    """The HFB-320 case's fitted model simulated, plus the real record's
    residuals (each output's mean removed: a null), shifted circularly by k
    tenths of the record: real coloured noise (Ljung-Box Q in the
    thousands) with nothing missing.  None when the shared record is not
    there."""
    import sys
    from conftest import REPO
    sys.path.insert(0, str(REPO / "cases" / "discrepancy"))
    import demos
    if not demos.HFB_DECK.is_file():
        return None
    case = mlid.read_deck(demos.HFB_DECK)[0]
    try:
        data = case.record()
    except mlid.MlidError:
        return None
    f = mlid.fit(case.model, data)
    e = f.residuals - f.residuals.mean(axis=0)
    y = f.yhat + np.roll(e, k * data.nt // 10, axis=0)
    return case.model, mlid.FlightData(data.t, data.u, y, data.input_names, data.output_names,
                                       input_units=data.input_units,
                                       output_units=data.output_units)


def test_real_coloured_residuals_null_is_clean():
    """Issue 47 measured the real-noise null clean 4 of 10 times (main gives
    4/10 on these ten shifts too); at least 9 of 10 now."""
    made = [hfb_residual_null(k) for k in range(10)]
    if made[0] is None:
        pytest.skip("the HFB-320 record is not in the shared data")
    clean_ = [not mlid.diagnose(*m).effects for m in made]
    assert sum(clean_) >= 9, clean_
