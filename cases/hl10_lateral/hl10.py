"""HL-10 lifting body, lateral, with a yaw damper (NASA CR-2200 §5.2, Table 5.3).

Synthetic data from eq. 5.1 with Table 5.3's wind-tunnel values as truth. A
yaw damper feeds yaw rate back to the rudder and the pilot's rudder input is
weak, so N_r and N_dr (and L_r and L_dr) are nearly confounded: the
unconstrained fit matches the data but returns wrong signs.  The remedies of
report §4.6, side by side: a priori weighting, fixed parameters, the
rank-deficient solution, bounds.  Then the model-size comparison (§5.3.5) and
the prediction check (§5.2.8).

    python hl10.py [--plots DIR]

Every number and where it comes from: README.md in this folder.
"""

import argparse
import sys

import numpy as np

import mlid
from mlid.design.signals import input_signal

ALPHA = np.radians(16.8)          # Table 5.3 heading / §5.2: alpha = 16.8 deg
V = 1181.0                        # ft/s: Mach 1.22 at 45,000 ft (ours)
G_V = 32.174 * np.cos(ALPHA) / V  # g cos(theta)/V with theta = alpha (ours)
WT = {"L_p": -0.3435, "L_r": 0.2723, "L_beta": -30.75, "N_p": 0.0245, "N_r": -0.1290,
      "N_beta": 6.8411, "Y_p": -0.0617, "Y_r": -0.0120, "Y_beta": -0.0916, "L_da": 11.2464,
      "L_dr": 5.665, "N_da": 0.8135, "N_dr": -3.617, "Y_da": -0.00180, "Y_dr": 0.0111}
K_YAW = 1.0                       # yaw damper gain, deg rudder per deg/s yaw rate (ours)
NOISE_STD = [0.2, 0.1, 0.1, 0.1, 0.01]     # p, r [deg/s], beta, phi [deg], a_y' [deg/s] (ours)
DT, NT, SEED = 0.02, 327, 1       # 327 samples at 50/s (§5.2); seed ours
ELEMENT = {"L_p": "f(1,1)", "L_r": "f(1,2)", "L_beta": "f(1,3)", "N_p": "f(2,1)",
           "N_r": "f(2,2)", "N_beta": "f(2,3)", "Y_beta": "f(3,3)", "L_da": "g(1,1)",
           "L_dr": "g(1,2)", "N_da": "g(2,1)", "N_dr": "g(2,2)", "Y_da": "g(3,1)",
           "Y_dr": "g(3,2)"}
# a_y' = Y_p p + Y_r r + Y_beta beta + Y_da da + Y_dr dr carries the side-force derivatives
TIES = {"h(5,3)": "f(3,3)", "d(5,1)": "g(3,1)", "d(5,2)": "g(3,2)"}
KEY = ["L_r", "N_r", "L_dr", "N_dr"]   # the confounded four


def matrices(v):
    F = np.array([[v["L_p"], v["L_r"], v["L_beta"], 0.0], [v["N_p"], v["N_r"], v["N_beta"], 0.0],
                  [v["Y_p"] + np.sin(ALPHA), v["Y_r"] - np.cos(ALPHA), v["Y_beta"], G_V],
                  [1.0, np.tan(ALPHA), 0.0, 0.0]])
    G = np.array([[v["L_da"], v["L_dr"]], [v["N_da"], v["N_dr"]], [v["Y_da"], v["Y_dr"]],
                  [0.0, 0.0]])
    H = np.vstack([np.eye(4), [v["Y_p"], v["Y_r"], v["Y_beta"], 0.0]])
    D = np.vstack([np.zeros((4, 2)), [v["Y_da"], v["Y_dr"]]])
    return F, G, H, D


