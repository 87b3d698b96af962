"""Online estimation (issue 45): recursive least squares per sample, the
core's mlid.online.rls against a straightforward numpy loop of the same
update (K = P x/(lambda + x'P x), theta += K e, P = (P - K x'P)/lambda),
side by side in one run, on test case 23's six aerodynamic regressions
(../shared/data/refs/recursive/data_tc23_RLS.csv, 2,128 samples; the
reference's settings), against the real-time budget of a sample (40 ms).

    python benchmarks/bench_online.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import interleaved_medians  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "refs" / "recursive"
MODELS = {"CD": ["al"], "CL": ["al"], "Cm": ["al", "qn", "de"], "CY": ["be"],
          "Cl": ["be", "pn", "rn", "da"], "Cn": ["be", "pn", "rn", "dr"]}


def numpy_rls(X, y, p0, lam=1.0):
    theta = np.zeros(X.shape[1])
    P = p0 * np.eye(X.shape[1])
    out = np.empty_like(X)
    for k in range(len(y)):
        x = X[k]
        px = P @ x
        K = px / (lam + x @ px)
        theta = theta + K * (y[k] - x @ theta)
        P = (P - np.outer(K, px)) / lam
        out[k] = theta
    return out


def main():
    if not (DATA / "data_tc23_RLS.csv").is_file():
        sys.exit(f"the test case 23 regressors are not under {DATA}")
    import pandas as pd
    d = pd.read_csv(DATA / "data_tc23_RLS.csv")
    problems = [(np.column_stack([np.ones(len(d))] + [d[c].to_numpy() for c in cols]),
                 d[z].to_numpy(), 1e7 if z == "Cm" else 1e6) for z, cols in MODELS.items()]
    ours = lambda: [mlid.online.rls(X, y, p0=p0) for X, y, p0 in problems]
    peer = lambda: [numpy_rls(X, y, p0) for X, y, p0 in problems]
    t_ours, t_peer = interleaved_medians([ours, peer], rounds=5, n=3)
    n = len(d) * len(problems)
    agree = max(np.max(np.abs(a.estimates - b)) for a, b in zip(ours(), peer()))
    print(f"RLS, 6 regressions x {len(d)} samples: mlid {1e6 * t_ours / n:.2f} us/sample, "
          f"numpy loop {1e6 * t_peer / n:.2f} us/sample, ratio {t_peer / t_ours:.1f}x; "
          f"budget 40,000 us/sample ({40e-3 * n / t_ours:.0f}x faster than real time); "
          f"largest difference {agree:.1e}")


if __name__ == "__main__":
    main()
