"""ATTAS flight-path reconstruction: the decks tc22.nml (sensor biases),
tc22b.nml (and vane calibration), tc32.nml (biases per manoeuvre) and
tc33.nml (time delays, each manoeuvre's initial state free), FVSysID test
cases 22, its variant, 32 and 33, and compatibility.nml (tc22b by the kind),
run through the Python front end and compared with the reference fits of the
textbook software; every number README.md quotes is printed here.

    python cases/flight_path/flight_path.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid

from mlid.estimate import compatibility
from mlid.cli.deck import iter_deck
from mlid.report.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
DECKS = {"tc22.nml": "attas_fpr_tc22_fvsysid_octave.txt",
         "tc22b.nml": "attas_fpr_tc22b_albe_fvsysid_octave.txt",
         "tc32.nml": "attas_fpr_tc32_segbias_fvsysid_octave.txt",
         "tc33.nml": "attas_fpr_tc33_delays_fvsysid_octave.txt",
         "compatibility.nml": "attas_fpr_tc22b_albe_fvsysid_octave.txt"}


def against_reference(pqr_dot):
    """The largest |difference| of angular accelerations (the three records
    one after another) from the ones the reference used
    (refs/derived/attas_fpr_pqrdot.asc)."""
    ref = np.loadtxt(DATA / "refs" / "derived" / "attas_fpr_pqrdot.asc")[:, 2:5]
    return np.max(np.abs(np.vstack(pqr_dot) - ref))


def with_fourier_deriv(case, ends=0):
    """The records with inputs 7-9 made by the global Fourier deriv (mlid.deriv)
    of the rates (inputs 4-6) instead of deriv_local, but for the first and
    last `ends` samples, which keep deriv_local's; the fit, and per manoeuvre
    how far the integral of each angular acceleration is from the change of
    its rate, for the two (the local one holds its end samples)."""
    records = case.record()
    gaps = {"local": 0.0, "fourier": 0.0}
    for rec in records:
        rates = rec.u[:, 3:6]
        change = rates[-1] - rates[0]
        gaps["local"] = max(gaps["local"], gap(rec.t, rec.u[:, 6:9], change))
        fourier = np.column_stack([mlid.deriv(rec.t, rates[:, k]) for k in range(3)])
        gaps["fourier"] = max(gaps["fourier"], gap(rec.t, fourier, change))
        rec.u[ends:rec.nt - ends, 6:9] = fourier[ends:rec.nt - ends]
    return mlid.fit(case.model, records, **case.options()), gaps


def gap(t, rates_dot, change):
    """The largest |integral of a derivative over t - the change of its channel|."""
    return np.max(np.abs(np.trapezoid(rates_dot, t, axis=0) - change))


def largest_differences(rows):
    """The largest |estimate - reference| / reference sigma over every free
    parameter, and over the corrections alone (initial states left out)."""
    def worst(keep):
        z = {r[0]: abs(r[4]) for r in rows if keep(r[0])}
        name = max(z, key=z.get)
        return f"{z[name]:.4f} sigma ({name})"
    line = f"largest |difference|, all {len(rows)} parameters: {worst(lambda n: True)}"
    if any(r[0].startswith("x0") for r in rows):
        line += f"; the corrections alone: {worst(lambda n: not n.startswith('x0'))}"
    return line


def colored_factors(res):
    """sigma col. / Cramer-Rao sigma of each correction (initial states left
    out): how optimistic the Cramer-Rao sigma is on coloured residuals."""
    f = {n: sc / s for n, s, sc in zip(res.names, res.sigma, res.sigma_corrected)
         if not n.startswith("x0")}
    return ("sigma col. / sigma of the corrections: " + " ".join(f"{n} {v:.1f}" for n, v in f.items())
            + f"; {min(f.values()):.1f} to {max(f.values()):.1f}")


def refit_of_corrected(case, res):
    """The records with the estimated corrections undone, fitted again:
    how far from neutral each correction then stands."""
    again = mlid.fit(case.model, compatibility.corrected_record(res), **case.options())
    z = {n: abs(v - compatibility.neutral(n)) / s
         for n, v, s in zip(again.names, again.estimate, again.sigma) if not n.startswith("x0")}
    worst = max(z, key=z.get)
    others = max(v for n, v in z.items() if n != worst)
    return (f"every correction within {others:.2f} Cramer-Rao sigma of neutral but {worst} "
            f"({z[worst]:.2f})")


def main():
    if not (DATA / "refs" / DECKS["tc22.nml"]).is_file():
        sys.exit(f"the references are not under {DATA / 'refs'}")
    for deck, ref_name in DECKS.items():
        case, _, res, error = next(iter_deck(HERE / deck))
        if error:
            sys.exit(f"{case.where()}: {error}")
        ref = read_reference(DATA / "refs" / ref_name)
        print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged}")
        # each manoeuvre's initial state: x0_u#2 here, x0_u_s2 there
        cmp = compare(res, ref, {n: n.replace("#", "_s") for n in res.names})
        print("\n".join(cmp["lines"]))
        print(largest_differences(cmp["rows"]))
        print(f"diag R relative differences up to "
              f"{np.max(np.abs(np.diag(res.rhat) / ref.diag_r - 1)):.1e}")
        if deck == "tc22.nml":
            local = against_reference([rec.u[:, 6:9] for rec in case.record()])
            print(f"deriv_local's angular accelerations against the reference's: at most "
                  f"{local:.1e} rad/s^2 apart")
            fourier, gaps = with_fourier_deriv(case)
            other = compare(fourier, ref)
            print(f"with the Fourier deriv instead: {other['lines'][-1]}; "
                  + largest_differences(other["rows"]))
            swapped = compare(with_fourier_deriv(case, ends=3)[0], ref)
            print("the same with deriv_local's first and last 3 samples: "
                  + largest_differences(swapped["rows"]))
            print(f"integral of an angular acceleration over a manoeuvre against the change "
                  f"of its rate: deriv_local up to {gaps['local']:.1e} rad/s, Fourier deriv "
                  f"{gaps['fourier']:.1e} rad/s")
        print("\n".join(compatibility.significance(res)["lines"]))
        print(colored_factors(res))
        if deck == "tc32.nml":
            columns = [np.loadtxt(DATA / f"fAttas{n}_pqrDot.asc")[:, 45:48]
                       for n in ("Elv1", "Ail1", "Rud1")]
            print(f"the records' columns 46-48 (read by this deck's reference) against the "
                  f"angular accelerations of tc22's: at most {against_reference(columns):.1e} "
                  f"rad/s^2 apart; after its quirk (* pi/180) "
                  f"{against_reference(columns) * np.pi / 180:.1e}")
        if deck == "tc33.nml":
            print("time delays: " + ", ".join(
                f"{n} {1e3 * v:.2f} ms (sigma {1e3 * sd:.1f} ms)"
                for n, v, sd in zip(res.names, res.estimate, res.sigma) if n.startswith("tau")))
            print(f"the corrected records refitted: {refit_of_corrected(case, res)}")
        print(f"fit {1e3 * res.wall_time:.0f} ms in-process against the reference's {ref.seconds:.1f} s "
              f"(benchmarks/bench_references.py times it side by side)")


if __name__ == "__main__":
    main()
