"""Monte Carlo validation of an optimal input (NASA CR-2200 §8.2, Table 8.1).

The C-8 four-state longitudinal model: an input designed on a priori values
about 50% off the truth (T = 2 s, energy 58) and a doublet of equal energy,
each flown N times with new measurement noise and identified by output
error with R estimated.  The statistics of Table 8.1 and a histogram of each
estimate (Figs 8.12-8.16).  Runs go in parallel over the cores, or over a
Dask cluster with --scheduler.

    python c8_mc.py [--runs N] [--scheduler ADDRESS] [--plots DIR]

Every number and where it comes from: README.md in this folder.
"""

import argparse
import sys
import time

import numpy as np

import mlid

# CASES.md §1 (report §8.2): x = (u, theta, q, alpha), z = x + n, dt = 0.02 s, T = 2 s
F0 = np.array([[-0.02, -32.2, 0, 33.74], [0, 0, 1, 0], [0.003, 0, -1.588, -0.562],
               [-0.004, 0, 1, -0.737]])
G0 = np.array([[0.0], [0.0], [-1.658], [0.005]])
UNKNOWNS = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]
NAMES = {"f(3,3)": "M_q", "f(3,4)": "M_alpha", "f(4,4)": "Z_alpha", "g(3,1)": "M_delta",
         "g(4,1)": "Z_delta"}
# The truth: the a priori (design) values changed by 50%, up and down (ours: the
# report's truth is lost)
CHANGE = np.array([1.5, 1.5, 0.5, 1.5, 0.5])
R_SAMPLE = np.array([0.125, 0.125, 0.25, 0.25])   # per-sample noise variances (OCR, ours)
DT, T, ENERGY = 0.02, 2.0, 58.0
SEED = 1


def models():
    start = mlid.LinearModel(F0, G0, np.eye(4), r=R_SAMPLE, free=UNKNOWNS, names=NAMES,
                             input_hold="zoh")
    truth_theta = start.theta.copy()
    idx = np.flatnonzero(start.free_mask)
    truth_theta[idx] = truth_theta[idx] * CHANGE
    return start.with_theta(truth_theta), start


