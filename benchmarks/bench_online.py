"""Online estimation (issue 45), per sample, against the real-time budget of
a sample (40 ms), each side by side in one run with a straightforward numpy
implementation of the same method:
- recursive least squares (mlid.online.rls; K = P x/(lambda + x'P x),
  theta += K e, P = (P - K x'P)/lambda) on test case 23's six aerodynamic
  regressions (../shared/data/refs/recursive/data_tc23_RLS.csv, 2,128
  samples, the reference's settings);
- Fourier-transform regression (mlid.online.ftr) on test case 11's joined
  record (1,252 samples, 33 frequencies, a solve a second; the reference's
  whole run took 0.10 s of Octave CPU, its header).

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


def numpy_ftr(t, z, u, w, every=25, trim=10):
    x, v = z - z[:trim].mean(axis=0), u - u[:trim].mean(axis=0)
    X = np.zeros((len(w), z.shape[1] + u.shape[1]), complex)
    out = []
    for k in range(len(t)):
        X += np.exp(-1j * w * (t[k] - t[0]))[:, None] * np.r_[x[k], v[k]][None, :]
        if (k + 1) % every == 0:
            A = X
            inv = np.linalg.inv((A.conj().T @ A).real)
            out.append([inv @ (A.conj().T @ (1j * w * A[:, i])).real for i in range(z.shape[1])])
    return np.array(out)


def tc11():
    d = Path(__file__).resolve().parents[2] / "shared" / "data"
    cols = (["T[s]"] + [f"c{i}" for i in range(2, 8)] + ["QRGY[deg/s]"]
            + [f"c{i}" for i in range(9, 13)] + ["ALCG[deg]"] + [f"c{i}" for i in range(14, 22)]
            + ["DELV[deg]"])
    parts = [mlid.FlightData.load(d / n, "T", ["DELV"], ["ALCG", "QRGY"], columns=cols)
             for n in ("fAttasElv1.mat", "fAttasElv2.mat")]
    z = np.vstack([p.y for p in parts])
    return 0.04 * np.arange(len(z)), z, np.vstack([p.u for p in parts])


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
    t, z, u = tc11()
    f = np.arange(0.2, 1.5 - 1e-9, 0.04)
    ours = lambda: mlid.online.ftr(t, z, u, f)
    peer = lambda: numpy_ftr(t, z, u, 2 * np.pi * f)
    t_ours, t_peer = interleaved_medians([ours, peer], rounds=5, n=3)
    agree = np.max(np.abs(ours().estimates - peer().reshape(len(t) // 25, -1)))
    print(f"FTR, {len(t)} samples, {len(f)} frequencies: mlid {1e6 * t_ours / len(t):.2f} "
          f"us/sample, numpy loop {1e6 * t_peer / len(t):.2f} us/sample, ratio "
          f"{t_peer / t_ours:.1f}x; the reference's whole run 0.10 s of CPU: "
          f"{0.10 / t_ours:.0f}x; largest difference {agree:.1e}")


if __name__ == "__main__":
    main()
