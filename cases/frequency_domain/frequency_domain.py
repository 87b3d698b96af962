"""Time domain and frequency domain side by side (issue 19): the C-8 short
period, the HL-10 lateral model (both simulated) and the real ATTAS lateral
record, each fitted by time-domain output error and by frequency-domain
output error and equation error; the estimates with their Cramer-Rao sigma
and their difference in units of the combined sigma sqrt(s_td^2 + s_fd^2).
On the simulated records, a constant bias and a slow drift added to every
measured output: the time-domain fit without bias parameters is pulled off,
the one with biases and drift rates modelled is not, and the
frequency-domain fits do not move.  The ATTAS fits against the reference
file's time-domain estimates, and the Bode plots of the identified model
against the record's measured frequency response with coherence.

    python cases/frequency_domain/frequency_domain.py [--plots DIR] [--quick]

--quick leaves out the ATTAS part.  Every number README.md
quotes is printed here; where it comes from: README.md in this folder.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.report import plots
from mlid.cli.deck import iter_deck
from mlid.report.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
REF = DATA / "refs" / "attas_lat_ailrud2_tc01model_fvsysid_octave.txt"
sys.path.insert(0, str(HERE.parent / "hl10_lateral"))
import hl10  # noqa: E402  (the HL-10 lateral model, its truth and start values: one place)

FDOE, FDEE = "frequency_output_error", "frequency_equation_error"
METHODS = {"output_error": "TD OE", FDOE: "FD OE", FDEE: "FD EE"}
# The bands (ours): C-8 from 0.6/T (T = 6 s; below 1/T the transient terms
# take up what is there) past the short period (0.22 Hz); HL-10 from near its
# roll mode (0.03 Hz) past the Dutch roll (0.59 Hz); the modes: modes_line.
C8_BAND = dict(f_min=0.1, f_max=2.0, n_freq=40)
HL10_BAND = dict(f_min=0.05, f_max=2.0, n_freq=80)
# The HL-10 record for this case (ours): hl10.py's 3211 aileron, the yaw
# damper off and a 2 deg rudder doublet (hl10.py's weak one, with the damper,
# is its case of confounded derivatives), 15 s at 50/s, seed 1.
HL10_RECORD = dict(k_yaw=0.0, rudder=2.0, nt=750, seed=1)
# The bias and drift added to every output (ours): C-8 in the outputs' units
# (u ft/s, theta rad, q rad/s, alpha rad: biases 0.8 to 3.2 noise sigmas,
# drifts 0.3 to 1.6 over the record), the drift given as its total over the
# record; HL-10 in noise sigmas.
C8_BIAS = np.array([1.0, 0.02, 0.005, 0.02])
C8_DRIFT = np.array([0.5, 0.01, 0.002, 0.01])
HL10_BIAS, HL10_DRIFT = 10.0, 10.0
# How far the frequency-domain estimates may move with bias and drift, in
# sigma: the transient terms take both up exactly, so what moves them is
# rounding carried through the iterations (1e-15 to 1e-7 here, varying with
# the compiler); the bound tests/test_frequency_cases.py asserts.
FD_MOVED_BOUND = 1e-6


def deck_fits(path):
    """Every estimate case of a deck run through the Python front end: the
    fits, keyed by method."""
    fits = {}
    for case, _, res, error in iter_deck(path):
        if error:
            sys.exit(f"{case.where()}: {error}")
        if res is not None:
            fits[METHODS[case.options()["method"]]] = res
    return fits


def pick(fit, names, what="estimate"):
    """The fit's estimate (or sigma, sigma_corrected) of the named parameters."""
    return np.asarray(getattr(fit, what))[[list(fit.names).index(n) for n in names]]