def record(seed=SEED, k_yaw=K_YAW, noise_scale=1.0, nt=NT, rudder=0.2):
    """Closed loop: the rudder surface is the pilot's input plus K r; the
    record holds the surface positions, as a flight record would.  The
    keywords vary the set-up for the scan of flips (defaults: the case)."""
    F, G, H, D = matrices(WT)
    loop = np.outer(G[:, 1], [0.0, k_yaw, 0.0, 0.0])
    closed = mlid.LinearModel(F + loop, G, H + np.outer(D[:, 1], [0.0, k_yaw, 0.0, 0.0]), D,
                              r=np.square(np.multiply(NOISE_STD, noise_scale)))
    t = np.arange(nt) * DT
    da = input_signal("3211", 2.0, 0.5, 0.3, DT, nt)       # aileron, deg
    dr_pilot = input_signal("doublet", rudder, 3.5, 0.3, DT, nt)   # weak rudder, deg
    sim, x = mlid.simulate(closed, t, np.column_stack([da, dr_pilot]), seed=seed)
    return mlid.FlightData(t, np.column_stack([da, dr_pilot + k_yaw * x[:, 1]]), sim.y,
                           ["delta_a", "delta_r"], ["p", "r", "beta", "phi", "a_y'"])


def wind_tunnel():
    """The a priori ('wind-tunnel') values: the truth 20% off, alternately up
    and down (ours), so that no remedy is handed the answer."""
    return {n: v * (1.2 if i % 2 else 0.8) for i, (n, v) in enumerate(WT.items())}


def model(free):
    F, G, H, D = matrices(wind_tunnel())
    return mlid.LinearModel(F, G, H, D, free=[ELEMENT[n] for n in free],
                            names={e: n for n, e in ELEMENT.items()}, ties=TIES)


def fits(data):
    allfree = list(ELEMENT)
    wt = wind_tunnel()
    out = {"unconstrained": mlid.fit(model(allfree), data)}
    weights = {n: 1.0 / (0.3 * wt[n]) ** 2 for n in KEY}           # 30% a priori sigma
    out["a priori"] = mlid.fit(model(allfree), data, prior_weight=weights)
    out["fixed L_dr, N_dr"] = mlid.fit(model([n for n in allfree if n not in ("L_dr", "N_dr")]),
                                       data)
    # the report's minimum rank for HL-10 is 10 (§5.3.6)
    out["rank-def., per it."] = mlid.fit(model(allfree), data, rank_min=10)
    out["rank-def., staged"] = mlid.fit(model(allfree), data, rank_min=10, rank_rule="staged")
    out["bounds (signs)"] = mlid.fit(model(allfree), data,
                                     bounds={"L_r": (0.0, None), "N_r": (None, 0.0)})
    return out


def sensitivity_pairs(res):
    """The largest relative difference, over the outputs, between the
    output sensitivity norms of L_r and L_dr and of N_r and N_dr."""
    s = res.sensitivity_norms()
    col = {n: s[:, res.names.index(n)] for n in KEY}
    return {f"{a}/{b}": float(np.max(np.abs(col[a] / col[b] - 1)))
            for a, b in (("L_r", "L_dr"), ("N_r", "N_dr"))}


def rank_costs(data, staged):
    """The rank rules' costs (no prior, so the cost is the objective):
    iteration 1 from the a priori values at each fixed rank 10 to 13 (what
    the per-iteration rule compares first), and the staged fit's converged
    cost with the fits that continue from its estimate at rank 12 and 13."""
    allfree = list(ELEMENT)
    first = {k: mlid.fit(model(allfree), data, rank_min=k, rank_max=k, max_iter=1).cost
             for k in (10, 11, 12, 13)}
    on = {k: mlid.fit(staged.model, data, rank_min=k, rank_max=k).cost for k in (12, 13)}
    return first, {staged.rank: staged.cost, **on}


def summary(name, res):
    est = {n: res.estimate[res.names.index(n)] for n in res.names}
    wrong = [n for n, e in est.items() if np.sign(e) * np.sign(WT[n]) < 0]    # 0: on a bound
    dist = np.sqrt(np.mean([((est.get(n, wind_tunnel()[n]) - WT[n]) / WT[n]) ** 2 for n in KEY]))
    return {"name": name, "est": est, "wrong": wrong, "ln_det_R": np.linalg.slogdet(res.rhat)[1],
            "rms_fit": float(np.sqrt(np.mean((res.residuals / np.std(res.data.y, axis=0)) ** 2))),
            "dist": float(dist), "rank": res.rank, "k": len(res.names)}


