"""HFB-320 Hansa Jet from the real flight record: the deck hfb320.nml run
through the Python front end, the output-error estimates compared with the
reference of ../../../shared/data/README.md, the filter-error estimates with
the extended Kalman filter (case 3) and with the steady-state gain (case 4)
side by side, FVSysID's filter error ml_fem2 (case 5, the textbook criterion)
against its reference with mlid's innovations (case 6) and exact-ML (case 7)
criteria on the same model, and the results table (unit, estimate, Cramer-Rao and
coloured-residual sigma, relative sigma, flag) printed and exported as CSV,
LaTeX and JSON.  Every number README.md
quotes is printed here.

    python cases/hfb320/hfb320.py [OUT_DIR]     # exports into OUT_DIR (default: a temp dir)
"""

import re
import sys
import tempfile
from pathlib import Path

import numpy as np

from mlid import fit, read_deck
from mlid.cli.deck import iter_deck

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
FEM_REF = DATA / "refs" / "hfb320_fem_tc04_fvsysid_octave.txt"
NAMES = ["C_D0", "C_DV", "C_Dalpha", "C_L0", "C_LV", "C_Lalpha", "C_m0", "C_mV", "C_malpha",
         "C_mq", "C_mde"]


def reference():
    """The reference estimates and sigmas, and det R, from the data README's
    'Reference result' tables (in the order of NAMES)."""
    text = (DATA / "README.md").read_text(encoding="utf-8")
    part = text.split("### Reference result", 1)[1].split("\n## ", 1)[0]
    pairs = re.findall(r"(−?-?[\d.]+(?:e[−-]?\d+)?) \(([\d.]+)\)", part)
    values = np.array([float(v.replace("−", "-")) for v, _ in pairs])
    sigmas = np.array([float(s) for _, s in pairs])
    det_r = float(re.search(r"det\(R\) = ([\d.]+e−?-?\d+)", part).group(1).replace("−", "-"))
    return values, sigmas, det_r


def main(out_dir):
    if not (DATA / "hfb320_1_10.asc").is_file():
        sys.exit(f"the flight record is not at {DATA}")
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    results = {}
    for case, out, result, error in iter_deck(HERE / "hfb320.nml"):
        if error:
            sys.exit(f"{case.where()}: {error}")
        results[case.index] = result
        print(f"case {case.index}: {case.title}: {result.iterations} iterations, "
              f"converged={result.converged}, cost {result.cost:.1f}, det R {result.det_r:.6e}, "
              f"{1e3 * result.wall_time:.0f} ms")

    res = results[1]
    ref, ref_sigma, ref_det = reference()
    assert res.names == NAMES, res.names
    z = (res.estimate - ref) / ref_sigma
    print("\ncase 1 against the reference (data README):")
    print(f"{'parameter':<10}{'ours':>15}{'sigma':>12}{'reference':>13}{'sigma':>10}"
          f"{'diff/sigma':>12}{'sigma ratio':>13}")
    for k, name in enumerate(NAMES):
        print(f"{name:<10}{res.estimate[k]:15.7g}{res.sigma[k]:12.5g}{ref[k]:13.6g}"
              f"{ref_sigma[k]:10.3g}{z[k]:12.4f}{res.sigma[k] / ref_sigma[k]:13.4f}")
    print(f"largest |diff|/sigma {np.abs(z).max():.4f}; sigma ratios "
          f"{(res.sigma / ref_sigma).min():.4f} to {(res.sigma / ref_sigma).max():.4f}; "
          f"det R {res.det_r:.6e} against {ref_det:.4e} "
          f"(relative {abs(res.det_r / ref_det - 1):.1e})")

    # V's measurement-noise variance: R-hat of output error, the estimate r(1) of filter error
    r1_oe, r1_fe = res.rhat[0, 0], results[3].estimate[results[3].names.index("r(1)")]
    print(f"r(1), V: output error (case 1) {r1_oe:.3g}, filter error (case 3) {r1_fe:.3g}: "
          f"{r1_oe / r1_fe:.0f} times smaller; -J rises by {results[1].cost - results[3].cost:.1f}")

    compare_gains(results[3], results[4])
    compare_fem(results[5], results[6], results[7])

    for index in (1, 3):
        table = results[index].table()
        ratio = results[index].sigma_corrected / results[index].sigma
        print(f"\ncase {index} results table (coloured-residual correction to lag "
              f"{results[index].colored_lag}; corrected/CR sigma {ratio.min():.2f} to "
              f"{ratio.max():.2f}, {sum(r['flag'] for r in table.rows)} flagged):")
        print(table.text(), end="")
        for suffix in ("csv", "tex", "json"):
            path = Path(out_dir) / f"hfb320_case{index}.{suffix}"
            table.write(path)
            print(f"  wrote {path}")