def side_by_side(fits, base="TD OE", reference=None, scale=None):
    """Rows: estimate ± sigma of each fit (label: fit), then each other
    fit's difference from base's in units of the combined sigma
    sqrt(s_base^2 + s^2) (each sigma times scale, per parameter, when
    given).  The derivatives the frequency domain estimates; the time
    domain's biases are left out.  Also the largest |difference| of each."""
    names = list(fits["FD OE"].names)
    others = [k for k in fits if k != base]
    head = f"{'':8s}" + "".join(f"{k:>22s}" for k in fits)
    head += f"{'reference (TD)':>22s}" if reference is not None else ""
    head += "".join(f"{'(' + k + '-' + base + ')/sc':>{max(14, len(k) + len(base) + 8)}s}"
                    for k in others)
    lines, diff = [head], {}
    c = np.ones(len(names)) if scale is None else scale
    for k in others:
        diff[k] = (pick(fits[k], names) - pick(fits[base], names)) / (
            c * np.hypot(pick(fits[k], names, "sigma"), pick(fits[base], names, "sigma")))
    for i, name in enumerate(names):
        row = f"{name:8s}" + "".join(f"{pick(r, [name])[0]:>12.5g} ± "
                                     f"{pick(r, [name], 'sigma')[0]:<7.2g}" for r in fits.values())
        if reference is not None:
            row += "{:>12.5g} ± {:<7.2g}".format(*reference.estimates[name])
        row += "".join(f"{diff[k][i]:>{max(14, len(k) + len(base) + 8)}.2f}" for k in others)
        lines.append(row)
    worst = {k: float(np.max(np.abs(d))) for k, d in diff.items()}
    lines.append("largest |difference| / combined sigma: " + ", ".join(
        f"{k} {v:.2f}" for k, v in worst.items()))
    return lines, worst


def with_bias_and_drift(model, data):
    """The model with an output bias and a drift rate for every output free
    (the drift as an input t - t0 entering the outputs only, D's new
    column), and the record with that input: the time domain's way of
    modelling what the frequency domain's transient terms hold."""
    m = model
    ny, nu = m.ny, m.nu
    G = np.column_stack([m.G, np.zeros(m.nx)])
    D = np.column_stack([m.D, np.zeros(ny)])
    free = list(m.free) + [f"bias({i + 1})" for i in range(ny)] + \
        [f"d({i + 1},{nu + 1})" for i in range(ny)]
    names = dict(m.names) if isinstance(m.names, dict) else {}
    names.update({f"d({i + 1},{nu + 1})": f"drift({i + 1})" for i in range(ny)})
    out = mlid.LinearModel(m.F, G, m.H, D, x0=m.x0, free=free, names=names, ties=m.ties)
    ramp = data.t - data.t[0]
    return out, mlid.FlightData(data.t, np.column_stack([data.u, ramp]), data.y,
                                list(data.input_names) + ["t"], list(data.output_names))


def spoil(data, bias, drift):
    """The record with a constant bias and a linear drift (drift per second)
    added to every measured output."""
    t = data.t - data.t[0]
    return mlid.FlightData(data.t, data.u, data.y + bias + np.outer(t, drift),
                           list(data.input_names), list(data.output_names))


def bias_drift_table(start, spoiled, band, clean_fits):
    """Each method on the spoiled record: how far its derivatives moved from
    the same method's on the clean record (the time domain's with biases
    and drifts: from the clean TD OE fit), in that clean fit's sigma; how
    far from the clean TD OE fit in the combined sigma; its sigma over the
    clean TD OE fit's.  Returns the lines and {label: largest |moved|}."""
    names = list(clean_fits["FD OE"].names)
    td = clean_fits["TD OE"]
    runs = [("TD OE, no bias parameters", "TD OE", start, spoiled, {}),
            ("TD OE, biases and drifts modelled", "TD OE",
             *with_bias_and_drift(start, spoiled), {}),
            ("FD OE", "FD OE", start, spoiled, dict(method=FDOE, **band)),
            ("FD EE", "FD EE", start, spoiled, dict(method=FDEE, **band))]
    lines = [f"{'':35s}{'max|moved|/s':>13s}{'max|-TD|/sc':>12s}{'s/s_TD':>12s}"
             "   moved/s per derivative"]
    moved = {}
    for label, clean, model, data, opts in runs:
        res = mlid.fit(model, data, **opts)
        ref = clean_fits[clean]
        d = (pick(res, names) - pick(ref, names)) / pick(ref, names, "sigma")
        dt = (pick(res, names) - pick(td, names)) / np.hypot(pick(res, names, "sigma"),
                                                             pick(td, names, "sigma"))
        ratio = pick(res, names, "sigma") / pick(td, names, "sigma")
        moved[label] = float(np.max(np.abs(d)))
        lines.append(f"{label:35s}{moved[label]:>13.3g}{np.max(np.abs(dt)):>12.3g}"
                     f"{ratio.min():>6.2f}-{ratio.max():<5.2f}  " + " ".join(f"{v:+.2g}" for v in d)
                     + ("" if res.converged else f"  (not converged: {res.reason})"))
    fd = max(moved["FD OE"], moved["FD EE"])
    lines.append(f"frequency domain moved at most {fd:.3g} sigma: "
                 f"{'below' if fd < FD_MOVED_BOUND else 'NOT below'} the bound {FD_MOVED_BOUND:g}")
    return lines, moved