# --- the report's own runs (§5.2.3-5.2.7, Table 5.3) on this record -------------------
FOUR = ["L_p", "L_r", "N_p", "N_r"]        # the signs the report's output-error fit flipped
STAR = {"Y_p*": "f(3,1)", "Y_r*": "f(3,2)"}   # identified as Y_p + sin(alpha), Y_r - cos(alpha)
# Table 5.3: the four and the likelihood value of each maximum-likelihood column
T53 = {"output error": {"L_p": 0.915, "L_r": -1.363, "N_p": -0.160, "N_r": 0.432, "J": -2243},
       "output error, Y_p Y_r free": {"L_p": 0.395, "L_r": 0.0671, "N_p": -0.187, "N_r": 0.548,
                                      "J": -2359},
       "a priori": {"L_p": -0.295, "L_r": 1.574, "N_p": 0.0380, "N_r": -0.111, "J": -1552},
       "a priori, biases": {"L_p": -0.271, "L_r": 1.349, "N_p": 0.0550, "N_r": -0.0896,
                            "J": -2264}}
# output-error column: the four, and two strong ones, value and Cramer-Rao sigma
T53_OE = {"L_p": (0.915, 0.025), "L_r": (-1.363, 0.138), "N_p": (-0.160, 0.00429),
          "N_r": (0.432, 0.0187), "L_beta": (-56.489, 0.305), "Y_beta": (-1.471, 0.0202)}


def report_model(y_free, y_zero=False, biases=False):
    """The report's model of each run, from the a priori values: Y_p, Y_r
    zero (its first run) or identified as Y_p*, Y_r* (the others), output
    biases on beta, phi, a_y' (the outputs §5.2.7 found biased; p and r
    would duplicate the initial state and constant terms)."""
    v = dict(wind_tunnel(), **({"Y_p": 0.0, "Y_r": 0.0} if y_zero else {}))
    F, G, H, D = matrices(v)
    free, names, ties = [ELEMENT[n] for n in ELEMENT], {e: n for n, e in ELEMENT.items()}, dict(TIES)
    if y_free:      # a_y' carries Y_p, Y_r: h(5,1) = Y_p* - sin(alpha), h(5,2) = Y_r* + cos(alpha)
        free += list(STAR.values())
        names |= {e: n for n, e in STAR.items()}
        ties |= {"h(5,1)": f"{-float(np.sin(ALPHA))!r} + f(3,1)",
                 "h(5,2)": f"{float(np.cos(ALPHA))!r} + f(3,2)"}
    return mlid.LinearModel(F, G, H, D, free=free + (["bias(3)", "bias(4)", "bias(5)"] if biases
                                                     else []), names=names, ties=ties)


def report_runs(data):
    """Table 5.3's four maximum-likelihood runs, from the a priori values.
    The FRC weights the report used are not printed: ours weight every
    derivative with sigma 30% of its a priori value."""
    wt = wind_tunnel()
    w = {n: 1.0 / (0.3 * wt[n]) ** 2 for n in ELEMENT}
    return {"output error": mlid.fit(report_model(False, y_zero=True), data),
            "output error, Y_p Y_r free": mlid.fit(report_model(True), data),
            "a priori": mlid.fit(report_model(True), data, prior_weight=w),
            "a priori, biases": mlid.fit(report_model(True, biases=True), data, prior_weight=w),
            # the remedies' model, Y_p and Y_r held 20% off: a model the data dispute
            "held: output error": mlid.fit(model(list(ELEMENT)), data),
            "held: a priori": mlid.fit(model(list(ELEMENT)), data, prior_weight=w)}


def _ratio(dj, n):
    """|R|^(1/ny) after over before, from a change of J = N/2 ln|R| + const."""
    return float(np.exp(2.0 * dj / (n * 5)))


