"""The input-signal library (fortran/design/mlid_signals.f90, mlid_inputs.f90;
python/mlid/design/signals.py): orthogonal minimum-RPF multisines, sweeps,
PRBS, multisteps and their finishing, against closed forms."""

import numpy as np
import pytest

from mlid.design.signals import finish, multisine, multisine_harmonics, multistep, prbs, sweep
from mlid.errors import InputError


def rpf(u):
    return (u.max() - u.min()) / (2 * np.sqrt(2) * np.sqrt(np.mean(u ** 2)))


@pytest.mark.parametrize("m, band, T, dt, power", [
    (3, (0.1, 1.5), 20.0, 0.02, None),
    (2, (0.2, 3.0), 15.0, 0.01, None),
    (4, (0.05, 2.0), 40.0, 0.05, "falling"),
    (1, (0.5, 5.0), 10.0, 0.02, None),
])
def test_multisine_orthogonal_zero_ends_and_rpf_below_schroeder(m, band, T, dt, power):
    nh = multisine_harmonics(m, *band, T, dt)
    pw = None if power is None else 1.0 / np.arange(1, nh + 1)
    ms = multisine(m, *band, T, dt, amplitude=np.linspace(1, 2, m), power=pw, iterations=300)
    u = ms.u[:-1]                               # one period: the last sample repeats the first
    g = u.T @ u
    off = g - np.diag(np.diag(g))
    assert np.max(np.abs(off)) <= 1e-12 * np.max(np.diag(g))
    assert np.all(ms.rpf <= ms.rpf_schroeder)
    assert np.allclose([rpf(u[:, j]) for j in range(m)], ms.rpf, rtol=1e-12)
    assert np.allclose(ms.peak, np.linspace(1, 2, m), rtol=1e-12)
    assert np.allclose(ms.u[0], 0, atol=1e-12) and np.allclose(ms.u[-1], 0, atol=1e-12)
    assert np.allclose(u.mean(axis=0), 0, atol=1e-12)
    # each input holds its own harmonics only, with the reported amplitudes
    n = u.shape[0]
    spec = np.abs(np.fft.rfft(u, axis=0)) * 2 / n
    k_all = np.concatenate([np.rint(f * T).astype(int) for f in ms.frequencies])
    assert sorted(k_all) == list(range(k_all.min(), k_all.max() + 1))
    for j in range(m):
        k = np.rint(ms.frequencies[j] * T).astype(int)
        assert np.all(np.diff(k) == m)                     # interleaved
        assert np.allclose(spec[k, j], ms.amplitudes[j], rtol=1e-9)
        rest = np.delete(spec[:, j], k)
        assert rest.max() < 1e-9 * spec[k, j].max()
        if pw is not None:                                  # the given spectrum's shape
            p = pw[j::m] / pw[j::m].sum()
            assert np.allclose(ms.amplitudes[j] ** 2 / np.sum(ms.amplitudes[j] ** 2), p)


def test_multisine_sidpac_example_settings():
    """SIDPAC's mkmsswp settings (3 inputs, 0.1-1.5 Hz, T = 20 s, dt = 0.02 s as in its
    help).  The optimised RPFs come well below Schroeder's; no published RPF figure
    for these settings was found (mkmsswp stops its loop at RPF 1.01, its goal, not a
    result), so the bound here is ours: every input at most 1.25."""
    ms = multisine(3, 0.1, 1.5, 20.0, 0.02)
    assert np.all(ms.rpf < 1.25)
    assert np.all(ms.rpf < 0.85 * ms.rpf_schroeder)
    assert [len(f) for f in ms.frequencies] == [10, 10, 9]
    assert ms.frequencies[0][0] == pytest.approx(0.1) and ms.frequencies[0][-1] == pytest.approx(1.45)
    assert ms.frequencies[1][-1] == pytest.approx(1.5)


def test_multisine_schroeder_only_and_table():
    ms = multisine(2, 0.1, 1.0, 20.0, 0.05, iterations=0)
    assert np.allclose(ms.rpf, ms.rpf_schroeder, rtol=0.01)   # only the time shift differs
    pd = pytest.importorskip("pandas")
    tab = ms.table()
    assert isinstance(tab, pd.DataFrame) and list(tab.index) == [1, 2]
    assert np.allclose(tab["rpf"], ms.rpf) and list(tab["harmonics"]) == [10, 9]