def compare_gains(ekf, steady):
    """Case 3 (extended Kalman filter) and case 4 (the steady-state gain of
    the model linearised at the start of the record) side by side."""
    z = (steady.estimate - ekf.estimate) / ekf.sigma
    print("\ncase 3 (extended Kalman filter) against case 4 (steady-state gain, linearised "
          "about x0 and the first input sample):")
    print(f"{'parameter':<10}{'EKF':>14}{'sigma':>11}{'steady':>14}{'sigma':>11}"
          f"{'diff/sigma':>12}{'sigma ratio':>13}")
    for k, name in enumerate(ekf.names):
        print(f"{name:<10}{ekf.estimate[k]:14.6g}{ekf.sigma[k]:11.3g}{steady.estimate[k]:14.6g}"
              f"{steady.sigma[k]:11.3g}{z[k]:12.3f}{steady.sigma[k] / ekf.sigma[k]:13.4f}")
    print(f"-J: EKF {-ekf.cost:.2f}, steady {-steady.cost:.2f} (steady lower by "
          f"{steady.cost - ekf.cost:.2f}); iterations {ekf.iterations} and {steady.iterations}; "
          f"largest |diff|/sigma {np.abs(z).max():.3f} ({ekf.names[np.abs(z).argmax()]}); "
          f"sigma ratios {(steady.sigma / ekf.sigma).min():.4f} to "
          f"{(steady.sigma / ekf.sigma).max():.4f}")


def fem_reference():
    """FVSysID ml_fem2's estimates, sigmas, det R and Octave CPU seconds from
    the reference file's table and header (parameters in the deck's order)."""
    text = FEM_REF.read_text(encoding="utf-8")
    rows = re.findall(r"^\d+ (\w+) (\S+) (\S+)$", text, re.M)
    det_r = float(re.search(r"det\(R\) = (\S+),", text).group(1))
    cpu = float(re.search(r"Octave CPU ([\d.]+) s", text).group(1))
    return ([name for name, _, _ in rows], np.array([float(v) for _, v, _ in rows]),
            np.array([float(s) for _, _, s in rows]), det_r, cpu)


def compare_fem(textbook, innovations, exact):
    """Case 5 (noise_criterion = 'textbook') against FVSysID ml_fem2's
    reference: reference | mlid | verdict (within 0.1 sigma_ref, sigma within
    5%, det R within 1%); then cases 6 and 7 (mlid's ML criteria) on the same
    model, in sigma_ref from the reference."""
    names, ref, ref_sigma, ref_det, cpu = fem_reference()
    z = (textbook.estimate - ref) / ref_sigma
    ratio = textbook.sigma / ref_sigma
    print("\ncase 5 (noise_criterion = 'textbook') against FVSysID ml_fem2 (reference file):")
    print(f"{'parameter':<10}{'reference':>14}{'sigma_ref':>11}{'mlid':>14}{'sigma':>11}"
          f"{'diff/sigma_ref':>15}{'sigma ratio':>12}  verdict")
    for k, name in enumerate(names):
        ok = abs(z[k]) < 0.1 and abs(ratio[k] - 1) < 0.05
        print(f"{name:<10}{ref[k]:14.6g}{ref_sigma[k]:11.4g}{textbook.estimate[k]:14.6g}"
              f"{textbook.sigma[k]:11.4g}{z[k]:15.4f}{ratio[k]:12.4f}  {'ok' if ok else 'FAIL'}")
    print(f"det R {textbook.det_r:.6e} against {ref_det:.6e} (relative "
          f"{abs(textbook.det_r / ref_det - 1):.1e}; {'ok' if abs(textbook.det_r / ref_det - 1) < 0.01 else 'FAIL'}); "
          f"iterations {textbook.iterations} (FVSysID 12); largest |diff|/sigma_ref "
          f"{np.abs(z).max():.4f}; sigma ratios {ratio.min():.4f} to {ratio.max():.4f}; "
          f"{1e3 * textbook.wall_time:.0f} ms against FVSysID's {cpu} s of Octave CPU")
    # the same iteration run on to its fixed point (R-hat = R): mlid's default tol_cost
    case5 = read_deck(HERE / "hfb320.nml")[4]
    full = fit(case5.model, case5.record(), **{**case5.options(), "tol_cost": 1e-8})
    zf = (full.estimate - ref) / ref_sigma
    print(f"case 5 with tol_cost = 1e-8 (to the fixed point): {full.iterations} iterations, "
          f"largest |diff|/sigma_ref {np.abs(zf).max():.3f} ({names[int(np.abs(zf).argmax())]}), "
          f"det R {full.det_r:.6e} ({full.det_r / ref_det - 1:+.2%} from the reference), "
          f"R-hat/R - 1 up to {np.max(np.abs(np.diag(full.rhat) / full.r_innovations - 1)):.1e}")
    for index, res in ((6, innovations), (7, exact)):
        zz = (res.estimate[:len(names)] - ref) / ref_sigma
        k = int(np.abs(zz).argmax())
        print(f"case {index} ({res.names[9]} {res.estimate[9]:.4g}): cost {res.cost:.1f}, "
              f"largest |diff|/sigma_ref {np.abs(zz).max():.1f} ({names[k]}); "
              f"{res.iterations} iterations")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="hfb320_"))
