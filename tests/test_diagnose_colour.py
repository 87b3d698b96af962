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

#: fixed seeds of the AR(1) nulls: 1-10 were used while the rule was
#: tuned, 11-20 were not (held out)
AR1_SEEDS = tuple(range(1, 11))
AR1_HELD_SEEDS = tuple(range(11, 21))
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
    """At least 19 of 20 fixed seeds accept nothing, ten of them not used
    while tuning (issue 47 measured 8, 0 and 0 of 10 before the colour
    factor and the noise-colour candidate; on seeds 11-40 this rule gave
    30, 30 and 29 of 30)."""
    ok = [clean(mlid.diagnose(*ar1_null(seed, phi))) for seed in AR1_SEEDS + AR1_HELD_SEEDS]
    assert sum(ok) >= 19, (phi, ok)


def longitudinal_ar1_null(seed, phi):
    """The linear longitudinal record (no bias on V-dot) with AR(1)
    measurement noise of factor phi, stationary sd scenarios.LON_NOISE."""
    model, data = scenarios.longitudinal_linear(seed, v_dot_bias=0.0)
    _, x = mlid.simulate(mlid.LinearModel(model.F, model.G, np.eye(4)), data.t, data.u,
                         seed=seed)
    rng = np.random.default_rng(seed)
    sd = np.asarray(scenarios.LON_NOISE)
    e = np.empty_like(x)
    e[0] = rng.normal(size=4) * sd
    w = rng.normal(size=x.shape) * sd * math.sqrt(1 - phi * phi)
    for k in range(1, len(e)):
        e[k] = phi * e[k - 1] + w[k]
    return model, mlid.FlightData(data.t, data.u, x + e, data.input_names, data.output_names)


def test_longitudinal_ar1_nulls_are_clean():
    """The longitudinal aircraft under AR(1) noise of phi 0.8: at least 9
    of 10 seeds accept nothing (17 of 20 before the colour factor under the
    null: a theta bias and products in the V equation; 20 of 20 now on
    seeds 1-20 at phi 0.6 and 0.8)."""
    ok = [clean(mlid.diagnose(*longitudinal_ar1_null(seed, 0.8))) for seed in range(1, 11)]
    assert sum(ok) >= 9, ok


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
    """Where a process noise is significant on an AR(1) null (phi 0.8, seed
    13: a gust on beta), coloured measurement noise explains the colour at
    least as well: named, in the report, the JSON and the HTML, and nothing
    accepted."""
    d = mlid.diagnose(*ar1_null(13, 0.8))
    assert not d.effects, d.report()
    assert d.colour is not None, d.report()
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


def _peaks_on_noise(phi, reps, n=400, dt=0.02, outputs=4, seed=1):
    """How many of reps synthetic residual sets (AR(1) of factor phi, n
    samples of dt, several outputs) the spectral-peak test
    (structure.peaks) finds a peak in."""
    import types
    from mlid.discrepancy import structure
    rng = np.random.default_rng(seed)
    hits = 0
    for _ in range(reps):
        w = rng.normal(size=(n + 200, outputs))
        e = np.empty_like(w)
        e[0] = w[0]
        for k in range(1, len(w)):
            e[k] = phi * e[k - 1] + w[k]
        res = types.SimpleNamespace(residuals=e[200:], data=types.SimpleNamespace(
            t=np.arange(n) * dt, output_names=[f"y{i}" for i in range(outputs)]))
        hits += bool(structure.peaks(res))
    return hits


def test_the_peak_test_false_alarm_rate():
    """The spectral-peak test alone on 200 white and 200 AR(1) phi 0.8
    residual sets of four outputs (the lateral record's length): its stated
    level is PEAK_ALPHA = 5% over every bin and output, its measured rate
    is 0 of 400 (and 0 of 400 on 800-sample sets): conservative, since it
    counts the averages' degrees of freedom as the segments that do not
    overlap (structure.py).  Asserted: at most 1%, i.e. that rate, not the
    stated one; a smooth colour makes no peak."""
    hits = _peaks_on_noise(0.0, 200) + _peaks_on_noise(0.8, 200)
    assert hits <= 4, hits


def test_the_peak_test_finds_a_sine():
    """White sets with a sine of amplitude 0.6 sd at 7 Hz on one output:
    found there in most (measured 36 of 50): the test is not merely
    silent."""
    import types
    from mlid.discrepancy import structure
    rng = np.random.default_rng(2)
    n, dt, hits = 400, 0.02, 0
    t = np.arange(n) * dt
    for _ in range(50):
        e = rng.normal(size=(n, 4))
        e[:, 1] += 0.6 * np.sin(2 * math.pi * 7.0 * t)
        res = types.SimpleNamespace(residuals=e, data=types.SimpleNamespace(
            t=t, output_names=[f"y{i}" for i in range(4)]))
        found = structure.peaks(res)
        hits += any(s.output == 1 and abs(s.frequency - 7.0) < 0.5 for s in found)
    assert hits >= 30, hits


