"""Smoothing and differentiation of channels (fortran/numerics/mlid_smooth.f90):
the global Fourier smoother and its derivative against sums of sines with
known derivatives at three noise levels, the ends apart; the decks'
smooth()/deriv() in both front ends and their refusals; ATTAS's rates
against the textbook's angular accelerations (refs/derived/attas_fpr_pqrdot.asc)."""

import numpy as np
import pytest

import mlid
from conftest import REPO, both_front_ends_json, refused_by_both, run_both, two_case_deck

DATA = REPO.parent / "shared" / "data"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason="real flight data not beside the checkout")

DT = 0.02
T = np.arange(0, 40 + DT / 2, DT)                     # 2001 samples, 40 s
LINES = [(1.0, 0.2, 0.3), (0.5, 0.55, 1.1), (0.25, 1.1, 2.0)]   # amplitude, Hz, phase
TRUE = sum(a * np.sin(2 * np.pi * f * T + p) for a, f, p in LINES)
TRUE_DOT = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * T + p) for a, f, p in LINES)
ENDS = int(0.05 * T.size)                             # first and last 5% of the samples


def _rms(e):
    return float(np.sqrt(np.mean(e ** 2)))


def _errors(est, truth):
    """rms error over the middle 90% and over the first and last 5%."""
    e = est - truth
    return _rms(e[ENDS:-ENDS]), _rms(np.r_[e[:ENDS], e[-ENDS:]])


@pytest.mark.parametrize("sigma", [0.01, 0.05, 0.2])
def test_sums_of_sines_with_noise(sigma):
    """White noise sigma through the filter: every line of the signal lies
    below the cut-off, so the error is the noise the filter passes.  Passing
    the bins up to fc (the raised-cosine roll-off adds a quarter's half,
    1.125 fc) of the n - 1 up to Nyquist leaves rms sigma sqrt(2.25 fc dt)
    in the smoothed signal; in the derivative each passed bin is multiplied
    by w, whose mean square over 0 .. w_c is w_c^2/3, so sigma sqrt(2.25 fc
    dt) 2 pi fc / sqrt 3.  Measured (seed 7): smooth 1.07-1.08 and deriv
    1.15-1.17 times these in the middle; at the ends (the odd mirror's
    second derivative jumps there, its tail is cut) smooth up to 1.25 and
    deriv up to 2.3 times.  Bounds: 1.3 in the middle, 3 at the ends."""
    x = TRUE + sigma * np.random.default_rng(7).standard_normal(T.size)
    xs, fc = mlid.smooth(T, x, cutoff=True)
    xd = mlid.deriv(T, x)
    assert 1.1 < fc < 4.0                             # above the highest line, well below Nyquist
    band = sigma * np.sqrt(2 * 1.125 * fc * DT)
    band_dot = band * 2 * np.pi * fc / np.sqrt(3)
    mid, ends = _errors(xs, TRUE)
    mid_dot, ends_dot = _errors(xd, TRUE_DOT)
    print(f"sigma {sigma}: fc {fc:.3f} Hz; smooth rms {mid:.4g} (ends {ends:.4g}), band-limited "
          f"noise {band:.4g}; deriv rms {mid_dot:.4g} (ends {ends_dot:.4g}), {band_dot:.4g}")
    assert mid < 1.3 * band and ends < 3 * band
    assert mid_dot < 1.3 * band_dot and ends_dot < 3 * band_dot
    assert mid < sigma / 2                            # smoothing removes most of the noise


def test_noise_free_is_kept():
    """Without noise the spectrum never meets a floor: nothing is cut, the
    smoothed signal is the signal to rounding; the derivative's error (the
    mirror's second-derivative jump at the ends) stays near the ends."""
    xs, fc = mlid.smooth(T, TRUE, cutoff=True)
    xd = mlid.deriv(T, TRUE)
    mid_dot, ends_dot = _errors(xd, TRUE_DOT)
    assert fc > 20 and _rms(xs - TRUE) < 1e-12
    assert mid_dot < 1e-5 and ends_dot < 0.02


