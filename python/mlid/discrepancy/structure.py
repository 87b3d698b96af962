"""What structure a fit's residuals still hold, by channel (issue 47 item 3):
the structure an effect must explain before mlid.diagnose accepts it, and
what it reports as not explained when no candidate does.

Two kinds, each with its own test at a stated false-alarm rate:

    spectral peak     a residual's Welch spectrum (the core's, through
                      mlid.frequency.record_response) above its running
                      median by the chi-square point of its averages at
                      PEAK_ALPHA over the bins and outputs tested, above
                      the line fitted to the log spectrum nearby (a
                      structural mode, an oscillation of the sensor);
                      smooth colour (AR(1) noise) makes no peak
    input correlation the residual correlated with a clipped input
                      sat(u, b) = min(max(u, -b), b): the input's small
                      values (a dead-zone or backlash), tested by
                      mlid.diagnose as a refit (_probes there) with the
                      colour-corrected likelihood ratio

Each Structure has a channel (the output), where (the frequency or the
input), its size over its test's point (excess >= 1: significant) and the
text the report gives.
"""

import math

import numpy as np

from ..data.flight_data import FlightData
from ..errors import MlidError
from ..frequency.responses import record_response

#: false-alarm rate of the spectral-peak test over every bin and output
PEAK_ALPHA = 0.05
#: bins nearest 0 Hz not tested: drift and a mean, not a peak
LOW_BINS = 2
#: half-width of the running median that is a bin's background, in bins
#: (itself and its neighbours left out: a peak's Hann window spans three)
BACKGROUND_BINS = 6
#: the averages' degrees of freedom are taken as 2 per segment that does not
#: overlap another (N / L), not Welch's 2 n_d / (1 + 2 c^2) of the
#: overlapping ones: neighbouring bins of Hann windows share their errors,
#: which the background's line does not see, and with Welch's count the null
#: records gave false peaks (gust record, seed 2: 3.0 against a point of 2.9)
#: an effect explains a structure when it removes at least this share of
#: its excess over its test's point (or makes it insignificant)
MARGIN = 0.5


class Structure:
    """One structure left in the residuals.

    Attributes
    ----------
    kind : str
        'spectral peak' or 'input correlation'.
    output : int
        The channel (0-based output).
    channel : str
        Its name.
    frequency : float or None
        The peak's frequency [Hz].
    size, point : float
        The statistic (peak over background; 2dJ over its colour factor)
        and the test's point; excess = size / point.
    text : str
        What the report says of it.
    bin : int or None
        The peak's bin of the Welch spectrum.
    probe, score_point : Candidate, float or None
        An input correlation's probe (mlid.diagnose's) and the point its
        score is judged against, to tell whether an effect removes it.
    probe_best : float or None
        The largest score (for colour) over every probe at the fit: an
        effect explains the correlation when it leaves every probe below
        score_point.
    test : str
        The test whose point ``point`` is (its level and what it is
        divided over).
    """

    def __init__(self, kind, output, channel, size, point, text, frequency=None, bin=None,
                 probe=None, score_point=None, test="", probe_best=None):
        self.test, self.probe_best = test, probe_best
        self.kind, self.output, self.channel = kind, output, channel
        self.size, self.point, self.text = float(size), float(point), text
        self.frequency, self.bin = frequency, bin
        self.probe, self.score_point = probe, score_point

    @property
    def excess(self):
        return self.size / self.point

    def as_dict(self):
        return {"kind": self.kind, "channel": self.channel,
                "frequency": None if self.frequency is None else float(self.frequency),
                "statistic": self.size, "point": self.point, "test": self.test,
                "text": self.text}

    def __repr__(self):
        return f"Structure({self.text})"