def report_table(runs):
    """Rows (quantity, report, mlid, verdict) for every number the README
    quotes from Table 5.3."""
    rows = []
    for run, res in runs.items():
        est = dict(zip(res.names, res.estimate))
        if run not in T53:      # no report column: the sign against the wind tunnel's
            rows += [(f"{run}: {n}", "-", f"{est[n]:.4g}", "right sign" if np.sign(est[n]) ==
                      np.sign(WT[n]) else "wrong sign") for n in FOUR]
            continue
        for n in FOUR:
            rep, ours = T53[run][n], est[n]
            flipped = np.sign(rep) != np.sign(WT[n])
            same = np.sign(ours) == np.sign(rep)
            verdict = ("flip reproduced" if same else "flip not reproduced") if flipped else \
                ("sign kept" if same else "sign not kept")
            rows.append((f"{run}: {n}", f"{rep:.4g}", f"{ours:.4g}", verdict))
    res = runs["output error"]
    for n, (rep, sig) in T53_OE.items():   # how far from the wind tunnel, in the fit's sigma
        k = res.names.index(n)
        rows.append((f"output error: ({n} - wind tunnel)/sigma", f"{(rep - WT[n]) / sig:.1f}",
                     f"{(res.estimate[k] - WT[n]) / res.sigma[k]:.1f}", "size"))
    n = len(res.data.t)
    for a, b, note in [("output error", "output error, Y_p Y_r free", "Y_p, Y_r freed"),
                       ("output error, Y_p Y_r free", "a priori", "a priori, no biases"),
                       ("output error, Y_p Y_r free", "a priori, biases", "the '10% worse fit'"),
                       ("output error", "a priori, biases", "a priori + biases vs first run")]:
        rep = _ratio(T53[b]["J"] - T53[a]["J"], 327)
        ours = _ratio(runs[b].cost - runs[a].cost, n)
        verdict = "reproduced" if abs(ours - rep) < 0.05 else "not reproduced (no change)" \
            if abs(ours - 1) < 0.01 else "direction only" if (ours - 1) * (rep - 1) > 0 \
            else "not reproduced"
        rows.append((f"|R|^(1/5) {note}", f"{rep:.3f} (dJ {T53[b]['J'] - T53[a]['J']:+d})",
                     f"{ours:.3f} (dJ {runs[b].cost - runs[a].cost:+.0f})", verdict))
    dj = runs["held: a priori"].cost - runs["held: output error"].cost
    ours = _ratio(dj, n)
    rows.append(("|R|^(1/5) a priori, Y_p Y_r held 20% off", "1.123 (dJ +95)",
                 f"{ours:.3f} (dJ {dj:+.0f})",
                 "reproduced" if abs(ours - 1.123) < 0.05 else "not reproduced"))
    return rows


SCAN = {"the case": {}, "no yaw damper (K 0)": {"k_yaw": 0.0}, "K 2": {"k_yaw": 2.0},
        "noise x3": {"noise_scale": 3.0}, "227 samples": {"nt": 227},
        "rudder doublet 2 deg": {"rudder": 2.0}}


def flip_scan(seeds=range(1, 21)):
    """How often each of the four flips, over seeds, for set-ups around the
    case's, with Y_p, Y_r held at the a priori values (the remedies' model)
    and identified (the report's later runs); median Cramer-Rao sigmas."""
    out = []
    for label, kw in SCAN.items():
        for y_free in (False, True):
            count, sig, failed = dict.fromkeys(FOUR, 0), [], 0
            for seed in seeds:
                m = report_model(True) if y_free else model(list(ELEMENT))
                try:
                    res = mlid.fit(m, record(seed=seed, **kw))
                except mlid.SingularInformationError:   # counted, not hidden
                    failed += 1
                    continue
                est, s = dict(zip(res.names, res.estimate)), dict(zip(res.names, res.sigma))
                for n in FOUR:
                    count[n] += int(np.sign(est[n]) != np.sign(WT[n]))
                sig.append([s[n] for n in FOUR])
            out.append({"label": label, "y_free": y_free, "count": count, "n": len(seeds) - failed,
                        "failed": failed,
                        "sigma": np.median(sig, axis=0)})
    return out