def test_a_line_and_a_given_cut_off():
    """The line through the end points is removed and added back: a ramp's
    derivative is its slope, at the ends too; a cut-off in Hz is used."""
    x = 3.0 + 0.5 * T
    assert np.allclose(mlid.deriv(T, x), 0.5, atol=1e-12)
    _, fc = mlid.smooth(T, TRUE, fc=0.8, cutoff=True)
    assert abs(fc - 0.8) < 1 / (2 * 40)


def test_bluestein_length():
    """A record whose mirror's length has a prime factor above 5 (999
    samples: 2 * 998 = 4 * 499) gives what the same record through the FFT
    gives, the one sample shorter record's mirror being 2^a 3^b 5^c-free
    too; checked against numpy's FFT directly."""
    n = 999
    t, x = T[:n], TRUE[:n] + 0.05 * np.random.default_rng(3).standard_normal(n)
    xs, fc = mlid.smooth(t, x, cutoff=True)
    slope = (x[-1] - x[0]) / (n - 1)
    xt = x - x[0] - slope * np.arange(n)
    m = 2 * (n - 1)
    y = np.fft.fft(np.r_[xt, -xt[-2:0:-1]])
    kc = round(fc * m * DT)
    r = max(2, kc // 4)
    k = np.abs(np.fft.fftfreq(m) * m)
    w = np.where(k <= kc, 1, np.where(k < kc + r, 0.5 * (1 + np.cos(np.pi * (k - kc) / r)), 0))
    assert np.allclose(xs, np.real(np.fft.ifft(w * y))[:n] + x[0] + slope * np.arange(n),
                       atol=1e-12)


@pytest.mark.parametrize("t, x, fc, message", [
    (T[:10], TRUE[:10], None, "smoothing needs at least 16 samples, 10 given"),
    (np.r_[T[:50], T[50:100] + 0.01], TRUE[:100], None, "sample 51: the time is not uniform"),
    (T, TRUE, -1.0, "fc must be a frequency > 0 in Hz"),
    (T, TRUE[:5], None, "t and x must be 1-D arrays of one length"),
])
def test_bad_arguments(t, x, fc, message):
    with pytest.raises(mlid.InputError, match=message):
        mlid.deriv(t, x, fc=fc)


DECK_CASE = """&case title = 'smoothed', job = 'estimate' /
&model kind = 'linear', nx = 2, nu = 2, ny = 2,
    f = -1.0, 0.5, -0.8, -2.0,   g = 1.0, 0.3, 0.0, 0.0,  h = 1, 0, 0, 1,
    free = 'f(1,1)', 'f(2,1)', 'g(1,1)', 'g(1,2)' /
&data file = '{file}', columns = 't', 'u', 'y1', 'y2', time_col = 't', input_cols = 'u', 'y1d',
    output_cols = 'y1s', 'y2', derived = {derived} /
"""


def test_deck_runs_identically_in_both_front_ends(tmp_path):
    """A fit taking a smoothed output and a differentiated input: the same
    report and JSON from mlid run and mlid-batch, and the channels the
    Python FlightData makes of the same record are mlid.smooth's/deriv's."""
    sim = tmp_path / "sim.nml"
    sim.write_text(two_case_deck().split("&case title = 'middle'")[0])
    assert run_both(sim, cwd=tmp_path)[0].returncode == 0
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK_CASE.format(file=tmp_path / "small.dat",
                                     derived="'y1s = smooth(y1)', 'y1d = deriv(y1)'"))
    fit = both_front_ends_json(deck, tmp_path)
    assert list(fit["parameters"]) == ["f(1,1)", "f(2,1)", "g(1,1)", "g(1,2)"]
    rec = np.loadtxt(tmp_path / "small.dat", comments=["#", "t"])
    d = mlid.FlightData.load(tmp_path / "small.dat", "t", ["u", "y1d"], ["y1s", "y2"],
                             columns=["t", "u", "y1", "y2"],
                             derived={"y1s": "smooth(y1)", "y1d": "deriv(y1)"})
    assert np.allclose(d.u[:, 1], mlid.deriv(rec[:, 0], rec[:, 2]), rtol=0, atol=1e-12)
    assert np.allclose(d.y[:, 0], mlid.smooth(rec[:, 0], rec[:, 2]), rtol=0, atol=1e-12)