def inputs():
    """The optimal input, designed on the a priori values with the noise's
    spectral density R dt, held on the 100 sample intervals; and a doublet of
    the same energy."""
    d = mlid.InputDesign(F0, G0, np.eye(4), np.diag(R_SAMPLE * DT), UNKNOWNS)
    n = int(round(T / DT))
    opt = d.optimal_input(T, ENERGY, cells=n // 2)          # 2 * (n/2) = n cells
    dbl = np.where(np.arange(n) < n // 2, 1.0, -1.0) * np.sqrt(ENERGY / T)
    t = np.arange(n + 1) * DT
    hold = lambda v: np.r_[v, v[-1]][:, None]              # noqa: E731 - one value per sample
    return t, {"optimal": hold(opt.u[:, 0]), "doublet": hold(dbl)}, d


SERVO_TAU, T_TWO_SIDED, E_TWO_SIDED = 0.2, 4.0, 101.25     # §8.3


def two_sided(theta):
    """§8.3: the 2 s optimal input followed by its negative (two-sided, so
    the speed returns to trim), energy 101.25 over 4 s, through a 0.2 s
    first-order servo; against a doublet of equal energy through the same
    servo.  Information at the parameters theta (free order), from the model
    with the servo as a fifth state, so that the surface is exact."""
    F, G = F0.copy(), G0.copy()
    F[2, 2], F[2, 3], F[3, 3] = theta[0], theta[1], theta[2]
    G[2, 0], G[3, 0] = theta[3], theta[4]
    Fs = np.zeros((5, 5))
    Fs[:4, :4] = F
    Fs[:4, 4] = G[:, 0]
    Fs[4, 4] = -1.0 / SERVO_TAU
    Gs = np.zeros((5, 1))
    Gs[4, 0] = 1.0 / SERVO_TAU
    Hs = np.hstack([np.eye(4), np.zeros((4, 1))])
    d = mlid.InputDesign(Fs, Gs, Hs, np.diag(R_SAMPLE * DT),
                         ["f(3,3)", "f(3,4)", "f(4,4)", "f(3,5)", "f(4,5)"])
    _, us, _ = inputs()
    half = us["optimal"][:-1, 0]
    u = np.r_[half, -half]
    u = u * np.sqrt(E_TWO_SIDED / (np.sum(u**2) * DT))
    n = len(u)
    dbl = np.where(np.arange(n) < n // 2, 1.0, -1.0) * np.sqrt(E_TWO_SIDED / T_TWO_SIDED)
    return {name: mlid.design.summary(d.information(T_TWO_SIDED, v[:, None]))
            for name, v in (("optimal", u), ("doublet", dbl))}


def statistics(mc, expected_info):
    """Table 8.1: sample covariance of the estimates, average information,
    Cramer-Rao sigma at the truth."""
    ok = mc["status"] == 0
    est, info = mc["estimates"][ok], mc["information"][ok]
    cov = np.cov(est.T)
    avg = info.mean(axis=0)
    return {"runs": int(ok.sum()), "failed": int((~ok).sum()),
            "sample cov trace": float(np.trace(cov)), "sample cov det": float(np.linalg.det(cov)),
            "sample cov eigenvalues": np.linalg.eigvalsh(cov), "sample sigma": est.std(axis=0, ddof=1),
            "mean": est.mean(axis=0), "expected info trace": float(np.trace(expected_info)),
            "avg info trace": float(np.trace(avg)), "avg info det": float(np.linalg.det(avg)),
            "avg info eigenvalues": np.linalg.eigvalsh(avg),
            "CR sigma": np.sqrt(np.diag(np.linalg.inv(expected_info))), "estimates": est}


def run(runs=50, scheduler=None, plots=None, workers=None):
    truth, start = models()
    t, us, _ = inputs()
    out = {"truth": truth.theta[truth.free_mask == 1], "start": start.theta[start.free_mask == 1]}
    for name, u in us.items():
        data, _ = mlid.simulate(truth, t, u, seed=SEED + 10**6)   # for the expected information
        expected = mlid.evaluate(truth, data)["information"]
        t0 = time.perf_counter()
        mc = mlid.monte_carlo_parallel(truth, start, t, u, runs=runs, seed=SEED,
                                       scheduler=scheduler, workers=workers)
        out[name] = statistics(mc, expected)
        out[name]["seconds"] = time.perf_counter() - t0
    out["two-sided"] = two_sided(out["truth"])
    if plots:
        out["plots"] = histograms(out, plots)
    return out


def histograms(out, folder):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path
    Path(folder).mkdir(parents=True, exist_ok=True)
    paths = []
    for k, key in enumerate(UNKNOWNS):
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for name, color in (("optimal", "C0"), ("doublet", "C3")):
            ax.hist(out[name]["estimates"][:, k], bins=15, alpha=0.5, color=color, label=name)
        ax.axvline(out["truth"][k], color="k", lw=1.5, label="truth")
        ax.set_title(f"Fig. 8.{12 + k}: {NAMES[key]}, {out['optimal']['runs']} runs")
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = Path(folder) / f"fig8_{12 + k}_{NAMES[key]}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=50)
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler (else local processes)")
    p.add_argument("--plots", metavar="DIR")
    args = p.parse_args(argv)
    try:
        out = run(args.runs, args.scheduler, args.plots)
    except mlid.MlidError as exc:
        print(f"c8_mc: {exc}", file=sys.stderr)
        return 1
    names = [NAMES[k] for k in UNKNOWNS]
    print(f" C-8 Monte Carlo (§8.2): {args.runs} runs per input, truth = design values x "
          f"{CHANGE.tolist()}")
    print(f"  {'':<28}" + "".join(f"{n:>12}" for n in names))
    print(f"  {'truth':<28}" + "".join(f"{v:12.5g}" for v in out["truth"]))
    print(f"  {'start (design values)':<28}" + "".join(f"{v:12.5g}" for v in out["start"]))
    for name in ("optimal", "doublet"):
        s = out[name]
        print(f"\n  {name}: {s['runs']} runs ({s['failed']} failed), {s['seconds']:.1f} s")
        for label, key in (("mean", "mean"), ("sample sigma", "sample sigma"),
                           ("Cramer-Rao sigma (truth)", "CR sigma")):
            print(f"  {label:<28}" + "".join(f"{v:12.4g}" for v in s[key]))
        print(f"  sample covariance: trace {s['sample cov trace']:.4g}, det "
              f"{s['sample cov det']:.4g}, eigenvalues "
              + " ".join(f"{v:.3g}" for v in s["sample cov eigenvalues"]))
        print(f"  information: expected trace {s['expected info trace']:.4g}, average trace "
              f"{s['avg info trace']:.4g}, average det {s['avg info det']:.4g}, eigenvalues "
              + " ".join(f"{v:.3g}" for v in s["avg info eigenvalues"]))
    ts = out["two-sided"]
    print(f"\n  two-sided through a {SERVO_TAU} s servo, {T_TWO_SIDED:g} s, energy "
          f"{E_TWO_SIDED} (§8.3), information at the truth: optimal det {ts['optimal']['det']:.3g}"
          f", tr {ts['optimal']['trace']:.3g}; doublet det {ts['doublet']['det']:.3g}, tr "
          f"{ts['doublet']['trace']:.3g}; eigenvalues larger for the optimal input: "
          f"{int(np.sum(ts['optimal']['eigenvalues'] > ts['doublet']['eigenvalues']))} of 5")
    for path in out.get("plots", []):
        print(f" plot: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
