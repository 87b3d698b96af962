"""The C-8 loop deck (design -> fly -> identify -> Monte Carlo) and the
numbers its README quotes, against Table 8.1 of NASA CR-2200.

    python c8_loop.py

The deck does all the work (mlid run c8_loop.nml prints the same reports);
this script adds the ratios the README states.  Sources: README.md here.
"""

import sys
from pathlib import Path

import numpy as np

import mlid

DECK = Path(__file__).with_name("c8_loop.nml")
# Table 8.1, optimal input (CASES.md §1)
REPORT = {"mean_info_trace": 2.15e7, "sample_cov_det": 1.62e-19,
          "sample_sigma": [0.407, 0.295, 0.00925, 0.0771, 0.000570],
          "mean_cr_sigma": [0.351, 0.234, 0.00876, 0.0665, 0.000247]}


def main():
    runs = mlid.run_deck(DECK)
    failed = [(case.title, error) for case, _, _, error in runs if error is not None]
    if failed:
        print(f"c8_loop: {failed}", file=sys.stderr)
        return 1
    design, _, fit, mc = (out for _, out, _, _ in runs)
    print(design.report, end="")
    print(f"  tr M / (mu E) = {design['trace_M'] / (design['mu'] * design['energy']):.6f}")
    truth = np.array(mc["truth"])
    dev = np.abs(np.array(fit["estimate"]) - truth) / np.array(fit["sigma"])
    res = runs[2][2]
    print(f" identification from the a priori values: {res.iterations} iterations; "
          + ", ".join(f"{n} {e:.4g} +- {s:.3g}" for n, e, s in
                      zip(res.names, res.estimate, res.sigma)))
    print("  |estimate - truth| / sigma = " + " ".join(f"{d:.2f}" for d in dev))
    print(mc.report, end="")
    print(f"  {'':<24}{'report':>45}   mlid")
    for key in ("mean_info_trace", "sample_cov_det"):
        print(f"  {key:<24}{REPORT[key]:>45.3g}   {mc[key]:.3g}")
    for key in ("sample_sigma", "mean_cr_sigma"):
        print(f"  {key:<24}" + "".join(f"{v:>9.3g}" for v in REPORT[key]) + "   "
              + " ".join(f"{v:.3g}" for v in mc[key]))
    for key, band in (("sample_sigma", 0.2), ("mean_cr_sigma", 0.1)):
        ratio = np.array(mc[key]) / np.array(REPORT[key])
        print(f"  {key} mlid / report: " + " ".join(f"{v:.3f}" for v in ratio)
              + f"; {np.sum(np.abs(ratio - 1) <= band)} of {ratio.size} within {band:.0%}")
    own = np.array(mc["sample_sigma"]) / np.array(mc["mean_cr_sigma"])
    report = np.array(REPORT["sample_sigma"]) / np.array(REPORT["mean_cr_sigma"])
    print("  sample sigma / Cramer-Rao sigma: mlid " + " ".join(f"{v:.2f}" for v in own)
          + "; report " + " ".join(f"{v:.2f}" for v in report))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
