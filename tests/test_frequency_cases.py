"""cases/frequency_domain: time-domain and frequency-domain estimates side by
side (agreement within the combined sigma on simulated records, fixed seeds),
the frequency domain's immunity to output bias and drift against the time
domain's pull, the C-8 deck through both front ends, the real ATTAS record in
both domains and its Bode plots.

The difference of two unbiased estimates from the same record has a
standard deviation below the combined sigma sc = sqrt(s_td^2 + s_fd^2) (for
an efficient time-domain estimate, sqrt(s_fd^2 - s_td^2)): a bound of 2 sc
per derivative is beyond two standard deviations of it; equation error's
estimates carry the errors-in-variables bias of its noisy regressors
besides, hence 2.5 sc for it."""

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import mlid
from conftest import REPO, c8_record, c8_start, run_both

CASE = REPO / "cases" / "frequency_domain"
sys.path.insert(0, str(CASE))
import frequency_domain as fdc  # noqa: E402

ATTAS = REPO.parent / "shared" / "data" / "fAttasAilRud2.mat"
LIMIT = {"FD OE": 2.0, "FD EE": 2.5}


def combined(fits, names, k, base="TD OE"):
    """|k's estimates - base's| / combined sigma, per derivative."""
    return np.abs(fdc.pick(fits[k], names) - fdc.pick(fits[base], names)) / np.hypot(
        fdc.pick(fits[k], names, "sigma"), fdc.pick(fits[base], names, "sigma"))


@pytest.fixture(scope="module")
def c8_fits():
    """The deck's start values on conftest's C-8 record (c8.nml's: model,
    doublet, noise, seed 1), the three methods."""
    data = c8_record()
    fits = {"TD OE": mlid.fit(c8_start(), data)}
    for m in (fdc.FDOE, fdc.FDEE):
        fits[fdc.METHODS[m]] = mlid.fit(c8_start(), data, method=m, **fdc.C8_BAND)
    return data, fits


def test_c8_deck_both_front_ends_agree_within_combined_sigma(tmp_path):
    """c8_frequency.nml (copied: its simulate case writes the record next to
    it): the same report and JSON from `mlid run` and mlid-batch, all three
    fits converged, each frequency-domain estimate within LIMIT combined
    sigma of the time domain's."""
    deck = tmp_path / "c8_frequency.nml"
    shutil.copy(CASE / "c8_frequency.nml", deck)
    runs = run_both(deck, "--json", str(tmp_path / "{exe}.json"))
    assert runs[0].returncode == 0 and runs[0].stdout == runs[1].stdout, runs[0].stderr
    py, fo = (json.loads((tmp_path / f"{e}.json").read_text()) for e in ("mlid", "mlid-batch"))
    assert py == fo
    td, fdoe, fdee = py[1:]
    assert all(c["converged"] for c in (td, fdoe, fdee))
    for c, limit in ((fdoe, LIMIT["FD OE"]), (fdee, LIMIT["FD EE"])):
        d = np.abs(np.subtract(c["estimate"], td["estimate"])) / np.hypot(c["sigma"], td["sigma"])
        assert np.all(d < limit), (c["title"], d)


def test_c8_bias_and_drift(c8_fits):
    """The script's bias and drift on the C-8 record.  Frequency domain:
    exact (the transient terms hold an offset and a drift rate per output),
    moved below 1e-6 sigma (the Newton iteration's convergence).  Time
    domain without bias parameters: pulled off by more than 10 sigma.  Time
    domain with biases and drift rates modelled: a refit of the same noise
    with its sigma grown by at most 1.44 (the README's table), whose shift
    has a standard deviation of at most sqrt(1.44^2 - 1) = 1.04 sigma: below
    3 sigma."""
    data, fits = c8_fits
    spoiled = fdc.spoil(data, fdc.C8_BIAS, fdc.C8_DRIFT / (data.t[-1] - data.t[0]))
    _, moved = fdc.bias_drift_table(c8_start(), spoiled, fdc.C8_BAND, fits)
    assert moved["TD OE, no bias parameters"] > 10
    assert moved["TD OE, biases and drifts modelled"] < 3
    assert moved["FD OE"] < 1e-6 and moved["FD EE"] < 1e-6


def test_hl10_lateral_agrees_and_ignores_bias_and_drift():
    """The HL-10 lateral model (13 derivatives, the script's record and
    start values): each frequency-domain estimate within LIMIT combined
    sigma of the time domain's; with 10 noise sigmas of bias and of drift
    the frequency domain does not move (< 1e-6 sigma), the time domain
    without bias parameters moves by more than 10 sigma."""
    data = fdc.hl10.record(**fdc.HL10_RECORD)
    start = fdc.hl10_start()
    fits = {"TD OE": mlid.fit(start, data)}
    for m in (fdc.FDOE, fdc.FDEE):
        fits[fdc.METHODS[m]] = mlid.fit(start, data, method=m, **fdc.HL10_BAND)
    names = list(fits["FD OE"].names)
    assert len(names) == 13 and all(f.converged for f in fits.values())
    for k, limit in LIMIT.items():
        assert np.all(combined(fits, names, k) < limit), (k, combined(fits, names, k))
    std = np.array(fdc.hl10.NOISE_STD)
    span = data.t[-1] - data.t[0]
    spoiled = fdc.spoil(data, fdc.HL10_BIAS * std, fdc.HL10_DRIFT * std / span)
    _, moved = fdc.bias_drift_table(start, spoiled, fdc.HL10_BAND, fits)
    assert moved["TD OE, no bias parameters"] > 10
    assert moved["FD OE"] < 1e-6 and moved["FD EE"] < 1e-6


@pytest.mark.skipif(not ATTAS.is_file(), reason=f"{ATTAS} not here")
def test_attas_both_domains_and_bode(tmp_path):
    """The real ATTAS record: attas_lat.nml (time domain, one record) and
    attas_lat_frequency.nml (frequency domain, two manoeuvres) converge; the
    15 derivatives of the three lie within 10% of each other (measured 8.3%
    and 9.3%, Yp; the README); on the same two manoeuvres, with both sigmas
    scaled by the time-domain fit's coloured-residual factor, within 1.5
    combined sigma (measured 1.34 and 1.17).  The Bode plots are written,
    PNG files, the model's gain within 2 dB rms of the record's over the
    fitted band where the coherence is 0.85 or more (measured 0.97 and 1.20
    dB, coherence 0.87 to 1)."""
    fits, td2, _, worst2 = fdc.attas()
    names = list(fits["FD OE"].names)
    assert len(names) == 15 and all(f.converged for f in fits.values())
    for k in ("FD OE", "FD EE", "TD OE 2m"):
        rel = np.abs(fdc.pick(fits[k], names) / fdc.pick(fits["TD OE"], names) - 1)
        assert np.all(rel < 0.10), (k, rel)
    assert max(worst2.values()) < 1.5, worst2
    summary = fdc.bode(fits["FD OE"], tmp_path)
    assert set(summary) == {"p/da", "r/dr"}
    for s in summary.values():
        assert s["path"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert s["coherence"].min() > 0.85 and s["rms"] < 2.0, s
