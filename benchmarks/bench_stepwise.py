"""Model-structure determination (issue 45 item 5): mlid.stepwise over the
30 candidates of tests/test_stepwise.py (linear, powers, products, splines)
on test case 23's 2,128 samples (../shared/data/refs/recursive/
data_tc23_RLS.csv), each of the six coefficients, against a straightforward
numpy implementation of the same forward selection with removals, backward
elimination (lstsq per step) and orthogonal-function ordering with PSE (the test's second implementation:
a QR of the model and a projection of every candidate per step), side by
side in one run; target <= 20 ms a regression.

    python benchmarks/bench_stepwise.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))
from timing import interleaved_medians  # noqa: E402
from test_stepwise import REFS, REFERENCE, np_backward, np_forward, np_mof, tc23_candidates  # noqa: E402


def main():
    if not (REFS / "data_tc23_RLS.csv").is_file():
        sys.exit(f"the test case 23 regressors are not under {REFS}")
    import pandas as pd
    d = pd.read_csv(REFS / "data_tc23_RLS.csv")
    cands = tc23_candidates(d)
    X = np.column_stack([np.ones(len(d)), cands.to_numpy()])
    ys = [d[z].to_numpy() for z in REFERENCE]
    print(f"{cands.shape[1]} candidates, {len(d)} samples, 6 coefficients "
          "(median of 5 rounds x 3, per regression):")
    for method, peer in (("forward", lambda y: np_forward(X, y, [0])),
                         ("backward", lambda y: np_backward(X, y, [0])), ("mof", lambda y: np_mof(X, y, [0]))):
        ours = lambda: [mlid.stepwise(cands, y, method=method) for y in ys]
        t = interleaved_medians([ours, lambda: [peer(y) for y in ys]], rounds=5, n=3)
        met = "met" if t[0] / 6 <= 0.020 else "MISSED"
        print(f"  {method:8s}: mlid {1e3 * t[0] / 6:6.2f} ms, numpy {1e3 * t[1] / 6:6.2f} ms, "
              f"ratio {t[1] / t[0]:.1f}x  (target 20 ms: {met})")


if __name__ == "__main__":
    main()
