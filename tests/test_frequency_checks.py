"""The frequency-domain tools' input checks, each one fact in the core:
uniform sampling (fortran/case/mlid_record.f90, record_uniform_step and
record_common_step) asked by the Fourier transform, the measured frequency
response, the recursive fit and fit()'s frequency-domain methods, with one
message from all of them and from both front ends; the transfer function's
parameter count (mlid_api_frequency's tf_orders); a measured response's channels
found in each manoeuvre by name; the recursive fit's band checked and laid
out by the core (band_check, freq_grid) and its free entries by the core's
layout of theta."""

import numpy as np
import pytest

import mlid
from mlid._bridge import api as _api, call_handle, put, results
from conftest import C8_F, C8_FREE, C8_G, C8_NAMES, c8_record, c8_start, run_both

BAND = dict(f_min=0.1, f_max=2.0, n_freq=40)
FDOE, FDEE = "frequency_output_error", "frequency_equation_error"
TOL = 1e-6                      # UNIFORM_TOL of mlid_sampling: steps to 1e-6 of the mean


def jittered(rel, at=40, seed=1):
    """The C-8 record with the samples from `at` on moved later by rel times
    the step: one step longer than the others by rel (less rel/300 of the
    mean's shift)."""
    d = c8_record(seed=seed)
    t = d.t.copy()
    t[at:] += rel * (t[1] - t[0])
    return mlid.FlightData(t, d.u, d.y, input_names=d.input_names, output_names=d.output_names,
                           source=d.source)


def tools(data):
    """Every frequency-domain tool on data, each a callable."""
    return {
        "fourier_transform": lambda: mlid.fourier_transform(data.t, data.y, [0.5, 1.0]),
        "record_response": lambda: mlid.record_response(data, 0, 2),
        "recursive_frequency_fit": lambda: mlid.recursive_frequency_fit(
            c8_start(), data, window=200, **BAND),
        "fit": lambda: mlid.fit(c8_start(), data, method=FDOE, **BAND),
        "frequency_evaluate": lambda: mlid.frequency_evaluate(c8_start(), data, method=FDEE,
                                                              **BAND),
    }


def test_uniform_sampling_one_message_from_every_tool():
    """A step 3e-6 of the step long (3 times the tolerance) is refused by
    every tool with the same message naming the sample; one of 0.5e-6 is
    taken by every one.  (Before, the Python tools took steps within 1e-6 of
    each other, the core within 1e-6 of the mean, each its own message.)"""
    messages = {}
    for name, run in tools(jittered(3 * TOL)).items():
        with pytest.raises(mlid.InputError) as err:
            run()
        messages[name] = str(err.value)
    assert len(set(messages.values())) == 1, messages
    text = messages["fit"]
    assert text.startswith("time is not uniformly sampled: the step to sample 41 (t = 0.8 s)")
    assert "\n" not in text
    for name, run in tools(jittered(0.5 * TOL)).items():
        run()                   # no error


def test_uniform_sampling_of_manoeuvres():
    """Several manoeuvres: the message names the one not uniformly sampled;
    a measured response needs one step for all (fit() lets each manoeuvre
    have its own)."""
    good, bad = c8_record(seed=2), jittered(3 * TOL)
    with pytest.raises(mlid.InputError, match=r"^manoeuvre 2: time is not uniformly sampled: "
                                              r"the step to sample 41"):
        mlid.record_response([good, bad], 0, 2)
    with pytest.raises(mlid.InputError, match=r"^manoeuvre 2: time is not uniformly sampled: "
                                              r"the step to sample 41"):
        mlid.fit(c8_start(), [good, bad], method=FDOE, **BAND)
    slow = c8_record(seed=3, dt=0.025)
    with pytest.raises(mlid.InputError, match=r"^manoeuvre 2: its step 2.500000000E-02 s is not "
                                              r"manoeuvre 1's 2.000000000E-02 s: the manoeuvres "
                                              r"of a frequency response need one sampling"):
        mlid.record_response([good, slow], 0, 2)
    assert mlid.fit(c8_start(), [good, slow], method=FDOE, **BAND).converged
    with pytest.raises(mlid.InputError, match="time is not finite at sample 6"):
        mlid.record_response(mlid.FlightData(np.r_[good.t[:5], np.inf, good.t[6:]], good.u,
                                              good.y), 0, 2)