def modes_line(fit):
    """The eigenvalues of the fitted model's F, rad/s and their |.| in Hz."""
    ev = np.linalg.eigvals(fit.model.F)
    ev = ev[np.argsort(-np.abs(ev))]
    return "modes of the TD OE model: " + ", ".join(
        f"{e.real:.3g}{e.imag:+.3g}j rad/s ({abs(e) / (2 * np.pi):.3g} Hz)" if e.imag else
        f"{e.real:.3g} rad/s ({abs(e) / (2 * np.pi):.3g} Hz)" for e in ev if e.imag >= 0)


def print_block(title, lines):
    print(f"\n{title}\n" + "\n".join(lines))


def sigma_ratio_line(fits, base="TD OE"):
    names = list(fits["FD OE"].names)
    return "sigma over the TD OE sigma: " + ", ".join(
        f"{k} {np.min(r):.2f} to {np.max(r):.2f}" for k, r in (
            (k, pick(f, names, "sigma") / pick(fits[base], names, "sigma"))
            for k, f in fits.items() if k != base))


def c8():
    """The C-8 short period: the deck's three fits, then bias and drift."""
    fits = deck_fits(HERE / "c8_frequency.nml")
    lines, worst = side_by_side(fits)
    print_block("C-8 short period (c8_frequency.nml): estimate ± Cramér-Rao sigma", lines)
    print(sigma_ratio_line(fits))
    print(modes_line(fits["TD OE"]))
    clean = mlid.FlightData.load(HERE / "c8_doublet.dat", time_col=1, input_cols=[2],
                                 output_cols=[3, 4, 5, 6])
    start = next(c for c in mlid.read_deck(HERE / "c8_frequency.nml")
                 if c.job == "estimate").model
    bias, drift = C8_BIAS, C8_DRIFT / (clean.t[-1] - clean.t[0])
    print(f"\nbias {bias.tolist()} and drift {drift.round(6).tolist()} per s added to "
          "(u [ft/s], theta [rad], q [rad/s], alpha [rad])")
    table, moved = bias_drift_table(start, spoil(clean, bias, drift), C8_BAND, fits)
    print_block("C-8 with bias and drift (estimates moved from the same method's on the clean "
                "record):", table)
    return fits, worst, moved


def hl10_start():
    """The 13 free derivatives of hl10.py at its wind-tunnel values (the
    truth 20% off); the fixed ones (Y_p, Y_r) at Table 5.3's, so that the
    model's structure is right and both domains fit the same model."""
    values = dict(hl10.WT, **{n: v for n, v in hl10.wind_tunnel().items() if n in hl10.ELEMENT})
    return mlid.LinearModel(*hl10.matrices(values), free=list(hl10.ELEMENT.values()),
                            names={e: n for n, e in hl10.ELEMENT.items()}, ties=hl10.TIES)


