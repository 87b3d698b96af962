"""ATTAS CD, CL and Cm as tables in alpha from real records (README.md): the
deck attas_alpha_tables.nml through the Python front end, case 1 against
FVSysID test case 23, the tables of cases 2 and 3 against the reference
fits where they overlap (the test case 23 lines, the test case 27 stall
model), what each record covers in alpha, which table values are weakly
or not identified, and the figure of the tables with their bands.  Every
number README.md quotes is printed here.

    python cases/tables/attas_tables.py [figure.png]
"""

import re
import sys
from pathlib import Path

import numpy as np

from mlid.cli.deck import iter_deck
from mlid.report.reference import compare, read_reference
from mlid.report.table_fit_plots import FittedTables, table_fit_figure

HERE = Path(__file__).resolve().parent
DATA = HERE.parents[2] / "shared" / "data"
DECK = HERE / "attas_alpha_tables.nml"
TC23 = DATA / "refs" / "attas_aero_reg_tc23_fvsysid_octave.txt"
TC27 = DATA / "refs" / "attas_qst_tc27_fvsysid_octave.txt"
LONG = ["CD0", "CDal", "CL0", "CLal", "Cm0", "Cmal", "Cmq", "Cmde"]


def tc27_static(ref, al, de, mach):
    """The test case 27 model (its header) at its estimates with alpha
    steady (alphadot = 0: no hysteresis lag), at elevator de and Mach."""
    p = {n: v for n, (v, _) in ref.items()}
    c, lam = 3.159, 7.22
    cla = p["CL0"] + (p["CLal"] + p["CLM"] * mach) * al - p["Cmde"] * c / 15 * de
    x = (1 - np.tanh(p["a1"] * (al - p["alstar"]))) / 2
    return {"CDt": p["CD0"] + cla ** 2 / (p["e_osw"] * np.pi * lam) + p["CDX"] * (1 - x),
            "CLt": cla + p["CLal"] * al * (((1 + np.sqrt(x)) / 2) ** 2 - 1)}


JOINS = {2: (DATA / "refs" / "derived" / "attas_reg_tc23_tc24_coeffs.asc",
             ["fAttasElv1", "fAttasAil1", "fAttasRud1"]),
         3: (DATA / "refs" / "derived" / "attas_qst_tc27_coeffs.asc",
             ["fAttas_qst01", "fAttas_qst02"])}
#: Each manoeuvre's record file (the deck's &data file) and its MACH column
#: (0-based; column 31 of ATTAS_CHANNELS.md).
RECORDS = {"fAttasElv1": "fAttasElv1_pqrDot.asc", "fAttasAil1": "fAttasAil1_pqrDot.asc",
           "fAttasRud1": "fAttasRud1_pqrDot.asc", "fAttas_qst01": "fAttas_qst01.asc",
           "fAttas_qst02": "fAttas_qst02.asc"}
MACH_COLUMN = 30


def coverage(k, res):
    """Each manoeuvre's name, alpha range [deg] and samples (its rows: the
    derived file's segment column) and Mach range (its record's MACH)."""
    path, names = JOINS[k]
    seg = np.loadtxt(path, usecols=1)
    al = np.degrees(res.data.u[:, res.data.input_names.index("al")])
    out = []
    for j, n in enumerate(names):
        mach = np.loadtxt(DATA / RECORDS[n], usecols=MACH_COLUMN)
        out.append((n, al[seg == j + 1].min(), al[seg == j + 1].max(),
                    int((seg == j + 1).sum()), mach.min(), mach.max()))
    return out


def table_report(k, r):
    """What case k's tables identify: coverage, unreached values, sigma."""
    ft = FittedTables(r)
    print(f"\ncase {k}: alpha covered by each manoeuvre [deg] (samples), Mach (its record's "
          f"MACH column)")
    cov = coverage(k, r)
    for n, lo, hi, cnt, m_lo, m_hi in cov:
        print(f"  {n}: {lo:.2f} to {hi:.2f} ({cnt}), Mach {m_lo:.4f} to {m_hi:.4f}")
    print(f"case {k}: all its records: alpha {min(c[1] for c in cov):.2f} to "
          f"{max(c[2] for c in cov):.2f} deg, Mach {min(c[4] for c in cov):.4f} to "
          f"{max(c[5] for c in cov):.4f}; the derived file "
          f"{JOINS[k][0].name} has {np.loadtxt(JOINS[k][0], usecols=None)[0].size} columns")
    print(f"case {k}: values no sample reaches (the core's list, the JSON's unreached_cells): "
          + ("; ".join(ft.unreached) or "none"))
    print(f"case {k}: each value +- sigma (Cramer-Rao), sigma over its table's median sigma")
    for q, tab in ft.tables.items():
        sig = np.array([ft.sigma[n] for n in tab.value_names(q)])
        med = np.nanmedian(sig)
        for n, b in zip(tab.value_names(q), tab.breakpoints[0]):
            print(f"  {n:8s} ald = {b:3g}: {ft.values[n]: .6f} +- {ft.sigma[n]:.2e} "
                  f"({ft.sigma[n] / med:.1f}x)")
    return ft