DECK = """&case title = 'C-8: frequency output error', job = 'estimate' /
&model kind = 'linear', nx = 4, nu = 1, ny = 4,
    f = -0.02, -32.2, 0.0, 33.74,  0.0, 0.0, 1.0, 0.0,  0.003, 0.0, -0.9528, -0.7868,
        -0.004, 0.0, 1.0, -0.47905,
    g = 0.0, 0.0, -2.2383, 0.0025, h = 1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1,
    free = 'f(3,3)', 'f(3,4)', 'f(4,4)', 'g(3,1)', 'g(4,1)' /
&data file = {files}, time_col = 1, input_cols = 2, output_cols = 3, 4, 5, 6 /
&estimate method = 'frequency_output_error', f_min = 0.1, f_max = 2.0, n_freq = 40 /
"""


def _write(path, data):
    np.savetxt(path, np.column_stack([data.t, data.u, data.y]), fmt="%.17g")


@pytest.mark.parametrize("files, where", [("'jit.dat'", ""),
                                          ("'good.dat', 'jit.dat'", "manoeuvre 2: ")])
def test_deck_not_uniformly_sampled_both_front_ends(tmp_path, files, where):
    """A deck's record not uniformly sampled: both front ends refuse it with
    one line naming the deck, case and line, the manoeuvre, the sample and
    its time; the same line from both, and the message of mlid.fit."""
    _write(tmp_path / "good.dat", c8_record(seed=2))
    _write(tmp_path / "jit.dat", jittered(3 * TOL))
    (tmp_path / "fd.nml").write_text(DECK.format(files=files))
    runs = run_both("fd.nml", "--json", "{exe}.json", cwd=tmp_path)
    lines = []
    for run, exe in zip(runs, ("mlid", "mlid-batch")):
        assert run.returncode == 1
        first = run.stderr.splitlines()[0]
        assert first.startswith(f"{exe}: fd.nml case 1 (line 1) "), run.stderr
        lines.append(first[len(exe):])
    assert lines[0] == lines[1]
    assert runs[0].stdout == runs[1].stdout
    records = [jittered(3 * TOL)] if not where else [c8_record(seed=2), jittered(3 * TOL)]
    with pytest.raises(mlid.InputError) as err:
        mlid.fit(c8_start(), records, method=FDOE, **BAND)
    assert str(err.value).startswith(f"{where}time is not uniformly sampled: the step to "
                                     f"sample 41")
    assert lines[0].endswith(f"'C-8: frequency output error': {err.value}")
    assert not (tmp_path / "mlid.json").exists() or (tmp_path / "mlid.json").read_bytes() == \
        (tmp_path / "mlid-batch.json").read_bytes()


def _pitch_fit():
    """A (1, 2) transfer function with a delay fitted to the C-8 model's q/dE."""
    resp = mlid.model_response(c8_start(), np.linspace(0.05, 3.0, 30), 0, 2)
    return resp, mlid.fit_transfer_function(resp, 1, 2)


def test_transfer_function_parameter_count():
    """The core's transfer-function residuals and response refuse a
    parameter vector whose length is not the orders' count, with a status
    and one line (before: read past x's end or left entries unused)."""
    w = 2 * np.pi * np.array([0.2, 0.5, 1.0])
    one = np.ones(3)
    h = call_handle()
    for np_, delay in ((4, 1), (6, 1), (5, 0)):
        x = np.linspace(1.0, 2.0, np_)
        put(h, w=w, gain=one, phase=one, coh=one, use_coh=0, m=1, n=2, delay=delay, x=x)
        status, msg = _api.mlid_tf_residuals(h.value)
        want = (f"transfer function: orders m = 1, n = 2 (delay {delay}) take {4 + delay} "
                f"parameters, got {np_}")
        assert status == 1 and msg.decode().strip() == want
        assert results(h) == {}                    # no residuals, no Jacobian
        gain, phase, status, msg = _api.mlid_tf_response(w=w, m=1, n=2, delay=delay, x=x)
        assert status == 1 and msg.decode().strip() == want
        assert not gain.any() and not phase.any()
    gain, phase, status, msg = _api.mlid_tf_response(w=w, m=1, n=0, delay=0, x=np.ones(2))
    assert status == 1 and b"must be m >= 0, n >= 1" in msg
    # through Python: a fit's estimate cut short
    resp, fit = _pitch_fit()
    assert np.isfinite(fit.response([0.5]).gain).all()
    fit.estimate = fit.estimate[:-1]
    with pytest.raises(mlid.InputError, match=r"^transfer function: orders m = 1, n = 2 "
                                              r"\(delay 1\) take 5 parameters, got 4$"):
        fit.response([0.5])
    with pytest.raises(mlid.InputError, match="take 5 parameters, got 4"):
        mlid.frequency.responses.transfer_mismatch(fit, resp)