def test_linear_sweep_flat_over_its_band():
    dt, T = 0.01, 60.0
    u = sweep("linear", 0.2, 2.0, T, dt, fade=1.0)
    p = np.abs(np.fft.rfft(u)) ** 2
    f = np.fft.rfftfreq(u.size, dt)
    inside = (f >= 0.3) & (f <= 1.9)
    bands = np.array_split(p[inside], 8)
    means = np.array([b.mean() for b in bands])
    assert means.max() / means.min() < 1.5               # closed form: flat, a^2 T / (4 (f1-f0))
    # Parseval: the power density a^2/(4 (f1-f0)) per Hz over the band, on average
    density = 2 * p[inside].mean() * dt / u.size
    assert density == pytest.approx(1.0 / (2 * (2.0 - 0.2)), rel=0.15)
    assert p[f > 3.0].sum() < 1e-3 * p.sum()


def test_log_sweep_equal_power_per_octave():
    dt, T = 0.01, 80.0
    u = sweep("log", 0.1, 3.2, T, dt)                     # five octaves, T/5 each
    p = np.abs(np.fft.rfft(u)) ** 2
    f = np.fft.rfftfreq(u.size, dt)
    octs = [p[(f >= 0.1 * 2 ** i) & (f < 0.2 * 2 ** i)].sum() for i in range(1, 4)]
    assert max(octs) / min(octs) < 1.2                   # closed form: density ~ 1/f
    # instantaneous frequency f0 r^(t/T): at t = T/2 the zero crossings are sqrt(f0 f1) apart
    t = np.arange(u.size) * dt
    i = np.flatnonzero((np.diff(np.sign(u)) != 0) & (np.abs(t[:-1] - T / 2) < 3.0))
    tc = t[i] - u[i] * dt / (u[i + 1] - u[i])           # interpolated zero crossings
    assert 1 / (2 * np.mean(np.diff(tc))) == pytest.approx(np.sqrt(0.1 * 3.2), rel=0.03)


def test_sweep_amplitude_shaping_and_fade():
    u = sweep("linear", 0.5, 0.5, 10.0, 0.001, amplitude=1.0, amplitude_end=3.0, fade=1.0)
    t = np.arange(u.size) * 0.001
    assert np.abs(u[t < 0.2]).max() < 0.1 and abs(u[0]) == 0 and abs(u[-1]) < 1e-12
    env = np.abs(u[(t > 4.0) & (t < 6.0)]).max()
    assert env == pytest.approx(1.0 + 2.0 * 0.55, rel=0.05)   # a(t) at the crest near t = 5.5


def _lfsr_period(u, nbits):
    for p in range(1, nbits + 1):
        if np.array_equal(u[p:p + nbits], u[:nbits]):
            return p
    return None


@pytest.mark.parametrize("order", range(2, 13))
def test_prbs_maximal_length(order):
    n = 2 ** order - 1
    u = prbs(order, 1, 0.01, 2 * n)
    assert _lfsr_period(u, n) == n
    assert np.count_nonzero(u[:n] > 0) == (n + 1) // 2      # balance of an m-sequence