def main():
    if not DATA.is_dir():
        sys.exit(f"the flight records are not at {DATA}")
    res = {}
    for case, out, result, error in iter_deck(DECK):
        if error:
            sys.exit(f"{case.where()}: {error}")
        res[case.index] = result
        print(f"case {case.index}: {case.title}: {result.iterations} iterations, "
              f"converged={result.converged}, det R = {result.det_r:.6e}, rank {result.rank} "
              f"of {len(result.names)}")
    ref23, ref27 = read_reference(TC23), read_reference(TC27)
    done = re.search(r"^# Result: converged after (\d+) ", TC23.read_text(encoding="utf-8"),
                     re.M)

    print("\ncase 1 against FVSysID test case 23 (its CD, CL, Cm parameters)")
    print("\n".join(compare(res[1], ref23, {n: n for n in LONG})["lines"]))
    print(f"test case 23 det R (all six outputs): {ref23.det_r:.6e}; case 1's R diagonal "
          f"{np.diag(res[1].rhat)}, the reference's first three {ref23.diag_r[:3]}")
    print(f"case 1: {res[1].iterations} iteration(s); test case 23 (its header): "
          f"{done.group(1) if done else 'not stated'} Gauss-Newton iterations")

    ft2 = table_report(2, res[2])
    p = {n: v for n, (v, _) in ref23.estimates.items()}
    print("case 2 tables against the test case 23 lines (table - line)/sigma_table at each "
          "breakpoint:")
    for q, (c0, ca) in {"CDt": ("CD0", "CDal"), "CLt": ("CL0", "CLal"),
                        "Cmt": ("Cm0", "Cmal")}.items():
        tab = ft2.tables[q]
        line = p[c0] + p[ca] * np.radians(tab.breakpoints[0])
        z = [(ft2.values[n] - v) / ft2.sigma[n] for n, v in zip(tab.value_names(q), line)]
        print(f"  {q}: " + ", ".join(f"{b:g}: {x:+.1f}" for b, x in zip(tab.breakpoints[0], z)))
    print(f"case 2 det R {res[2].det_r:.6e} against case 1's {res[1].det_r:.6e}: ratio "
          f"{res[2].det_r / res[1].det_r:.3f}")
    for n in ("Cmq", "Cmde"):
        v, s = ref23.estimates[n]
        print(f"case 2 {n} {res[2].estimate[n]:.4f} +- {res[2].sigma[n]:.4f}; test case 23: "
              f"{v:.4f} +- {s:.4f}; (case 2 - test case 23)/sigma_ref = "
              f"{(res[2].estimate[n] - v) / s:+.2f}")

    ft3 = table_report(3, res[3])
    d = res[3].data
    de = float(np.mean(d.u[:, d.input_names.index("de")]))
    print(f"case 3 tables against the test case 27 model at its estimates, alpha steady (no "
          f"hysteresis lag), at the records' mean elevator {np.degrees(de):.3f} deg and Mach "
          f"0.25: (table - model)/sigma_table, and the difference")
    for q in ("CDt", "CLt"):
        tab = ft3.tables[q]
        b = tab.breakpoints[0]
        model = tc27_static(ref27.estimates, np.radians(b), de, 0.25)[q]
        print(f"  {q}: " + ", ".join(
            f"{bb:g}: {(ft3.values[n] - m) / ft3.sigma[n]:+.1f} ({ft3.values[n] - m:+.4f})"
            for bb, n, m in zip(b, tab.value_names(q), model) if np.isfinite(ft3.values[n])))
    print(f"case 3 det R {res[3].det_r:.6e}, test case 27 (reference) {ref27.det_r:.6e}: ratio "
          f"{res[3].det_r / ref27.det_r:.3f}; R diagonal {np.diag(res[3].rhat)}, the "
          f"reference's {ref27.diag_r}; ratios (CD, CL, Cm) "
          + ", ".join(f"{x:.3f}" for x in np.diag(res[3].rhat) / ref27.diag_r))
    if len(sys.argv) > 1:
        table_fit_figure(res[3], sys.argv[1])
        print(f"figure: {sys.argv[1]}")


if __name__ == "__main__":
    main()