def _two_channel(data, source, order):
    """data with its first two outputs (u, alpha) named and in the order given."""
    names = {"u": 0, "alpha": 1, "q": 2, "theta": 3}
    return mlid.FlightData(data.t, data.u, data.y[:, [names[n] for n in order]],
                           input_names=["de"], output_names=list(order), source=source,
                           output_units=["ft/s" if n == "u" else "rad" for n in order])


def test_record_response_finds_channels_by_name_in_each_record():
    """Manoeuvres whose channels are in another order: each one's own column
    of the named channel (an index names the first record's channel); the
    same response as with the channels in one order.  A manoeuvre without
    the channel, or with it in another unit, is refused naming the record
    and the channel."""
    a, b = c8_record(seed=1), c8_record(seed=5)
    same = mlid.record_response([_two_channel(a, "a.dat", ["q", "alpha", "u", "theta"]),
                                 _two_channel(b, "b.dat", ["q", "alpha", "u", "theta"])],
                                "de", "alpha")
    other = [_two_channel(a, "a.dat", ["q", "alpha", "u", "theta"]),
             _two_channel(b, "b.dat", ["theta", "u", "alpha", "q"])]
    by_name = mlid.record_response(other, "de", "alpha")
    by_index = mlid.record_response(other, 0, 1)
    for resp in (by_name, by_index):
        assert resp.output_name == "alpha"
        np.testing.assert_array_equal(resp.response, same.response)
        np.testing.assert_array_equal(resp.coherence, same.coherence)
    # what reading record 2's column 1 (the first record's index) would have given
    naive = mlid.FlightData(b.t, b.u, other[1].y[:, [1]], input_names=["de"],
                            output_names=["alpha"], output_units=["rad"])
    wrong = mlid.record_response([other[0], naive], "de", "alpha")
    assert np.max(np.abs(wrong.response - same.response)) > 0.1 * np.max(np.abs(same.response))
    missing = _two_channel(b, "b.dat", ["q", "u", "theta"])
    with pytest.raises(mlid.InputError, match=r"^record 2 \(b.dat\): no output channel 'alpha' "
                                              r"\(record 1 has it\); this record has "
                                              r"\['q', 'u', 'theta'\]$"):
        mlid.record_response([other[0], missing], "de", "alpha")
    degrees = _two_channel(b, "b.dat", ["q", "alpha", "u", "theta"])
    degrees.output_units[1] = "deg"
    with pytest.raises(mlid.InputError, match=r"^record 2 \(b.dat\): output channel 'alpha' is "
                                              r"in 'deg', in record 1 in 'rad'$"):
        mlid.record_response([other[0], degrees], "de", "alpha")


def test_recursive_fit_band_and_free_entries_from_the_core(c8_data):
    """The recursive fit's band is the frequency-domain methods' band, with
    their messages (mlid_options' band_check through the api); its free
    entries come from the core's layout of theta, in any order given."""
    for band in (dict(f_min=2.0, f_max=0.1, n_freq=40), dict(f_min=0.1, f_max=2.0, n_freq=1),
                 dict(f_min=None, f_max=2.0, n_freq=40)):
        with pytest.raises(mlid.InputError) as rec:
            mlid.recursive_frequency_fit(c8_start(), c8_data, window=200, **band)
        with pytest.raises(mlid.InputError) as fit:
            mlid.fit(c8_start(), c8_data, method=FDEE,
                     **{k: v for k, v in band.items() if v is not None})
        assert str(rec.value) == str(fit.value)
    whole = len(c8_data.t)
    rec = mlid.recursive_frequency_fit(c8_start(), c8_data, window=whole, **BAND)
    shuffled = mlid.LinearModel(c8_start().F, c8_start().G, np.eye(4), free=C8_FREE[::-1],
                                names=C8_NAMES)
    rec2 = mlid.recursive_frequency_fit(shuffled, c8_data, window=whole, **BAND)
    assert sorted(rec2["names"]) == sorted(rec["names"])
    for k, name in enumerate(rec["names"]):
        assert rec2["estimates"][0, rec2["names"].index(name)] == rec["estimates"][0, k]
    with pytest.raises(mlid.InputError, match=r"^recursive_frequency_fit estimates entries of "
                                              r"F and G, not 'h\(2,2\)'$"):
        m = mlid.LinearModel(C8_F, C8_G, np.eye(4), free=C8_FREE + ["h(2,2)"])
        mlid.recursive_frequency_fit(m, c8_data, window=200, **BAND)