def hl10_case():
    """The HL-10 lateral model (yaw damper off), simulated; the same."""
    data = hl10.record(**HL10_RECORD)
    start = hl10_start()
    fits = {"TD OE": mlid.fit(start, data)}
    for method in (FDOE, FDEE):
        fits[METHODS[method]] = mlid.fit(start, data, method=method, **HL10_BAND)
    lines, worst = side_by_side(fits)
    print_block(f"HL-10 lateral ({data.nt} samples at {hl10.DT} s, yaw damper off): estimate ± "
                "Cramér-Rao sigma", lines)
    print(sigma_ratio_line(fits))
    print(modes_line(fits["TD OE"]))
    names = list(fits["FD OE"].names)
    truth = np.array([hl10.WT[n] for n in names])
    print("largest |estimate - truth (Table 5.3)| / sigma: " + ", ".join(
        f"{k} {np.max(np.abs(pick(f, names) - truth) / pick(f, names, 'sigma')):.2f}"
        for k, f in fits.items()))
    std = np.array(hl10.NOISE_STD)
    bias, drift = HL10_BIAS * std, HL10_DRIFT * std / (data.t[-1] - data.t[0])
    print(f"\nbias {HL10_BIAS:g} noise sigmas and a drift of {HL10_DRIFT:g} noise sigmas over the "
          f"record on every output (noise sigma {hl10.NOISE_STD}: p, r [deg/s], beta, phi [deg],"
          " a_y' [deg/s])")
    table, moved = bias_drift_table(start, spoil(data, bias, drift), HL10_BAND, fits)
    print_block("HL-10 with bias and drift (estimates moved from the same method's on the clean "
                "record):", table)
    return fits, worst, moved


def td_start_model():
    """attas_lat.nml's model at its start values."""
    return next(c for c in mlid.read_deck(HERE.parent / "attas_lateral" / "attas_lat.nml")
                if c.job == "estimate").model


def attas(plots_dir=None):
    """The real ATTAS lateral record: the time-domain deck of
    cases/attas_lateral against its reference, the same model on the two
    manoeuvres, the frequency-domain deck, and the Bode plots."""
    td = deck_fits(HERE.parent / "attas_lateral" / "attas_lat.nml")["TD OE"]
    fd = deck_fits(HERE / "attas_lat_frequency.nml")
    ref = read_reference(REF)
    print("\nATTAS lateral, time domain (../attas_lateral/attas_lat.nml) against the reference:")
    print("\n".join(compare(td, ref)["lines"]))
    td2 = mlid.fit(td_start_model(), fd["FD OE"].evaluate_args[0])
    fits = {"TD OE": td, "TD OE 2m": td2, **fd}
    lines, worst = side_by_side(fits, reference=ref)
    print_block("ATTAS lateral: estimate ± Cramér-Rao sigma (TD OE: attas_lat.nml, one record "
                "across the gap, 7 biases; TD OE 2m: the two manoeuvres, 7 biases each; FD: the "
                "two manoeuvres, attas_lat_frequency.nml)", lines)
    print(sigma_ratio_line(fits))
    print(modes_line(td))
    for k in ("TD OE 2m", "FD OE", "FD EE"):
        r = fits[k]
        print(f"{k}: {r.iterations} iterations, converged={r.converged}")
    names = list(fd["FD OE"].names)
    for k in ("FD OE", "FD EE"):
        rel = pick(fits[k], names) / pick(td, names) - 1
        d2 = (pick(fits[k], names) - pick(td2, names)) / np.hypot(
            pick(fits[k], names, "sigma"), pick(td2, names, "sigma"))
        i, j = np.argmax(np.abs(rel)), np.argmax(np.abs(d2))
        print(f"{k}: largest relative difference from TD OE {100 * rel[i]:+.1f}% ({names[i]}); "
              f"largest |difference| from TD OE 2m {abs(d2[j]):.2f} combined sigma ({names[j]})")
    scale = pick(td2, names, "sigma_corrected") / pick(td2, names, "sigma")
    print(f"TD OE 2m's sigma corrected for coloured residuals over its Cramér-Rao sigma: "
          f"{scale.min():.2f} to {scale.max():.2f}")
    lines2, worst2 = side_by_side({k: fits[k] for k in ("TD OE 2m", "FD OE", "FD EE")},
                                  base="TD OE 2m", scale=scale)
    print_block("the same on the same two manoeuvres, both sigmas scaled by TD OE 2m's "
                "coloured-residual factor:", lines2)
    if plots_dir is not None:
        bode(fd["FD OE"], Path(plots_dir))
    return fits, td2, worst, worst2


# The Bode plots' frequency range (ours): the Welch segment of 256 samples
# (10.24 s, resolution 0.098 Hz, 4 to 5 averages in a 30 s manoeuvre) and
# up to 5 Hz, past the fitted band (0.1 to 1.5 Hz) to where the coherence of
# the aileron manoeuvre falls.
BODE_SEGMENT, BODE_F_MAX = 256, 5.0
BODE_PAIRS = (("da", "p", 0, "aileron δa → roll rate p, aileron manoeuvre"),
              ("dr", "r", 1, "rudder δr → yaw rate r, rudder manoeuvre (measured r less the "
               "model's β and δa paths)"))