def spectrum(t, e):
    """(frequency, Welch spectrum, degrees of freedom) of one residual, the
    Nyquist bin left out (a one-sided spectrum does not double it)."""
    rec = FlightData(t, e.reshape(-1, 1), e.reshape(-1, 1), ["e"], ["e"])
    r = record_response(rec, 0, 0)
    return (np.asarray(r.frequency)[:-1], np.asarray(r.output_spectrum)[:-1],
            2.0 * max(1, len(e) // r.segment))


def peak_ratios(g, nu):
    """Each bin's spectrum over its background, and the factor the test's
    point takes for the background's own error.  The background is the
    straight line fitted to the log spectrum of BACKGROUND_BINS neighbours
    each side (itself and the next ones left out): a slope (AR(1) colour,
    the model's own roll-off) is followed, a peak is not.  Log chi-square
    has the sd sqrt(trigamma(nu/2)) and the mean log(2/nu) + digamma(nu/2)
    below the log spectrum; the line's error at the bin widens the point by
    exp(2 se).  NaN in the LOW_BINS."""
    from scipy.special import digamma, polygamma
    n = len(g)
    ratio, widen = np.full(n, np.nan), np.ones(n)
    sd = math.sqrt(float(polygamma(1, nu / 2.0)))
    shift = math.log(2.0 / nu) + float(digamma(nu / 2.0))
    logg = np.log(np.maximum(g, np.finfo(float).tiny))
    for k in range(LOW_BINS, n):
        near = np.array([j for j in range(max(0, k - BACKGROUND_BINS),
                                          min(n, k + BACKGROUND_BINS + 1)) if abs(j - k) > 1])
        if near.size < 3:
            continue
        x = near - k
        a = np.column_stack([np.ones(near.size), x])
        coef, *_ = np.linalg.lstsq(a, logg[near], rcond=None)
        se = sd * math.sqrt(float(np.linalg.inv(a.T @ a)[0, 0]))
        ratio[k] = math.exp(logg[k] - (coef[0] - shift))
        widen[k] = math.exp(2.0 * se)
    return ratio, widen


def peak_point(nu, tested, alpha=PEAK_ALPHA):
    """The ratio a bin must exceed over a known background: chi-square(nu)
    / nu's upper point at alpha / tested (Bonferroni)."""
    from scipy.special import chdtri
    return float(chdtri(nu, alpha / tested) / nu)


def peaks(res, names=None, alpha=PEAK_ALPHA):
    """The significant spectral peaks of a fit's residuals (one per output
    at most: its largest), as Structures."""
    e = np.asarray(res.residuals, dtype=float)
    t = np.asarray(res.data.t, dtype=float)
    names = names or list(res.data.output_names or [f"y{i + 1}" for i in range(e.shape[1])])
    found = []
    spectra = []
    try:
        for i in range(e.shape[1]):
            spectra.append(spectrum(t, e[:, i]))
    except MlidError:                      # a record too short for Welch: no peaks tested
        return []
    tested = sum(max(len(g) - LOW_BINS, 0) for _, g, _ in spectra)
    for i, (f, g, nu) in enumerate(spectra):
        ratio, widen = peak_ratios(g, nu)
        excess = ratio / (peak_point(nu, max(tested, 1), alpha) * widen)
        if not np.any(np.isfinite(excess)):
            continue
        k = int(np.nanargmax(excess))
        point = peak_point(nu, max(tested, 1), alpha) * widen[k]
        if ratio[k] > point:
            found.append(Structure("spectral peak", i, names[i], ratio[k], point,
                                   f"{names[i]} residual peak at {f[k]:.3g} Hz",
                                   frequency=float(f[k]), bin=k,
                                   test=f"peak over background at {alpha:g} over {tested} bins "
                                        "of all outputs"))
    return found


def peak_left(res, s):
    """The ratio at structure s's bin in another fit's residuals (of the
    same record)."""
    e = np.asarray(res.residuals, dtype=float)[:, s.output]
    _, g, nu = spectrum(np.asarray(res.data.t, dtype=float), e)
    r = peak_ratios(g, nu)[0][s.bin]
    return float(r) if math.isfinite(r) else 0.0


def explained(before, after):
    """Does a statistic fall from before to after by MARGIN of its excess
    over the point (or below the point)?  before, after: (size, point)."""
    size, point = before
    return after < point or size - after >= MARGIN * (size - point)