def test_the_colour_factor_is_one_under_white_noise_and_large_under_ar1():
    """colour_factor's variance ratio for a bias refit: within 0.7-1.3 on
    the white null (measured 0.87-1.03, seeds 3-5), within 5-12 under AR(1)
    noise of phi 0.8 (measured 6.2-7.4; (1 + phi) / (1 - phi) = 9 in
    theory: the refit's own residuals bias it low, which is why the tests
    also take the factor at the current fit, null_colour_factor)."""
    from mlid.discrepancy.diagnose import colour_factor
    for phi, low, high in ((0.0, 0.7, 1.3), (0.8, 5.0, 12.0)):
        for seed in (3, 4, 5):
            model, data = ar1_null(seed, phi) if phi else scenarios.make("null", seed)
            m = model.with_free(list(model.free) + ["bias(3)"])
            res = mlid.fit(m, data)
            k = res.names.index("bias(3)")
            ratio = float((res.sigma_corrected[k] / res.sigma[k]) ** 2)
            assert low <= ratio <= high, (phi, seed, ratio)
            assert colour_factor(res, ["bias(3)"], {}) == pytest.approx(max(1.0, ratio))


def test_an_effect_and_a_mode_on_one_channel():
    """A q bias of 5 sd with the 2.7 Hz mode on the same q gyro: the bias
    is named (its fitted change has no power at the peak, so the peak does
    not judge it), and the peak is still said as not explained."""
    for seed in (1, 2):
        model, data = structural_mode(seed)
        y = data.y.copy()
        y[:, 2] += 5 * scenarios.LON_NOISE[2]
        d = mlid.diagnose(model, mlid.FlightData(data.t, data.u, y, data.input_names,
                                                 data.output_names))
        assert [e.name for e in d.effects] == ["bias on q"], d.report()
        assert any(s.kind == "spectral peak" and s.channel == "q" for s in d.unexplained)
        assert "q residual peak at" in d.verdict


def backlash(seed):
    """The dead_zone record with a backlash of DEAD_ZONE instead: the
    aileron follows its command only when the command leaves a band of
    DEAD_ZONE either side of it."""
    t, u = scenarios.inputs()
    f = 0.2 + (1.5 - 0.2) * t / t[-1]
    u = u.copy()
    u[:, 0] = SWEEP_AMPLITUDE * np.sin(2 * math.pi * np.cumsum(f) * scenarios.DT)
    surf, pos = u.copy(), 0.0
    for k in range(len(t)):
        pos = min(max(pos, u[k, 0] - DEAD_ZONE), u[k, 0] + DEAD_ZONE)
        surf[k, 0] = pos
    F, G = scenarios.matrices(scenarios.BASE)
    data, _ = mlid.simulate(mlid.LinearModel(F, G, np.eye(4), r=np.square(scenarios.NOISE)),
                            t, surf, seed=seed)
    return scenarios.analysis_model(), mlid.FlightData(
        t, u, data.y, ["delta_a", "delta_r"], ["p", "r", "beta", "phi"])


def test_a_backlash_names_no_wrong_effect():
    """A backlash on the aileron sweep (outside the library): the input
    correlation with the aileron's small values is said as not explained,
    and no effect is named on at least 4 of 5 seeds (before, a delay on
    delta_a and products were named on 6 of 10: the delay's own channel is
    p, the probe's r; now 0 of 10, seeds 1-10)."""
    named = 0
    for seed in range(1, 6):
        d = mlid.diagnose(*backlash(seed))
        assert any(s.kind == "input correlation" and "delta_a" in s.text
                   for s in d.unexplained), d.report()
        named += bool(d.effects)
    assert named <= 1, named


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


def test_a_gust_whose_competitor_cannot_be_fitted_is_untested(monkeypatch):
    """Issue 47 item 1's competitor is required: when coloured measurement
    noise cannot be fitted, the gust is untested, not accepted; and one
    competitor per output serves every process noise of a round."""
    from mlid.discrepancy import noise_colour

    def fail(*args, **kwargs):
        raise mlid.MlidError("no competitor here")
    monkeypatch.setattr(noise_colour, "measurement_colour", fail)
    d = mlid.diagnose(*scenarios.make("gust", 2))
    assert not any(e.family == "process noise" for e in d.effects), d.report()
    noise = [c for c in d.rounds[0]["candidates"] if c.family == "process noise" and c.lr]
    assert any(c.decision.startswith("untested: its competitor") for c in noise), d.report()
    colour = [c.name for c in d.rounds[0]["candidates"] if c.family == "measurement-noise colour"]
    assert len(colour) == len(set(colour)), colour