@pytest.mark.parametrize("rows, derived, message", [
    (201, "'y1s = smooth(y3)', 'y1d = deriv(y1)'", "derived y1s: no channel named y3"),
    (201, "'y1s = 2*smooth(y1)', 'y1d = deriv(y1)'",
     "derived y1s: smooth() makes a channel of its own"),
    (201, "'y1s = smooth(y1 + y2)', 'y1d = deriv(y1)'",
     "smooth() takes one channel's name, not 'y1 + y2'"),
    (201, "'y1s = smooth_local(y1, 2)', 'y1d = deriv(y1)'",
     "derived y1s: smooth_local(): the local smoother takes no cut-off: its windows are fixed"),
    (201, "'y1s = smooth(y1)', 'y1d = 1 + deriv_local(y1)'",
     "derived y1d: deriv_local() makes a channel of its own"),
    (4, "'y1s = smooth_local(y1)', 'y1d = deriv_local(y1)'",
     "data file short.dat: derived channel y1s: local smoothing needs at least 5 samples, 4 given"),
    (201, "'y1s = smooth(y1, -2)', 'y1d = deriv(y1)'",
     "the cut-off in 'smooth(y1, -2)' must be a frequency > 0 in Hz"),
    (10, "'y1s = smooth(y1)', 'y1d = deriv(y1)'",
     "data file short.dat: derived channel y1s: smoothing needs at least 16 samples, 10 given"),
    (-1, "'y1s = smooth(y1)', 'y1d = deriv(y1)'",
     "data file short.dat line 21: derived channel y1s: the time is not uniform (step 0.025 s"),
])
def test_bad_uses_one_line_each(tmp_path, rows, derived, message):
    n = abs(rows) if rows > 0 else 40
    t = 0.02 * np.arange(n)
    if rows < 0:
        t[20:] += 0.005
    (tmp_path / "short.dat").write_text("".join(f"{v} {np.sin(v)} {np.cos(v)} {v}\n" for v in t))
    deck = tmp_path / "deck.nml"
    deck.write_text(DECK_CASE.format(file="short.dat", derived=derived))
    refused_by_both("deck.nml", message, cwd=tmp_path)


@needs_data
def test_attas_rates_against_the_textbooks_accelerations():
    """p, q, r of the three flight-path records (columns 7-9 of the
    *_pqrDot.asc copies, deg/s, as the .mat records; cases/flight_path/tc22.nml)
    differentiated and compared, in rad/s^2, with what the reference used
    (FVSysID ndiff_pqr, refs/derived/attas_fpr_pqrdot.asc): by the
    automatic cut-off and at 2.5 Hz, about where the reference's filter
    cuts.  Measured rms differences (rad/s^2): automatic 0.0028-0.049
    (worst: Ail1's p, whose cut-off the rule puts at 4.9 Hz, 14% of its
    rms), 2.5 Hz 0.0016-0.025 (Ail1's p, 7%), over the rows but the first and
    last 5% (the reference holds its first and last values there).  Bounds:
    20% and 10% of each
    reference channel's rms, or 0.005 rad/s^2 when that is more."""
    ref = np.loadtxt(DATA / "refs" / "derived" / "attas_fpr_pqrdot.asc")
    for seg, name in enumerate(["Elv1", "Ail1", "Rud1"], 1):
        rec = np.loadtxt(DATA / f"fAttas{name}_pqrDot.asc")
        r = ref[ref[:, 1] == seg]
        t = 0.04 * np.arange(rec.shape[0])            # the rebuilt time of the decks (dt = 0.04)
        for j, rate in enumerate("pqr"):
            x = rec[:, 6 + j] * np.pi / 180
            size = _rms(r[:, 2 + j])
            for fc, share in ((None, 0.2), (2.5, 0.1)):
                e = mlid.deriv(t, x, fc=fc) - r[:, 2 + j]
                ends = int(0.05 * e.size)
                diff = _rms(e[ends:-ends])
                print(f"{name} {rate}dot, cut-off {fc or 'auto'}: rms difference {diff:.3g} "
                      f"rad/s^2, {_rms(e):.3g} with the ends (reference rms {size:.3g})")
                assert diff < max(share * size, 0.005), (name, rate, fc)