def run(plots=None):
    data = record()
    results = fits(data)
    rows = [summary(n, r) for n, r in results.items()]
    # model size: the unconstrained model against smaller free sets (§5.3.5)
    size_fits = [results["unconstrained"], results["fixed L_dr, N_dr"],
                 mlid.fit(model([n for n in ELEMENT if n not in ("L_dr", "N_dr", "Y_da", "Y_dr")]),
                          data)]
    table = mlid.compare_models(size_fits, ["13: all", "11: L_dr, N_dr fixed",
                                            "9: and Y_da, Y_dr fixed"],
                                plot=f"{plots}/hl10_model_size.png" if plots else None)
    # prediction check (§5.2.8): fit the first 227 samples, predict the last 100
    first = mlid.FlightData(data.t[:227], data.u[:227], data.y[:227], data.input_names,
                            data.output_names)
    part = mlid.fit(model(list(ELEMENT)), first, rank_min=10, rank_rule="staged")
    pred = mlid.predict(part, data, 227)
    if plots:
        from mlid.discrepancy.model_checks import plot_prediction
        from mlid.report.plots import plot_fit
        plot_fit(results["unconstrained"], plots, "hl10_unconstrained")
        plot_fit(results["rank-def., staged"], plots, "hl10_rank_deficient")
        plot_prediction(data, pred["prediction"], 227, f"{plots}/hl10_prediction.png")
    return results, rows, table, pred


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--plots", metavar="DIR")
    p.add_argument("--scan", action="store_true", help="also the flip counts over 20 seeds")
    args = p.parse_args(argv)
    try:
        results, rows, table, pred = run(args.plots)
        first, staged = rank_costs(record(), results["rank-def., staged"])
        runs = report_runs(record())
        scan = flip_scan() if args.scan else []
    except mlid.MlidError as exc:
        print(f"hl10: {exc}", file=sys.stderr)
        return 1
    print(" HL-10 with a yaw damper: the confounded derivatives under each remedy")
    print(f" {'':<18}" + "".join(f"{n:>10}" for n in KEY)
          + f"{'wrong signs':>14}{'fit rms':>9}{'dist':>7}{'rank':>6}")
    print(f" {'truth':<18}" + "".join(f"{WT[n]:10.4f}" for n in KEY))
    for r in rows:
        cells = "".join(f"{r['est'][n]:10.4f}" if n in r["est"] else f"{'fixed':>10}" for n in KEY)
        print(f" {r['name']:<18}{cells}{len(r['wrong']):14d}{r['rms_fit']:9.4f}{r['dist']:7.2f}"
              f"{r['rank']:4d}/{r['k']}")
    print(" fit rms: residual rms over output rms; dist: rms relative error of the four")
    print("\n model size (§5.3.5): k, ln|R|, FPE = (N-k)/(N+k) ln|R|")
    for row in table:
        print(f"  {row['label']:<24} k={row['k']:2d}  ln|R|={row['ln_det_R']:9.3f}  "
              f"FPE={row['fpe']:9.3f}")
    print("\n prediction of the last 100 samples from a rank-deficient fit of the first 227 "
          "(rms / noise sigma): " + ", ".join(f"{n} {v:.2f}" for n, v in
                                              zip(["p", "r", "beta", "phi", "a_y'"],
                                                  pred["rms_over_noise"])))
    print("\n" + results["unconstrained"].report().split(" normalised information")[0].rstrip()
          .split("\n")[0])
    print(" " + results["unconstrained"].identifiability()[1].strip())
    print(" " + results["unconstrained"].identifiability()[2].strip())
    print(" output sensitivity norms, largest relative difference over the outputs: " + ", ".join(
        f"{k} {100 * v:.1f}%" for k, v in sensitivity_pairs(results["unconstrained"]).items()))
    print("\n rank rules: cost after iteration 1 from the a priori values at rank "
          + ", ".join(f"{k} {c:.2f}" for k, c in first.items()))
    print(" converged cost of the staged fit (rank 11) and continuing from its estimate at rank "
          "12 and 13: " + ", ".join(f"rank {k} {c:.2f}" for k, c in staged.items()))
    print("\n Table 5.3's runs on this record, from the a priori values: report | mlid | verdict")
    for q, rep, ours, verdict in report_table(runs):
        print(f"  {q:<46} | {rep:>16} | {ours:>16} | {verdict}")
    if scan:
        print("\n flips of the four over seeds 1-20 (Y_p, Y_r held / identified); median sigma")
        for r in scan:
            print(f"  {r['label']:<22} {'identified' if r['y_free'] else 'held':<11}"
                  + "".join(f" {n} {r['count'][n]:2d}/{r['n']}" for n in FOUR)
                  + "  sigma " + " ".join(f"{v:.4f}" for v in r["sigma"])
                  + (f"  ({r['failed']} singular)" if r["failed"] else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
