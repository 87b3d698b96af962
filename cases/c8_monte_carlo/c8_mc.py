"""Monte Carlo validation of an optimal input (NASA CR-2200 §8.2, Table 8.1;
§8.3, the servo; Figs 8.12-8.18).

The C-8 four-state longitudinal model (c8_longitudinal.py): an input designed
on the a priori values and a doublet of equal energy, each flown N times with
new measurement noise and identified by output error with R estimated, from
the a priori values.  The truth the report lost is searched among the
"about 50%" changes of the a priori values against Table 8.1's bound
columns.  Prints every number of README.md beside the report's, with a
verdict.  Runs go in parallel over threads, or a Dask cluster (--scheduler).

    python c8_mc.py [--runs N] [--scheduler ADDRESS] [--plots DIR] [--readings]

Every number and where it comes from: README.md in this folder.
"""

import argparse
import itertools
import sys
import warnings
from pathlib import Path

import numpy as np

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent))
import c8_longitudinal as c8  # noqa: E402

SEED = 1
NAMES = list(c8.NAMES.values())
# Table 8.1 (report p. 171), columns optimal | doublet; eigenvalues largest first
TABLE_8_1 = {
    "optimal": {"sample cov trace": 0.242, "sample cov det": 1.62e-19,
                "sample cov eigenvalues": [0.234, 0.725e-2, 0.252e-3, 0.188e-4, 0.202e-7],
                "sample sigma": [0.407, 0.295, 0.00925, 0.0771, 0.000570],
                "avg info trace": 2.15e7, "avg info det": 4.70e18,
                "avg info eigenvalues": [2.14e7, 2.95e4, 6.56e3, 1.39e2, 1.12],
                "CR sigma": [0.351, 0.234, 0.00876, 0.0665, 0.000247],
                "expected info trace": 2.12e7},          # the last: §8.2.4 text
    "doublet": {"sample cov trace": 0.315, "sample cov det": 1.501e-15,
                "sample cov eigenvalues": [0.262, 0.514e-1, 0.115e-2, 0.766e-4, 0.126e-5],
                "sample sigma": [0.307, 0.491, 0.0235, 0.0537, 0.00168],
                "avg info trace": 4.79e5, "avg info det": 1.95e14,
                "avg info eigenvalues": [4.79e5, 8.46e3, 4.77e2, 2.18e1, 4.14],
                "CR sigma": [0.303, 0.441, 0.0311, 0.0568, 0.00262],
                "expected info trace": 4.74e5}}
# What picks the truth: the bound columns and the expected traces.  Not the
# optimal input's Z_delta bound, .000247, which no truth reaches (README).
SEARCH_LEVELS = (0.5, 2 / 3, 1.5, 2.0)    # truth = a priori x (1 +- .5), or a priori = truth x (1 +- .5)
# §8.3 (report p. 178-180)
SERVO_TAU, T_TWO_SIDED, E_TWO_SIDED = 0.2, 4.0, 101.25
SECTION_8_3 = {"optimal det": 1.6e26, "doublet det": 7.3e24, "optimal trace": 1.4e8,
               "doublet trace": 9.7e6, "larger eigenvalues": 3}
# §8.2.4 on Figs 8.17-8.18: |error of R-hat| against the noise's own sample covariance
R_ERROR_REPORT = {("theta", "optimal"): "< 5%, mostly < 1%", ("theta", "doublet"): "< 5%",
                  ("q", "optimal"): "< 7%", ("q", "doublet"): "< 9%"}