@pytest.mark.parametrize("order, clock", [(5, 1), (6, 4), (7, 3)])
def test_prbs_line_spectrum_sinc2(order, clock):
    """One period of a held m-sequence: DC a^2/N^2, lines a^2 (N+1)/N^2 times the
    hold's envelope (the discrete sinc^2 of a bit of `clock` samples)."""
    a, n = 0.7, 2 ** order - 1
    u = prbs(order, clock, 0.02, n * clock, amplitude=a)
    c = np.fft.fft(u) / u.size
    p = np.abs(c) ** 2
    k = np.arange(1, u.size // 2)
    k = k[k % n != 0]
    hold = (np.sin(np.pi * k / n) / (clock * np.sin(np.pi * k / (n * clock)))) ** 2
    assert p[0] == pytest.approx(a ** 2 / n ** 2, rel=1e-9)
    assert np.allclose(p[k], a ** 2 * (n + 1) / n ** 2 * hold, rtol=1e-9)
    # the continuous envelope sinc^2(f Tc) it tends to, within the hold's rounding
    assert np.allclose(hold, np.sinc(k / n) ** 2, atol=0.15 if clock > 1 else 1.0)


@pytest.mark.parametrize("shape, widths", [("doublet", [1, 1]), ("211", [2, 1, 1]),
                                           ("3211", [3, 2, 1, 1])])
def test_multistep_durations(shape, widths):
    dt, pw, t0 = 0.02, 0.4, 1.0
    u = multistep(shape, 2.0, t0, pw, dt, 500)
    nz = np.flatnonzero(u)
    assert nz[0] == round(t0 / dt) and nz.size == round(sum(widths) * pw / dt)
    edges = np.flatnonzero(np.diff(np.sign(u[nz[0]:nz[-1] + 1]))) + 1
    runs = np.diff(np.concatenate([[0], edges, [nz.size]])) * dt
    assert np.allclose(runs, np.array(widths) * pw)
    assert np.all(np.abs(u[nz]) == 2.0)


def test_finish_zero_mean_ends_and_limit():
    rng = np.random.default_rng(43)
    x = 1.0 + np.cumsum(rng.standard_normal(400)) * 0.1
    v = finish(x, zero=True, limit=0.5)
    assert v[0] == 0 and v[-1] == 0 and abs(v.mean()) < 1e-14
    assert np.abs(v).max() == pytest.approx(0.5, rel=1e-14)
    w = finish(x, zero=True)                    # scaled, not clipped: the shape stays
    assert np.allclose(v, w * 0.5 / np.abs(w).max())
    assert np.array_equal(finish(x, zero=False, limit=100.0), x)
    u = prbs(5, 3, 0.02, 300, zero=True, limit=0.3)
    assert u[0] == 0 and u[-1] == 0 and abs(u.mean()) < 1e-14 and np.abs(u).max() <= 0.3
    s = sweep("linear", 0.2, 1.0, 20.0, 0.02, amplitude=2.0, zero=True, limit=1.0)
    assert s[0] == 0 and s[-1] == 0 and abs(s.mean()) < 1e-14 and np.abs(s).max() <= 1.0
    m = multistep("3211", 1.0, 0.5, 0.3, 0.02, 200, zero=True)
    assert m[0] == 0 and m[-1] == 0 and abs(m.mean()) < 1e-14


@pytest.mark.parametrize("call, words", [
    (lambda: multisine(3, 0.1, 0.15, 20.0, 0.02), "fewer than the 3 inputs"),
    (lambda: multisine(2, 1.5, 0.1, 20.0, 0.02), "f_min < f_max"),
    (lambda: multisine(2, 0.1, 1.5, 20.0, 0.02, amplitude=[1.0, -1.0]), "amplitudes"),
    (lambda: multisine(2, 0.1, 1.5, 20.0, 0.02, power=np.ones(3)), "one value per harmonic"),
    (lambda: sweep("cubic", 0.1, 1.0, 10.0, 0.02), "'linear' or 'log'"),
    (lambda: sweep("log", 0.1, 30.0, 10.0, 0.02), "Nyquist"),
    (lambda: sweep("linear", 0.1, 1.0, 10.0, 0.02, fade=6.0), "half the record"),
    (lambda: prbs(21, 1, 0.02, 10), "order"),
    (lambda: prbs(5, 0, 0.02, 10), "clock"),
    (lambda: finish(np.ones(5), limit=-1.0), "limit"),
])
def test_bad_arguments_one_line(call, words):
    with pytest.raises(InputError) as e:
        call()
    text = str(e.value)
    assert words in text and "\n" not in text


DECK = """&case title = 'multisines', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 3, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.2, 0.1, 0.5, 0.5,  h = 1, 0, 0, 1 /
&simulate out = 'ms.dat', t_end = 20.0, dt = 0.02, seed = 4, noise_std = 0.01, 0.01,
    input_shape = 'multisine', amplitude = 1.0, 2.0, 0.5, f_min = 0.1, f_max = 1.5 /
&case title = 'sweep prbs', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 3, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.2, 0.1, 0.5, 0.5,  h = 1, 0, 0, 1 /
&simulate out = 'sw.dat', t_end = 20.0, dt = 0.02, input_shape = 'sweep', 'log_sweep', 'prbs',
    amplitude = 1.0, 1.0, 1.0, f_min = 0.1, f_max = 1.5, pulse_width = 2.0, 2.0, 0.2,
    prbs_order = 6 /
&case title = 'bad band', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 3, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.2, 0.1, 0.5, 0.5,  h = 1, 0, 0, 1 /
&simulate out = 'bad.dat', t_end = 20.0, dt = 0.02, input_shape = 'multisine',
    amplitude = 1.0, 1.0, 1.0, f_min = 0.1, f_max = 0.12 /
&case title = 'bad prbs', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 3, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.2, 0.1, 0.5, 0.5,  h = 1, 0, 0, 1 /
&simulate out = 'bad2.dat', t_end = 20.0, dt = 0.02, input_shape = 'prbs', 'none', 'none',
    amplitude = 1.0, 1.0, 1.0, pulse_width = 0.2, prbs_order = 25 /
"""


def test_deck_simulate_signals_both_front_ends(tmp_path):
    """&simulate input_shape = 'multisine' / 'sweep' / 'log_sweep' / 'prbs': the same
    report and records from both front ends, the records the Python API's signals,
    and one line for each bad case."""
    from conftest import run_both
    deck = tmp_path / "signals.nml"
    deck.write_text(DECK)
    records = {}
    for run, exe in zip(run_both(deck, cwd=tmp_path), ("mlid", "mlid-batch")):
        assert run.returncode == 1
        errors = run.stderr.splitlines()
        assert errors[0].endswith("'bad band': multisine: the band [ 1.000E-01, 1.200E-01] Hz "
                                  "holds 1 harmonics of 1/T (T = 2.000E+01 s) below Nyquist, "
                                  "fewer than the 3 inputs")
        assert errors[1].endswith("'bad prbs': prbs: the order must be 2 to 20, got 25")
        assert errors[0].startswith(f"{exe}: {deck} case 3 (line 12)")
        records[exe] = {name: (tmp_path / name).read_bytes() for name in ("ms.dat", "sw.dat")}
        assert not (tmp_path / "bad.dat").exists() and not (tmp_path / "bad2.dat").exists()
    outs = [r.stdout for r in run_both(deck, cwd=tmp_path)]
    assert outs[0] == outs[1]
    assert records["mlid"] == records["mlid-batch"]
    ms = np.loadtxt(tmp_path / "ms.dat")
    ref = multisine(3, 0.1, 1.5, 20.0, 0.02, amplitude=[1.0, 2.0, 0.5])
    assert np.allclose(ms[:, 1:4], ref.u, atol=1e-12)
    sw = np.loadtxt(tmp_path / "sw.dat")
    assert np.allclose(sw[:, 1], sweep("linear", 0.1, 1.5, 20.0, 0.02, fade=2.0), atol=1e-12)
    assert np.allclose(sw[:, 2], sweep("log", 0.1, 1.5, 20.0, 0.02, fade=2.0), atol=1e-12)
    assert np.array_equal(sw[:, 3], prbs(6, 10, 0.02, 1001))


def test_deck_simulate_reports_each_input(tmp_path):
    """The simulate report and JSON give each input's shape, peak, rms and
    relative peak factor, as computed from the written record, and a
    multisine's harmonics (those of the Python API's multisine, disjoint
    between the inputs) or a sweep's band."""
    import json
    from conftest import run_both
    deck = tmp_path / "signals.nml"
    deck.write_text(DECK.split("&case title = 'bad band'")[0])
    runs = run_both(deck, "--json", "out.json", cwd=tmp_path)
    assert runs[0].stdout == runs[1].stdout
    cases = json.loads((tmp_path / "out.json").read_text())
    ref = multisine(3, 0.1, 1.5, 20.0, 0.02, amplitude=[1.0, 2.0, 0.5])
    for case, name in zip(cases, ("ms.dat", "sw.dat")):
        rec = np.loadtxt(tmp_path / name)
        for k, inp in enumerate(case["inputs"]):
            u = rec[:, 1 + k]
            assert inp["peak"] == pytest.approx(np.max(np.abs(u)), rel=1e-9)
            assert inp["rms"] == pytest.approx(np.sqrt(np.mean(u**2)), rel=1e-9)
            rpf = (u.max() - u.min()) / (2 * np.sqrt(2) * np.sqrt(np.mean(u**2)))
            assert inp["rpf"] == pytest.approx(rpf, rel=1e-9)
    shapes = [i["shape"] for c in cases for i in c["inputs"]]
    assert shapes == ["multisine"] * 3 + ["sweep", "log_sweep", "prbs"]
    freqs = [np.array(i["frequencies_hz"]) for i in cases[0]["inputs"]]
    assert sum(map(len, freqs)) == len(np.unique(np.concatenate(freqs)))
    for k, f in enumerate(freqs):
        assert np.allclose(f, ref.frequencies[k]), k
    assert cases[1]["inputs"][0]["frequencies_hz"] == [0.1, 1.5]
    assert cases[1]["inputs"][2]["frequencies_hz"] == []
    assert " multisine " in runs[0].stdout and "RPF" in runs[0].stdout


def test_deck_limit_scales_multisines_too(tmp_path):
    """&simulate limit on multisine inputs scales each down to its limit
    (peaks 0.5 and 0.3 from amplitudes 1 and 2; the third, unlimited, keeps
    its 0.5), which keeps them orthogonal; more than 4,000 powers are one
    line naming the limit."""
    from conftest import run_both
    deck = tmp_path / "ms.nml"
    deck.write_text(DECK.split("&case title = 'sweep prbs'")[0]
                    .replace("f_min = 0.1, f_max = 1.5 /", "f_min = 0.1, f_max = 1.5, limit = 0.5, 0.3, 0 /"))
    runs = run_both(deck, cwd=tmp_path)
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    u = np.loadtxt(tmp_path / "ms.dat")[:, 1:4]
    np.testing.assert_allclose(np.abs(u).max(axis=0), [0.5, 0.3, 0.5], rtol=1e-12)
    gram = u[:-1].T @ u[:-1]
    assert abs(gram[0, 1]) < 1e-9 * np.sqrt(gram[0, 0] * gram[1, 1])
    deck.write_text(DECK.split("&case title = 'sweep prbs'")[0]
                    .replace("f_max = 1.5 /", "f_max = 1.5, power = " + ", ".join(["1"] * 4001) + " /"))
    from conftest import refused_by_both
    refused_by_both(deck, "power has 4001 entries; a case takes at most 4000 relative powers",
                    cwd=tmp_path)


SHAPED = """&case title = 'shaped', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 3, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.2, 0.1, 0.5, 0.5,  h = 1, 0, 0, 1 /
&simulate out = 'sh.dat', t_end = 20.0, dt = 0.02, input_shape = 'sweep', 'prbs', '3211',
    amplitude = 1.0, 2.0, 0.5, amplitude_end = 0.25, f_min = 0.1, f_max = 1.5,
    pulse_width = 2.0, 0.2, 1.0, prbs_order = 6, limit = 0, 1.5, 0, zero_mean = .true. /
"""


def test_deck_shapes_limits_and_zero_means_as_the_python_api(tmp_path):
    """&simulate amplitude_end (a sweep's amplitude shaping), limit and
    zero_mean give the Python API's signals (sweep(amplitude_end=...),
    finish(zero=True, limit=...)) in both front ends: zero at both ends,
    zero mean, the limit kept."""
    from conftest import run_both
    deck = tmp_path / "shaped.nml"
    deck.write_text(SHAPED)
    runs = run_both(deck, cwd=tmp_path)
    assert runs[0].returncode == runs[1].returncode == 0 and runs[0].stdout == runs[1].stdout
    u = np.loadtxt(tmp_path / "sh.dat")[:, 1:4]
    want = [finish(sweep("linear", 0.1, 1.5, 20.0, 0.02, amplitude=1.0, amplitude_end=0.25,
                         fade=2.0)),
            finish(prbs(6, 10, 0.02, 1001, amplitude=2.0), limit=1.5),
            finish(multistep("3211", 0.5, 0.0, 1.0, 0.02, 1001))]
    for k in range(3):
        assert np.allclose(u[:, k], want[k], atol=1e-12), k
    assert np.all(u[0] == 0) and np.all(u[-1] == 0)
    assert np.max(np.abs(u.mean(axis=0))) < 1e-12
    assert np.max(np.abs(u[:, 1])) == pytest.approx(1.5, rel=1e-12)
    # shaping: the sweep's envelope falls from 1 toward 0.25
    assert np.max(np.abs(u[100:200, 0])) > 1.8 * np.max(np.abs(u[-200:-100, 0]))


@pytest.mark.parametrize("change, new, message", [
    ("limit = 0, 1.5, 0", "limit = -1",
     "limit (the largest |u| of each input; 0: none) must be >= 0 and finite"),
    ("amplitude_end = 0.25", "amplitude_end = 0.25, 0.5",
     "amplitude_end and limit take one value or one per input (3)"),
    ("input_shape = 'sweep', 'prbs', '3211'", "input_shape = 'prbs', 'prbs', '3211'",
     "amplitude_end is for sweeps (input_shape 'sweep' or 'log_sweep'), and no input is one"),
    ("zero_mean = .true.", "zero_mean = .true., phases = 'schroeder'",
     "power and phases are for multisines (input_shape 'multisine'), and no input is one"),
])
def test_deck_bad_shaping_one_line(tmp_path, change, new, message):
    """A negative limit, amplitude_end of neither one value nor one per input,
    amplitude_end without a sweep, phases without a multisine: one line each
    (a setting no input takes is refused, not ignored)."""
    deck = tmp_path / "bad.nml"
    deck.write_text(SHAPED.replace(change, new))
    from conftest import refused_by_both
    refused_by_both(deck, message, cwd=tmp_path)
    assert not (tmp_path / "sh.dat").exists()


def test_deck_multisine_power_as_the_python_api(tmp_path):
    """&simulate power (one relative power per harmonic of the band) gives
    the Python API's multisine(power=...), in both front ends; a list of the
    wrong length fails that case with one line naming the band's count."""
    from conftest import run_both
    case = """&case title = '{title}', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 2, ny = 2,
    f = -1.0, 0.5, -2.0, -1.5, g = 1.0, 0.2, 0.0, 1.0, h = 1, 0, 0, 1 /
&simulate out = '{out}', t_end = 10.0, dt = 0.02, input_shape = 'multisine',
    amplitude = 1.0, 0.5, f_min = 0.1, f_max = 1.0, power = {power} /
"""
    deck = tmp_path / "power.nml"
    deck.write_text(case.format(title="sloped", out="p.dat", power="10, 9, 8, 7, 6, 5, 4, 3, 2, 1")
                    + case.format(title="short", out="q.dat", power="10, 9, 8"))
    runs = run_both(deck, cwd=tmp_path)
    assert runs[0].stdout == runs[1].stdout
    for run in runs:
        assert run.returncode == 1
        assert run.stderr.splitlines()[0].endswith(
            "'short': multisine: power has 3 values, the band holds 10 harmonics (one per "
            "harmonic, all inputs' in frequency order)")
    ms = multisine(2, 0.1, 1.0, 10.0, 0.02, amplitude=[1.0, 0.5], power=np.arange(10, 0, -1.0))
    assert np.allclose(np.loadtxt(tmp_path / "p.dat")[:, 1:3], ms.u, atol=1e-12)
    assert not (tmp_path / "q.dat").exists()


def test_deck_schroeder_phases_as_the_python_api(tmp_path):
    """&simulate phases = 'schroeder' gives multisine(iterations=0), whose RPF
    the optimised default beats on every input; an unknown word: one line."""
    import json
    from conftest import run_both
    case = """&case title = '{title}', job = 'simulate' /
&model kind = 'linear', nx = 2, nu = 3, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.2, 0.1, 0.5, 0.5,  h = 1, 0, 0, 1 /
&simulate out = '{title}.dat', t_end = 20.0, dt = 0.02, input_shape = 'multisine',
    amplitude = 1.0, 1.0, 1.0, f_min = 0.1, f_max = 1.5{phases} /
"""
    deck = tmp_path / "phases.nml"
    deck.write_text(case.format(title="schroeder", phases=", phases = 'Schroeder'")
                    + case.format(title="optimised", phases="")
                    + case.format(title="bad", phases=", phases = 'random'"))
    runs = run_both(deck, "--json", "{exe}.json", cwd=tmp_path)
    assert runs[0].stdout == runs[1].stdout
    for run in runs:
        assert run.stderr.splitlines()[0].endswith(
            "'bad': group &simulate: phases must be 'optimised' (least relative peak factor) "
            "or 'schroeder', not 'random'")
    ref = multisine(3, 0.1, 1.5, 20.0, 0.02, iterations=0)
    assert np.allclose(np.loadtxt(tmp_path / "schroeder.dat")[:, 1:4], ref.u, atol=1e-12)
    cases = json.loads((tmp_path / "mlid.json").read_text())
    schroeder = [i["rpf"] for i in cases[0]["inputs"]]
    optimised = [i["rpf"] for i in cases[1]["inputs"]]
    assert all(o < s for o, s in zip(optimised, schroeder)), (optimised, schroeder)