def below(resp, f_max):
    """The response's points at or below f_max Hz."""
    keep = resp.frequency <= f_max
    fields = {k: (v[keep] if isinstance(v, np.ndarray) and v.shape == keep.shape else v)
              for k, v in vars(resp).items()}
    return mlid.FrequencyResponse(**fields)


def other_paths_removed(fit, record, keep):
    """The record with the identified model's response to every input but
    keep taken out of the measured outputs (each input from its first
    value, from rest: the trim stays in the record and a segment's mean
    takes it).  With beta a measured input of the model, the model's r/dr
    holds beta still; the record's r moves with beta too (the Dutch roll),
    so its single-input response is the model's only with that path out."""
    u = record.u - record.u[0]
    k = list(record.input_names).index(keep)
    u[:, k] = 0.0
    others = mlid.simulate(fit.model, record.t, u)[0].y
    return mlid.FlightData(record.t, record.u, record.y - others, list(record.input_names),
                           list(record.output_names))


def bode(fit, out):
    """p/da from the aileron manoeuvre, r/dr from the rudder manoeuvre (with
    the model's beta and da paths out of r): the identified model with its
    ±2σ Cramér-Rao band against the record's response and coherence,
    written to out.  Returns {pair: summary} (path, the band's coherence,
    the model's 2σ and the rms of measured - model gain over 0.1-1.5 Hz)."""
    from mlid.files import atomic_savefig
    out.mkdir(parents=True, exist_ok=True)
    records = fit.evaluate_args[0]               # the two manoeuvres, as fitted
    summary = {}
    for u, y, k, title in BODE_PAIRS:
        rec = records[k] if k == 0 else other_paths_removed(fit, records[k], u)
        measured = below(mlid.record_response(rec, u, y, segment=BODE_SEGMENT), BODE_F_MAX)
        fig = plots.bode_measured(fit, u, y, measured=measured)
        fig.suptitle(f"ATTAS fAttasAilRud2: {title}\nmodel: FD output error over 0.1-1.5 Hz; "
                     f"measured: {measured.averages} averages of {measured.segment} samples",
                     fontsize=9)
        path = out / f"attas_bode_{y}_{u}.png"
        atomic_savefig(fig, path, dpi=130)
        band = measured.band(0.1, 1.5)
        mod = mlid.model_response(fit, measured.frequency[band], u, y)
        s = dict(path=path, averages=measured.averages,
                 shown=int(np.sum(measured.coherence >= plots.COHERENCE_SHOWN)),
                 points=measured.frequency.size, coherence=measured.coherence[band],
                 two_sigma=2 * mod.sigma_gain,
                 rms=float(np.sqrt(np.mean(np.square(measured.gain[band] - mod.gain)))))
        high = measured.band(1.5, None, plots.COHERENCE_SHOWN)
        s["above"] = float(np.max(measured.gain[high] - mlid.model_response(
            fit, measured.frequency[high], u, y).gain))
        summary[f"{y}/{u}"] = s
        print(f"wrote {path}: {s['averages']} averages, coherence >= {plots.COHERENCE_SHOWN} at "
              f"{s['shown']} of {s['points']} points up to {BODE_F_MAX:g} Hz; over the fitted "
              f"band 0.1-1.5 Hz: coherence {s['coherence'].min():.2f} to "
              f"{s['coherence'].max():.2f}, model gain 2σ {s['two_sigma'].min():.2f} to "
              f"{s['two_sigma'].max():.2f} dB, measured - model gain rms {s['rms']:.2f} dB; "
              f"above 1.5 Hz (coherence >= {plots.COHERENCE_SHOWN}) the measured gain up to "
              f"{s['above']:.1f} dB above the model's")
    return summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plots", help="directory to write the ATTAS Bode plots to")
    ap.add_argument("--quick", action="store_true", help="leave out the ATTAS record")
    args = ap.parse_args(argv)
    c8()
    hl10_case()
    if not args.quick:
        if not REF.is_file():
            sys.exit(f"the reference is not at {REF}")
        attas(args.plots)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