def inputs(r=c8.R_SAMPLE):
    """The optimal input designed on the a priori values (one value per
    0.02 s sample interval), and the doublet: §8.3 says the doublet starts
    with a jump as large as the optimal input's first value (about 10 deg),
    so its amplitude is that value and, at equal energy, its two halves
    last E / (2 A^2) each (rounded to whole samples).  Both as (cells, 1)."""
    n = int(round(c8.T / c8.DT))
    opt = c8.design(r=r).optimal_input(c8.T, c8.ENERGY, cells=n // 2).u   # 2 (n/2) cells
    return {"optimal": opt, "doublet": doublet(abs(opt[0, 0]), c8.ENERGY, n)}


def doublet(amplitude, energy, n):
    """+A then -A on n cells of DT, each half energy / (2 A^2) long rounded
    to whole cells, then zero; rescaled to the energy exactly."""
    half = int(round(energy / (2 * amplitude**2) / c8.DT))
    u = np.zeros((n, 1))
    u[:half], u[half:2 * half] = 1.0, -1.0
    return u * np.sqrt(energy / (np.sum(u**2) * c8.DT))


def held(u):
    """Cells to samples: one input row per sample, the last repeated."""
    return np.vstack([u, u[-1:]])


def search_truth(r=c8.R_SAMPLE):
    """Every truth a priori x f, f in SEARCH_LEVELS for each unknown,
    scored by the rms of log(mlid / report) over Table 8.1's bound sigma
    and expected information traces (eq. 7.12 at that truth): a list of
    (score, factors, the optimal input's Z_delta bound), best first."""
    us = inputs(r)
    ref = {k: TABLE_8_1[k] for k in us}
    out = []
    for f in itertools.product(SEARCH_LEVELS, repeat=5):
        d = c8.design(c8.DESIGN_VALUES * np.array(f), r)
        logs, sig = [], {}
        for name, u in us.items():
            s = mlid.design.input_design.summary(d.information(c8.T, u))
            sig[name] = s["sigma"]
            keep = slice(0, 4) if name == "optimal" else slice(0, 5)
            logs += list(np.log(s["sigma"][keep] / np.array(ref[name]["CR sigma"])[keep]))
            logs.append(np.log(s["trace"] / ref[name]["expected info trace"]))
        out.append((float(np.sqrt(np.mean(np.square(logs)))), np.array(f), sig["optimal"][4]))
    out.sort(key=lambda sf: sf[0])
    return out


def statistics(mc, expected_info):
    """Table 8.1's rows: the sample covariance of the estimates (1/N, the
    report's formula), the average information, the bound at the truth."""
    ok = mc["status"] == 0
    est, info = mc["estimates"][ok], mc["information"][ok]
    cov = np.cov(est.T, ddof=0)
    avg = info.mean(axis=0)
    exp = mlid.design.input_design.summary(expected_info)
    return {"runs": int(ok.sum()), "failed": int((~ok).sum()), "estimates": est,
            "mean": est.mean(axis=0), "sample sigma": np.sqrt(np.diag(cov)),
            "sample cov trace": float(np.trace(cov)), "sample cov det": float(np.linalg.det(cov)),
            "sample cov eigenvalues": np.linalg.eigvalsh(cov)[::-1],
            "avg info trace": float(np.trace(avg)),
            "avg info det": float(np.mean(np.linalg.det(info))),
            "avg info eigenvalues": np.linalg.eigvalsh(avg)[::-1],
            "CR sigma": exp["sigma"], "expected info trace": exp["trace"],
            "expected info eigenvalues": exp["eigenvalues"][::-1]}


def per_run(truth, start, t, u, runs, seed, x0_first=False):
    """Each run again, one fit at a time (same seed, same record as the
    Monte Carlo's run): R-hat against the noise's own sample covariance
    (Figs 8.17-8.18), and the estimates with x0 the first data point
    (report §8.2.3) when x0_first."""
    clean, _ = mlid.simulate(truth, t, u, noise_std=np.zeros(4))
    est, rel, first = [], [], []
    for k in range(runs):
        data, _ = mlid.simulate(truth, t, u, seed=seed + k)
        res = mlid.fit(start, data)
        noise = data.y - clean.y
        actual = np.mean(noise**2, axis=0)
        est.append(res.estimate)
        rel.append(np.diag(res.rhat) / actual - 1.0)
        if x0_first:
            first.append(_fit_from_first_sample(start, data))
    out = {"estimates": np.array(est), "R error": np.array(rel)}
    if x0_first:
        first = np.array([f for f in first if f is not None])
        out["x0 first"] = {"runs": len(first), "sample sigma": first.std(axis=0)}
    return out


def _fit_from_first_sample(start, data):
    """The fit with the initial state held at the first (noisy) sample."""
    m = mlid.LinearModel(start.F, start.G, np.eye(4), x0=data.y[0], r=c8.R_SAMPLE,
                         free=c8.UNKNOWNS, names=c8.NAMES, input_hold="zoh")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = mlid.fit(m, data)
        except mlid.MlidError:
            return None
    return res.estimate if res.converged else None


def two_sided_inputs():
    """§8.3's inputs on 200 cells of DT: the 2 s optimal input followed by
    its negative (the speed returns to trim), scaled to energy 101.25 over
    4 s; doublets of equal energy: the one of our rule (amplitude the
    command's first value), one of 1 s halves (amplitude sqrt(E / 2)) and
    one of 2 s halves."""
    half = inputs()["optimal"]
    u = np.vstack([half, -half])
    u = u * np.sqrt(E_TWO_SIDED / (np.sum(u**2) * c8.DT))
    n = len(u)
    return {"optimal": u, "doublet": doublet(abs(u[0, 0]), E_TWO_SIDED, n),
            "doublet, 1 s halves": doublet(np.sqrt(E_TWO_SIDED / 2.0), E_TWO_SIDED, n),
            "doublet, 2 s halves": doublet(np.sqrt(E_TWO_SIDED / 4.0), E_TWO_SIDED, n)}


def two_sided(theta):
    """§8.3 at theta: the information of each two-sided input through the
    0.2 s first-order servo."""
    d = c8.servo_design(theta, SERVO_TAU)
    return {k: mlid.design.input_design.summary(d.information(T_TWO_SIDED, v))
            for k, v in two_sided_inputs().items()}


def run(runs=50, scheduler=None, plots=None, workers=None):
    search = search_truth()
    factors = search[0][1]
    truth_theta = c8.DESIGN_VALUES * factors
    truth, start = c8.model(truth_theta), c8.model()
    us = inputs()
    n = len(us["optimal"])
    t = np.arange(n + 1) * c8.DT
    out = {"search": search, "factors": factors, "truth": truth_theta, "start": c8.DESIGN_VALUES,
           "inputs": us}
    d_truth = c8.design(truth_theta)
    for name, u in us.items():
        mc = mlid.monte_carlo_parallel(truth, start, t, held(u), runs=runs, seed=SEED,
                                       scheduler=scheduler, workers=workers)
        out[name] = statistics(mc, d_truth.information(c8.T, u))
        out[name]["per run"] = per_run(truth, start, t, held(u), runs, SEED,
                                       x0_first=name == "optimal")
        out[name]["mc estimates"] = mc["estimates"]
    out["two-sided"] = {"design values": two_sided(c8.DESIGN_VALUES), "truth": two_sided(truth_theta)}
    if plots:
        out["plots"] = histograms(out, plots)
    return out


def verdict(ours, report, note=""):
    """'agrees' within 20% (two standard errors of a sample sigma from 50
    runs), 'same order' within 3x, else 'differs'; and a note."""
    ratio = ours / report
    v = "agrees" if abs(ratio - 1) <= 0.2 else "same order" if 1 / 3 <= ratio <= 3 else "differs"
    return f"{v} ({note})" if note else v


SEARCHED = "picked the truth"


def _notes(name, key, k):
    """Why a row is not an independent check, or why it cannot agree."""
    ref = TABLE_8_1[name]
    if key == "expected info trace" or (key == "CR sigma" and (name == "doublet" or k < 4)):
        return SEARCHED
    if name == "optimal" and key == "CR sigma" and k == 4:
        return f"no truth reaches it; the report's sample sigma is {ref['sample sigma'][4]:g}"
    if name == "optimal" and key == "avg info eigenvalues" and k == 4:
        # tr M^-1 >= 1 / lambda_min: the report's own bound column needs this much
        need = 1 / np.sum(np.square(ref["CR sigma"]))
        return f"the report's bound column needs >= {need:.2f}"
    return ""


def table_rows(out):
    """(quantity, report, mlid, verdict) for every number README.md quotes."""
    rows = []
    fmt = lambda v: f"{v:.3g}"                                     # noqa: E731
    for name in ("optimal", "doublet"):
        s, ref = out[name], TABLE_8_1[name]
        for key in ("expected info trace", "avg info trace", "avg info det",
                    "sample cov trace", "sample cov det"):
            rows.append((f"{name}: {key}", fmt(ref[key]), fmt(s[key]),
                         verdict(s[key], ref[key], _notes(name, key, 0))))
        for key in ("avg info eigenvalues", "sample cov eigenvalues", "CR sigma", "sample sigma"):
            for k, (a, b) in enumerate(zip(ref[key], s[key])):
                label = NAMES[k] if "sigma" in key else f"#{k + 1}"
                rows.append((f"{name}: {key} {label}", fmt(a), fmt(b),
                             verdict(b, a, _notes(name, key, k))))
        err = 100 * np.abs(s["per run"]["R error"])
        for ch, idx in (("theta", 1), ("q", 2)):
            bound = R_ERROR_REPORT[(ch, name)]
            limit = float(bound.split("%")[0].strip("< "))
            rows.append((f"{name}: max |R-hat error| {ch} [%]", bound, f"{err[:, idx].max():.1f}",
                         "agrees" if err[:, idx].max() < limit else "differs"))
        rows.append((f"{name}: R-hat error theta within 1% [% of runs]",
                     "most" if name == "optimal" else "-", f"{np.mean(err[:, 1] <= 1):.0%}",
                     "agrees" if name == "doublet" or np.mean(err[:, 1] <= 1) > 0.5 else "differs"))
    o, dd = out["optimal"], out["doublet"]
    zd = min(z for _, _, z in out["search"])
    rows.append((f"optimal: CR sigma Z_delta, smallest of the {len(out['search'])} candidates",
                 fmt(TABLE_8_1["optimal"]["CR sigma"][4]), fmt(zd), verdict(zd, 0.000247)))
    ref = TABLE_8_1["optimal"]["expected info trace"] / TABLE_8_1["doublet"]["expected info trace"]
    mine = o["expected info trace"] / dd["expected info trace"]
    rows.append(("expected info trace, optimal / doublet", fmt(ref), fmt(mine), verdict(mine, ref)))
    ratio_ref = TABLE_8_1["doublet"]["sample cov det"] / TABLE_8_1["optimal"]["sample cov det"]
    ratio = dd["sample cov det"] / o["sample cov det"]
    rows.append(("det sample cov, doublet / optimal", fmt(ratio_ref), fmt(ratio),
                 verdict(ratio, ratio_ref)))
    for where, ts in out["two-sided"].items():
        for key in ("det", "trace"):
            for inp in ("optimal", "doublet"):
                ref = SECTION_8_3[f"{inp} {key}"]
                rows.append((f"§8.3 at the {where}: {inp} {key}", fmt(ref),
                             fmt(ts[inp][key]), verdict(ts[inp][key], ref)))
            ref = SECTION_8_3[f"optimal {key}"] / SECTION_8_3[f"doublet {key}"]
            mine = ts["optimal"][key] / ts["doublet"][key]
            rows.append((f"§8.3 at the {where}: {key} optimal / doublet", fmt(ref), fmt(mine),
                         verdict(mine, ref)))
            for other in ("doublet, 1 s halves", "doublet, 2 s halves"):
                mine = ts["optimal"][key] / ts[other][key]
                rows.append((f"§8.3 at the {where}: {key} optimal / {other}", "-", fmt(mine),
                             "ours"))
        larger = int(np.sum(ts["optimal"]["eigenvalues"] > ts["doublet"]["eigenvalues"]))
        rows.append((f"§8.3 at the {where}: eigenvalues larger for optimal", "3 of 5",
                     f"{larger} of 5", "agrees" if larger == 3 else "differs"))
    xf = out["optimal"]["per run"]["x0 first"]
    for k, name in enumerate(NAMES):
        rows.append((f"optimal, x0 = first sample: sample sigma {name}",
                     fmt(TABLE_8_1["optimal"]["sample sigma"][k]), fmt(xf["sample sigma"][k]),
                     verdict(xf["sample sigma"][k], TABLE_8_1["optimal"]["sample sigma"][k])))
    return rows


def histograms(out, folder):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    Path(folder).mkdir(parents=True, exist_ok=True)
    paths = []
    for k, name in enumerate(NAMES):
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for inp, color in (("optimal", "C0"), ("doublet", "C3")):
            ax.hist(out[inp]["estimates"][:, k], bins=15, alpha=0.5, color=color, label=inp)
        ax.axvline(out["truth"][k], color="k", lw=1.5, label="truth")
        ax.set_title(f"Fig. 8.{12 + k}: {name}, {out['optimal']['runs']} runs")
        ax.legend(fontsize=8)
        paths.append(_save(fig, folder, f"fig8_{12 + k}_{name}.png"))
    for fig_no, (channel, idx) in zip((17, 18), (("theta", 1), ("q", 2))):
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for inp, color in (("optimal", "C0"), ("doublet", "C3")):
            ax.hist(100 * out[inp]["per run"]["R error"][:, idx], bins=15, alpha=0.5, color=color,
                    label=inp)
        ax.set_xlabel(f"(R-hat - sample variance of the noise) / sample variance, {channel} [%]")
        ax.set_title(f"Fig. 8.{fig_no}: error of R-hat for n_{channel}, "
                     f"{out['optimal']['runs']} runs")
        ax.legend(fontsize=8)
        paths.append(_save(fig, folder, f"fig8_{fig_no}_R_error_{channel}.png"))
    return paths


def _save(fig, folder, name):
    """The figure written whole or not at all (mlid.files.atomic_savefig)."""
    import matplotlib.pyplot as plt
    from pathlib import Path

    from mlid.files import atomic_savefig
    fig.tight_layout()
    path = Path(folder) / name
    atomic_savefig(fig, path, dpi=100)
    plt.close(fig)
    return path


def print_readings():
    """The truth search's best score under each reading of the noise line."""
    print(" Noise line '.125 .125 .250': best truth-search score (rms log mlid/report) per reading")
    for label, r in c8.R_READINGS.items():
        score, f, _ = search_truth(r)[0]
        print(f"  {label:<32} {score:.3f}  factors {np.round(f, 3).tolist()}")


def _nonzero(u):
    """Seconds from the start to the input's last non-zero cell."""
    return f"{(np.flatnonzero(u[:, 0])[-1] + 1) * c8.DT:.2f}"


def print_results(out, runs):
    print(f" C-8 Monte Carlo (§8.2): {runs} runs per input, noise R = {c8.R_SAMPLE.tolist()} "
          f"per sample")
    print("  truth search (a priori x factors), best five of "
          f"{len(out['search'])}: score = rms log(mlid/report)")
    for score, f, _ in out["search"][:5]:
        print(f"    {score:.4f}  {np.round(f, 3).tolist()}")
    print(f"  {'':<24}" + "".join(f"{n:>12}" for n in NAMES))
    print(f"  {'truth':<24}" + "".join(f"{v:12.5g}" for v in out["truth"]))
    print(f"  {'start (a priori)':<24}" + "".join(f"{v:12.5g}" for v in out["start"]))
    for name in ("optimal", "doublet"):
        s = out[name]
        amp = out["inputs"][name]
        print(f"\n  {name}: first value {amp[0, 0]:.3f}, {_nonzero(amp)} s long, {s['runs']} runs "
              f"({s['failed']} failed)")
        for label in ("mean", "sample sigma", "CR sigma"):
            print(f"  {label:<24}" + "".join(f"{v:12.4g}" for v in s[label]))
    print(f"\n  §8.3 inputs, energy {E_TWO_SIDED} over {T_TWO_SIDED:g} s: " + "; ".join(
        f"{k}: first value {abs(v[0, 0]):.2f}, {_nonzero(v)} s long"
        for k, v in two_sided_inputs().items()))
    xf = out["optimal"]["per run"]["x0 first"]
    print(f"\n  optimal, x0 held at the first data point (§8.2.3): {xf['runs']} of {runs} runs "
          "converged")
    print(f"\n  {'quantity':<62}{'report':>18}{'mlid':>10}  verdict")
    for q, rep, ours, v in table_rows(out):
        print(f"  {q:<62}{rep:>18}{ours:>10}  {v}")
    for path in out.get("plots", []):
        print(f" plot: {path}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=50)
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler (else local threads)")
    p.add_argument("--plots", metavar="DIR")
    p.add_argument("--readings", action="store_true",
                   help="also score both readings of the noise line")
    args = p.parse_args(argv)
    try:
        if args.readings:
            print_readings()
        out = run(args.runs, args.scheduler, args.plots)
    except mlid.MlidError as exc:
        print(f"c8_mc: {exc}", file=sys.stderr)
        return 1
    print_results(out, args.runs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