def test_local_smoothing_is_exact_on_cubics_inside():
    """Spencer's 15 weights keep a cubic (their second moment is zero) and
    the 17-point central difference differentiates it exactly, so
    deriv_local is exact wherever both full formulas reach (8 + 8 samples
    from each end); the 5-point formulas toward the ends are not (their
    weights (7, 24, 34, 24, 7)/96 bias a curve by (104/96) x''(t) dt^2/2),
    and the two end samples are held: checked to be so."""
    t = 0.05 * np.arange(120)
    x = 0.3 - 1.2 * t + 0.4 * t**2 - 0.07 * t**3
    dx = -1.2 + 0.8 * t - 0.21 * t**2
    xs = mlid.smooth(t, x, method="local")
    xd = mlid.deriv(t, x, method="local")
    assert np.max(np.abs(xs[8:-8] - x[8:-8])) < 1e-12
    assert np.max(np.abs(xd[16:-16] - dx[16:-16])) < 1e-10
    assert np.max(np.abs(xs[3:8] - x[3:8])) > 1e-5       # the 5-point formula's bias
    assert np.all(xs[:3] == x[:3]) and np.all(xs[-3:] == x[-3:])
    assert xd[0] == xd[1] == xd[2] and xd[-1] == xd[-2] == xd[-3]
    with pytest.raises(mlid.InputError, match="takes no cut-off"):
        mlid.deriv(t, x, fc=2.0, method="local")
    with pytest.raises(mlid.InputError, match="method must be one of"):
        mlid.smooth(t, x, method="spline")


@needs_data
def test_deriv_local_remakes_the_textbooks_angular_accelerations():
    """deriv_local of the ATTAS rates (the .mat records, as the flight-path
    decks read them) against what the reference used (FVSysID ndiff_pqr,
    refs/derived/attas_fpr_pqrdot.asc), every sample, the ends included.
    Measured: 5.0e-11 rad/s^2 at most (the textbook prints its weights to 11
    digits; ours are computed), against accelerations of up to 0.5 rad/s^2."""
    ref = np.loadtxt(DATA / "refs" / "derived" / "attas_fpr_pqrdot.asc")
    for seg, name in enumerate(["Elv1", "Ail1", "Rud1"], 1):
        d = mlid.FlightData.load(DATA / f"fAttas{name}.mat", "T", ["pd", "qd", "rd"], ["PHI"],
                                 columns=["T[s]", "AXCG", "AYCG", "AZCG", "AYCKP", "AZCKP",
                                          "PRGX[deg/s]", "QRGY[deg/s]", "RRGZ[deg/s]", "PHI"],
                                 dt=0.04,
                                 derived={"pd": "deriv_local(PRGX)", "qd": "deriv_local(QRGY)",
                                          "rd": "deriv_local(RRGZ)"})
        r = ref[ref[:, 1] == seg][:, 2:5]
        assert d.u.shape == r.shape
        assert np.max(np.abs(d.u - r)) < 1e-9, name
