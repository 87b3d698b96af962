"""Online estimation against the textbook software's recursive estimators
(FVSysID chapter 7, ../shared/data/refs/recursive/): test case 11 by
Fourier-transform regression (tc11_ftr.nml) and by the augmented-state
extended and unscented Kalman filters (tc11_ekf.nml, and the same deck
with estimator 'ukf') as decks, both front ends run them alike, and test
case 23's six aerodynamic regressions by recursive least squares in
Python and as a deck (tc23_rls.nml), and their model structure by
stepwise regression as a deck (tc23_stepwise.nml); every number
README.md quotes is printed here.

    python cases/online/online.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.cli.deck import iter_deck

HERE = Path(__file__).resolve().parent
REFS = HERE.parents[2] / "shared" / "data" / "refs" / "recursive"
#: Test case 23's regressions, in the reference header's words, and the
#: regressor behind each parameter's suffix.
TC23 = {"CD": ["CD0", "CDal"], "CL": ["CL0", "CLal"], "Cm": ["Cm0", "Cmal", "Cmq", "Cmde"],
        "CY": ["CY0", "CYbe"], "Cl": ["Cl0", "Clbe", "Clp", "Clr", "Clda"],
        "Cn": ["Cn0", "Cnbe", "Cnp", "Cnr", "Cndr"]}
REGRESSOR = {"0": None, "al": "al", "be": "be", "q": "qn", "p": "pn", "r": "rn",
             "de": "de", "da": "da", "dr": "dr"}


def ftr_against_reference():
    import pandas as pd
    case, out, _, error = next(iter_deck(HERE / "tc11_ftr.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    ref = pd.read_csv(REFS / "hist_tc11_FTR.csv")
    names = out["parameters"]
    est, sig = np.array(out["estimates"]), np.array(out["sigma"])
    dev = np.abs(est - ref[names].to_numpy()) / ref[[f"sig_{n}" for n in names]].to_numpy()
    ratio = sig[-1] / ref[[f"sig_{n}" for n in names]].to_numpy()[-1]
    print(f"test case 11, FTR deck: {len(out['t'])} solves; largest |ours - reference| at any "
          f"solve {dev.max():.1e} sigma; sigma ratios at the last {ratio.min():.6f} to "
          f"{ratio.max():.6f}")
    print("  last solve: " + ", ".join(f"{n} {v:.6g} ({s:.3g})" for n, v, s in
                                       zip(names, est[-1], sig[-1])))
    print("  converged (within 2 sigma of the last from then on): " + ", ".join(
        f"{n} {c:.2f} s" for n, c in zip(names, out["converged"])))
    mine = mlid.online.ftr(*_tc11(), np.linspace(0.2, 1.48, 33), every=25, trim=10)
    later = mine.t >= 0.2 * mine.t[-1]
    dev1 = np.abs(mine.estimates - ref[names].to_numpy()) / \
        ref[[f"sig_{n}" for n in names]].to_numpy()
    print(f"  from sample 1 (mlid's default): largest |difference| after the first 20% "
          f"{dev1[later].max():.4f} sigma, at the last solve {dev1[-1].max():.4f} sigma")


def filters_against_reference():
    """The EKF deck, and the same deck with the unscented filter: every
    sample's estimates against the reference's history (its Zq is the
    deck's f(1,2) - 1)."""
    import pandas as pd
    names = ["Z0", "Zal", "Zq", "Zde", "M0", "Mal", "Mq", "Mde"]
    for estimator, ref_name in (("ekf", "EKF"), ("ukf", "UKF")):
        out = _deck_output("tc11_ekf.nml", estimator)
        ref = pd.read_csv(REFS / f"hist_tc11_{ref_name}.csv")
        est = np.array(out["estimates"])
        est[:, out["parameters"].index("Zq1")] -= 1.0
        order = [out["parameters"].index("Zq1" if n == "Zq" else n) for n in names]
        sig = ref[[f"sig_{n}" for n in names]].to_numpy()
        dev = np.abs(est[:, order] - ref[names].to_numpy()) / sig
        ratio = np.array(out["sigma"])[-1, order] / sig[-1]
        print(f"test case 11, {ref_name} deck: {len(out['t'])} samples; largest |ours - "
              f"reference| at any sample {dev.max():.1e} sigma; sigma ratios at the last "
              f"{ratio.min():.6f} to {ratio.max():.6f}")


def _deck_output(name, estimator=None):
    """The first case of a deck here, its data read from ../shared, run in a
    scratch folder (its history file goes there)."""
    import tempfile
    text = (HERE / name).read_text().replace("../../../shared", str(HERE.parents[2] / "shared"))
    if estimator:
        text = text.replace("estimator = 'ekf'", f"estimator = '{estimator}'")
    with tempfile.TemporaryDirectory() as tmp:
        deck = Path(tmp) / name
        deck.write_text(text)
        case, out, _, error = next(iter_deck(deck))
    if error:
        sys.exit(f"{case.where()}: {error}")
    return out


def efrls_against_reference():
    """tc11_efrls.nml against the EFRLS reference: relative differences
    (its sigma is no standard deviation: unit weights)."""
    import pandas as pd
    out = _deck_output("tc11_efrls.nml")
    ref = pd.read_csv(REFS / "hist_tc11_EFRLS.csv")
    names = ["Z0", "Zal", "Zq", "Zde", "M0", "Mal", "Mq", "Mde"]
    est = np.array(out["estimates"])
    est[:, out["parameters"].index("Zq1")] -= 1.0
    order = [out["parameters"].index("Zq1" if n == "Zq" else n) for n in names]
    rel = np.abs(est[:, order] - ref[names].to_numpy()) / np.abs(ref[names].to_numpy()[-1])
    checkpoints = [round(j * 1252 / 10) - 1 for j in range(1, 11)]
    print(f"test case 11, EFRLS deck: largest |ours - reference| / |final| at the ten "
          f"checkpoints {rel[checkpoints].max():.1e}, at the last sample {rel[-1].max():.1e}")


def _reference_table(name, count):
    lines = (REFS.parent / name).read_text().splitlines()
    start = next(i for i, s in enumerate(lines) if "estimate" in s and "crb_std" in s)
    rows = [s.split() for s in lines[start + 1:start + 1 + count]]
    return np.array([float(r[-2]) for r in rows]), np.array([float(r[-1]) for r in rows])


def held_out_cases():
    """Chapter 7's test cases 4 and 8, which no recursive reference holds:
    the filters' last estimates against the batch fits of the same records."""
    ref, sig = _reference_table("hfb320_fem_tc04_fvsysid_octave.txt", 11)
    for estimator in ("ekf", "ukf"):
        out = _deck_output("hfb320_ekf.nml", estimator)
        dev = np.abs(np.array(out["estimates"])[-1] - ref) / sig
        ratio = np.array(out["sigma"])[-1] / sig
        worst = out["parameters"][int(np.argmax(dev))]
        print(f"HFB-320 {estimator.upper()} (hfb320_ekf.nml): last estimates against the "
              f"filter-error fit, largest {dev.max():.2f} of its sigma ({worst}); sigma ratios "
              f"{ratio.min():.2f} to {ratio.max():.2f}")
    ref, _ = _reference_table("unstab_ac_tc06_regstart_fvsysid_octave.txt", 5)
    for estimator in ("ekf", "ukf"):
        out = _deck_output("unstable_ekf.nml", estimator)
        rel = np.abs(np.array(out["estimates"])[-1] - ref) / np.abs(ref)
        print(f"unstable aircraft {estimator.upper()} (unstable_ekf.nml): last estimates "
              f"against the output-error fit, largest {100 * rel.max():.2f}% "
              f"({out['parameters'][int(np.argmax(rel))]})")


def _tc11():
    cols = (["T[s]"] + [f"c{i}" for i in range(2, 8)] + ["QRGY[deg/s]"]
            + [f"c{i}" for i in range(9, 13)] + ["ALCG[deg]"] + [f"c{i}" for i in range(14, 22)]
            + ["DELV[deg]"])
    parts = [mlid.FlightData.load(REFS.parents[1] / n, "T", ["DELV"], ["ALCG", "QRGY"],
                                  columns=cols) for n in ("fAttasElv1.mat", "fAttasElv2.mat")]
    z = np.vstack([p.y for p in parts])
    return 0.04 * np.arange(len(z)), z, np.vstack([p.u for p in parts])


def rls_against_reference():
    import pandas as pd
    data = pd.read_csv(REFS / "data_tc23_RLS.csv")
    hist = pd.read_csv(REFS / "hist_tc23_RLS.csv")
    worst, worst_final = 0.0, 0.0
    for z, names in TC23.items():
        X = np.column_stack([np.ones(len(data)) if REGRESSOR[n[2:]] is None
                             else data[REGRESSOR[n[2:]]].to_numpy() for n in names])
        est = mlid.online.rls(X, data[z].to_numpy(), names=names, t=data["t"].to_numpy(),
                              p0=1e7 if z == "Cm" else 1e6)
        ref = hist[names].to_numpy()
        scale = np.abs(ref[-1])
        worst = max(worst, np.max(np.abs(est.estimates - ref) / scale))
        worst_final = max(worst_final, np.max(np.abs(est.estimates[-1] - ref[-1]) / scale))
    print(f"test case 23, RLS (lambda 1, P0 1e6 I, Cm 1e7 I): largest |ours - reference| at any "
          f"sample {worst:.1e} of the parameter's final size; at the last {worst_final:.1e}")


def rls_deck_against_reference():
    """tc23_rls.nml: the same regressions as a deck (equation error on the
    outputs of an equations model of no states)."""
    import pandas as pd
    import tempfile
    text = (HERE / "tc23_rls.nml").read_text()
    with tempfile.TemporaryDirectory() as tmp:
        deck = Path(tmp) / "tc23.nml"
        deck.write_text(text.replace("../../../shared", str(HERE.parents[2] / "shared")))
        case, out, _, error = next(iter_deck(deck))
    if error:
        sys.exit(f"{case.where()}: {error}")
    names = out["parameters"]
    est, sig = np.array(out["estimates"]), np.array(out["sigma"])
    ref = pd.read_csv(REFS / "hist_tc23_RLS.csv")[names].to_numpy()
    final, ref_sig = {}, {}
    rows = False
    for line in (REFS / "ref_tc23_RLS.txt").read_text().splitlines():
        rows = line.startswith("# [final]") or (rows and not line.startswith("#"))
        if rows and not line.startswith("#") and line.split():
            f = line.split()
            final[f[0]], ref_sig[f[0]] = float(f[1]), float(f[2])
    want = np.array([final[n] for n in names])
    ratio = sig[-1] / np.array([ref_sig[n] for n in names])
    print(f"test case 23, RLS deck: {len(out['t'])} samples; largest |ours - reference| / |final| "
          f"at the last sample {np.max(np.abs(est[-1] - want) / np.abs(want)):.1e} (the table's "
          f"10 digits), at any sample {np.max(np.abs(est - ref) / np.abs(want)):.1e}; sigma "
          f"(ours, a-posteriori residuals) / the reference's LS_Stat {ratio.min():.3f} to "
          f"{ratio.max():.3f}")
    conv = dict(zip(names, out["converged"]))
    print("  converged (within 2 sigma of the last from then on): " + ", ".join(
        f"{n} {conv[n]:.2f} s" for n in names))


def stepwise_deck():
    """tc23_stepwise.nml: each coefficient's terms from 47 candidates, by
    each method (the deck's, then the same deck with 'backward' and 'mof'),
    against the reference's linear model."""
    import tempfile
    reference = {"CD": ["al"], "CL": ["al"], "Cm": ["al", "qn", "de"], "CY": ["be"],
                 "Cl": ["be", "pn", "rn", "da"], "Cn": ["be", "pn", "rn", "dr"]}
    text = (HERE / "tc23_stepwise.nml").read_text()
    # each method with the thresholds it takes (the deck refuses one it does not use)
    settings = {"forward": "method = 'forward', f_in = 20, f_out = 20",
                "backward": "method = 'backward', f_out = 20", "mof": "method = 'mof'"}
    for method in ("forward", "backward", "mof"):
        with tempfile.TemporaryDirectory() as tmp:
            deck = Path(tmp) / "tc23.nml"
            deck.write_text(text.replace("../../../shared", str(HERE.parents[2] / "shared"))
                            .replace(settings["forward"], settings[method]))
            case, out, _, error = next(iter_deck(deck))
        if error:
            sys.exit(f"{case.where()}: {error}")
        rule = {"forward": "F_in = F_out = 20", "backward": "F_out = 20",
                "mof": "least PSE"}[method]
        print(f"test case 23, stepwise deck, {method} ({rule}), {len(out['candidates'])} "
              "candidates:")
        for o in out["outputs"]:
            missing = [r for r in reference[o["output"]] if r not in o["selected"]]
            print(f"  {o['output']}: {len(o['selected'])} terms, R2 {o['r2']:.4f}, PSE "
                  f"{o['pse']:.3g}; the reference's regressors "
                  + ("all kept" if not missing else "kept except " + ", ".join(missing))
                  + "; the first steps: " + ", ".join(o["path"]["term"][1:4]))


def main():
    if not (REFS / "hist_tc11_FTR.csv").is_file():
        sys.exit(f"the references are not under {REFS}")
    ftr_against_reference()
    filters_against_reference()
    efrls_against_reference()
    held_out_cases()
    rls_against_reference()
    rls_deck_against_reference()
    stepwise_deck()


if __name__ == "__main__":
    main()
