"""The simulated unstable aircraft (FVSysID test cases 6 to 10): each deck
run through the Python front end and compared with the reference fit of the
textbook software; then filter error on tc08's model (tc08_filter_error.nml,
R from the innovations), which has no reference: its estimates against tc06's
and tc07's (which recover the unstable plant) and tc08's wrong, stable model;
beside it exact ML with r free and bounded below by the record's rounding
variance (built here from the deck): where it ends from the deck's start,
both criteria from 12 noise start values with the time-varying and the
steady-state gain, exact ML's floor moved, and exact ML without the floor.
Every number README.md quotes is printed here.

    python cases/unstable_aircraft/unstable.py
"""

import sys
import warnings
from pathlib import Path

import numpy as np

import mlid
from mlid.cli.deck import iter_deck
from mlid.report.reference import compare, read_reference

HERE = Path(__file__).resolve().parent
REFS = HERE.parents[2] / "shared" / "data" / "refs"
CASES = {"tc06": "unstab_ac_tc06_regstart_fvsysid_octave.txt",
         "tc07": "unstab_ac_tc07_eqdecoup_fvsysid_octave.txt",
         "tc08": "unstab_ac_tc08_oem_fvsysid_octave.txt",
         "tc09": "unstab_ac_tc09_stabilized_fvsysid_octave.txt",
         "tc10": "unstab_ac_tc10_eigtransf_fvsysid_octave.txt"}


def plant(model):
    """The short period's F = [[Zw, u0 + Zq], [Mw, Mq]] from the deck's
    derivatives: tc08's and tc09's F itself; not tc06's and tc07's F, which
    take measured states as inputs, nor tc10's, whose equations carry the
    shift of the transformed data."""
    v = model.value
    return np.array([[v("Zw"), 44.5695 - 1.4768], [v("Mw"), v("Mq")]])


FE_DECK = "tc08_filter_error"
DERIVATIVES = ("Zw", "Zde", "Mw", "Mq", "Mde")
U0_ZQ = 44.5695 - 1.4768          # u0 + Zq, the w equation's q term in every deck
# The record's resolution: AZ and W printed with 6 decimals, Q with 7; the rounding
# variance (10^-d)^2/12 (exact ML's lower bounds on r)
FLOOR = {"r(1)": 1e-12 / 12, "r(2)": 1e-12 / 12, "r(3)": 1e-14 / 12}
# The noise start values of the sweep: q(1) = qs, q(2) = qs/10, r = rs times the deck's
Q_STARTS, R_STARTS = (0.01, 0.1, 1.0, 10.0), (0.1, 1.0, 10.0)
R_DECK = {"r(1)": 0.05, "r(2)": 0.02, "r(3)": 1e-4}


def short_period(v):
    """F = [[Zw, u0 + Zq], [Mw, Mq]] from a dict of the derivatives."""
    return np.array([[v["Zw"], U0_ZQ], [v["Mw"], v["Mq"]]])


def eigenvalues(f):
    """The eigenvalues of a real 2 x 2 F with real eigenvalues, largest first."""
    return np.sort(np.linalg.eigvals(f).real)[::-1]


def eigenvalue_sigma(res):
    """Standard deviations of F's eigenvalues (largest first, as
    ``eigenvalues``) from the corrected covariance of Zw, Mw, Mq, by
    central differences."""
    k = [res.names.index(n) for n in ("Zw", "Mw", "Mq")]
    theta = res.estimate[k]

    def eig(t):
        return eigenvalues(short_period(dict(zip(("Zw", "Mw", "Mq"), t))))

    h = 1e-7
    jac = np.array([(eig(theta + h * e) - eig(theta - h * e)) / (2 * h) for e in np.eye(3)]).T
    return np.sqrt(np.diag(jac @ res.covariance_corrected[np.ix_(k, k)] @ jac.T))


def fit(model, data, **opts):
    """mlid.fit, its MlidWarnings caught: (result, the warnings' text)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mlid.MlidWarning)
        res = mlid.fit(model, data, **opts)
    return res, [str(w.message) for w in caught if issubclass(w.category, mlid.MlidWarning)]


def exact_ml(case):
    """The comparison: the deck's model and options with exact ML instead,
    r(1), r(2), r(3) free and bounded below by the rounding variance (the
    deck's tolerances, the defaults)."""
    m, opts = case.model, case.options()
    names = dict(m.names, **{"r(1)": "R_az", "r(2)": "R_w", "r(3)": "R_q"})
    model = m.with_free(m.free + list(FLOOR), names=names)
    bounds = dict(opts["bounds"], **{k: (v, None) for k, v in FLOOR.items()})
    return model, dict(opts, noise_criterion="exact", bounds=bounds)


def noise_start(model, qs, rs):
    """The model with the sweep's noise start (q(1) = qs, q(2) = qs/10, r rs
    times the deck's), the derivatives' start unchanged (tc08's)."""
    theta = model.theta.copy()
    start = dict({"q(1)": qs, "q(2)": qs / 10}, **{k: v * rs for k, v in R_DECK.items()})
    for k, v in start.items():
        theta[model.element_names().index(k)] = v
    return model.with_theta(theta)


def estimates(res):
    """The fit's line of derivatives, Q and R, and eigenvalues of F."""
    v = " ".join(f"{n} {res.model.value(n):.7g}" for n in DERIVATIVES)
    qr = " ".join(f"{k} {res.model.value(k):.4g}" for k in ("q(1)", "q(2)", *FLOOR))
    return f"{v}; {qr}; eigenvalues of F {eigenvalues(res.model.F)}"


def filter_error():
    """tc08_filter_error.nml (the innovations criterion): its estimates,
    sigma, R from the innovations, eigenvalues of F, cost and warning, and
    the comparison with the tc06, tc07 and tc08 references."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", mlid.MlidWarning)
        case, _, res, error = next(iter_deck(HERE / f"{FE_DECK}.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged} "
          f"({res.reason}), {res.wall_time:.2f} s")
    for w in caught:
        print(f"warning: {w.message}")
    print(f"{'parameter':<9} {'estimate':>16} {'sigma':>11} {'sigma corr.':>11}")
    for n, v, s, sc in zip(res.names, res.estimate, res.sigma, res.sigma_corrected):
        print(f"{n:<9} {v:16.9e} {s:11.4e} {sc:11.4e}")
    print(f"cost {res.cost:.6f}; det B {res.det_r:.6e}; B diagonal (mean innovation covariance) "
          + " ".join(f"{b:.4e}" for b in np.diag(res.rhat)) + "; R from the innovations "
          + " ".join(f"{r:.4e}" for r in res.r_innovations) + "; R/B "
          + " ".join(f"{r:.3g}" for r in res.r_innovations / np.diag(res.rhat)))
    ours = dict(zip(res.names, res.estimate))
    sig = dict(zip(res.names, res.sigma))
    sigc = dict(zip(res.names, res.sigma_corrected))
    lam, lam_sigma = eigenvalues(res.model.F), eigenvalue_sigma(res)
    print(f"eigenvalues of F {lam}; their sigma (corrected, by the delta method) {lam_sigma}; "
          f"at the deck's start values {eigenvalues(case.model.F)}")
    refs = {d: read_reference(REFS / CASES[d]) for d in ("tc06", "tc07", "tc08")}
    for deck, ref in refs.items():
        print(f"\nagainst {ref.path.name}")
        print(f"{'parameter':<9} {'reference':>16} {'sigma_ref':>11} {'(ours-ref)/sigma_ref':>21} "
              f"{'(ours-ref)/sigma':>17} {'/sigma corr.':>13}")
        z = []
        for n in DERIVATIVES:
            r, sr = ref.estimates[n]
            z.append((ours[n] - r) / sr)
            print(f"{n:<9} {r:16.9e} {sr:11.4e} {z[-1]:21.4g} {(ours[n] - r) / sig[n]:17.4g} "
                  f"{(ours[n] - r) / sigc[n]:13.4g}")
        k = int(np.argmax(np.abs(z)))
        eig = eigenvalues(short_period({n: v[0] for n, v in ref.estimates.items()}))
        print(f"largest |ours - ref|/sigma_ref {abs(z[k]):.4g} ({DERIVATIVES[k]}); eigenvalues of "
              f"the reference's plant {eig}, (ours - theirs)/sigma corr. {(lam - eig) / lam_sigma}")
    for d in ("tc06", "tc07"):       # the two references' own disagreement, in each one's sigma
        z = [(refs["tc06"].estimates[n][0] - refs["tc07"].estimates[n][0]) / refs[d].estimates[n][1]
             for n in DERIVATIVES]
        k = int(np.argmax(np.abs(z)))
        print(f"largest |tc06 - tc07|/sigma_{d} {abs(z[k]):.4g} ({DERIVATIVES[k]})")
    return case, res


def exact_from_the_decks_start(case, res):
    """Exact ML with the rounding-variance floors from the deck's start: the
    other local optimum, against the deck's fit (in the deck's sigma_c) and
    tc06 (in its own sigma_c)."""
    model, opts = exact_ml(case)
    data = case.record()
    other, said = fit(model, data, **opts)
    print(f"\nexact ML, r >= the rounding variance, from the deck's start: {other.iterations} "
          f"iterations, converged={other.converged} ({other.reason}), cost {other.cost:.3f}")
    print(estimates(other))
    for w in said:
        print(f"warning: {w}")
    tc06 = read_reference(REFS / CASES["tc06"]).estimates
    k = [res.names.index(n) for n in DERIVATIVES]
    print("(exact - the deck's)/sigma_c of the deck: " + ", ".join(
        f"{n} {d:.4g}" for n, d in zip(DERIVATIVES, (other.estimate[k] - res.estimate[k])
                                      / res.sigma_corrected[k])))
    print("(exact - tc06)/its own sigma_c: " + ", ".join(
        f"{n} {(other.model.value(n) - tc06[n][0]) / other.sigma_corrected[i]:.4g}"
        for i, n in zip(k, DERIVATIVES)))


def noise_starts(case, res):
    """Both criteria from 12 noise start values (q(1) from 0.01 to 10, r
    from 0.1 to 10 times the deck's; the derivatives' start: tc08's), with
    the time-varying and the steady-state gain: where each ends, the largest
    distance of its derivatives from the deck's fit in the deck's sigma_c,
    and for exact ML the cost (the two optima), the r above its floor and
    the r its warning names."""
    print("\nfrom 12 noise start values (the derivatives' start: tc08's); d: largest "
          "|derivative - the deck's|/sigma_c of the deck")
    data = case.record()
    k = [res.names.index(n) for n in DERIVATIVES]
    models = {"exact": exact_ml(case), "innovations": (case.model, case.options())}
    print(f"{'q start':>12} {'r start':>21} |" + " |".join(
        f" {c + ', ' + g:<30}" for c in models for g in ("time-varying", "steady gain"))
        + " | exact ML: r off its floor, warnings")
    print(f"{'':>12} {'':>21} |" + " |".join(
        f" {'it':>3} {'conv':>5} {'cost':>10} {'d':>8}" for _ in range(4)) + " | (t.-v. / steady)")
    ends, failed = {}, []
    for qs in Q_STARTS:
        for rs in R_STARTS:
            line = (f"{qs:5.2g} {qs / 10:6.2g} {R_DECK['r(1)'] * rs:6.2g} {R_DECK['r(2)'] * rs:6.2g} "
                    f"{R_DECK['r(3)'] * rs:7.2g} |")
            named = []
            for c, (model, opts) in models.items():
                for steady in (False, True):
                    o, said = fit(noise_start(model, qs, rs), data,
                                  **dict(opts, steady_state=steady))
                    d = np.max(np.abs(o.estimate[k] - res.estimate[k]) / res.sigma_corrected[k])
                    line += f" {o.iterations:3d} {o.converged!s:>5} {o.cost:10.3f} {d:8.2g} |"
                    where = (f"cost {o.cost:.1f}" if o.converged else "not converged")
                    if c == "innovations" and o.converged:
                        where = "d < 0.001" if d < 0.001 else f"d = {d:.2g}"
                    key = f"{c}, {'steady gain' if steady else 'time-varying'}"
                    ends.setdefault(key, {}).setdefault(where, 0)
                    ends[key][where] += 1
                    if not o.converged:
                        failed.append(f"{key} from q(1) {qs:g}, r {rs:g} times the deck's: "
                                      f"{o.iterations} iterations, cost {o.cost:.3f} ({o.reason})")
                    if c == "exact":     # the r above its floor, and what the warning says
                        off = [f"{n} {o.model.value(n):.2g}" for n, lo in FLOOR.items()
                               if o.model.value(n) > 1.001 * lo]
                        warned = [w.split(" look")[0].removeprefix("outputs ") + " warned, "
                                  + w.split("(")[-1].split(")")[0] for w in said]
                        named.append(", ".join(off + warned) or "-")
            print(line + " " + " / ".join(named))
    for key, where in ends.items():
        print(f"{key}: " + "; ".join(f"{w} from {n}" for w, n in where.items()))
    for f in failed:
        print(f"not converged: {f}")


def floors(case, res):
    """Exact ML with the lower bounds on r multiplied by 0.01, 100 and 1e4,
    from the deck's start (the -6429 optimum) and from r ten times the
    deck's (the -7663 one): cost, r and the derivatives' change from the
    floor times 1 in that fit's sigma_c."""
    print("\nexact ML, the floor on r moved (the rounding variance times k)")
    model, opts = exact_ml(case)
    data = case.record()
    k = [res.names.index(n) for n in DERIVATIVES]
    for rs in (1.0, 10.0):
        start = noise_start(model, 1.0, rs)
        base, _ = fit(start, data, **opts)
        print(f"from q 1, 0.1 and r {rs:g} times the deck's: k = 1 gives cost {base.cost:.3f}")
        for f in (0.01, 100.0, 1e4):
            bounds = dict(opts["bounds"], **{n: (lo * f, None) for n, lo in FLOOR.items()})
            other, _ = fit(start, data, **dict(opts, bounds=bounds))
            d = (other.estimate[k] - base.estimate[k]) / base.sigma_corrected[k]
            rel = np.max(np.abs(other.estimate[k] / base.estimate[k] - 1))
            r = " ".join(f"{other.model.value(n):.3e}" for n in FLOOR)
            print(f"  k = {f:g}: converged={other.converged}, cost {other.cost:.3f}, r {r}; "
                  f"change/sigma_c: " + ", ".join(f"{n} {v:.2g}" for n, v in zip(DERIVATIVES, d))
                  + f"; largest relative change {rel:.1e}")


def without_the_floor(case):
    """Exact ML without the lower bounds on r (q >= 0 kept): with the
    default tolerances, and with only the Newton decrement (tol_grad) to end
    the search; and r fixed at the rounding variance with q free."""
    print("\nexact ML without the lower bounds on r")
    model, opts = exact_ml(case)
    data = case.record()
    qpos = {k: v for k, v in opts.pop("bounds").items() if k.startswith("q(")}
    runs = {"R free, q >= 0, default tolerances": (model, dict(opts, bounds=qpos)),
            "R free, q >= 0, tol_cost = tol_step = 0":
                (model, dict(opts, bounds=qpos, tol_cost=0.0, tol_step=0.0))}
    theta = model.theta.copy()
    for k, v in FLOOR.items():
        theta[model.element_names().index(k)] = v
    fixed = model.with_theta(theta).with_free(case.model.free)
    runs["r fixed at the rounding variance, q free"] = (fixed, dict(opts, bounds=qpos))
    for what, (m, o) in runs.items():
        try:
            r, said = fit(m, data, **o)
            ends = (f"converged={r.converged} after {r.iterations} iterations ({r.reason}), "
                    f"cost {r.cost:.4f}")
        except mlid.MlidError as exc:
            r, said, ends = exc.result, [], f"failed: {exc}"
        rs = "; r " + " ".join(f"{m.value(k) if r.failed else r.model.value(k):.3e}"
                               for k in FLOOR) if r is not None else ""
        print(f"{what}: {ends}{rs}")
        if r is not None and not r.failed and r.message:
            print(f"  message: {r.message}")
        for w in said:
            if r is None or w not in r.message:       # a converged fit's message is its warning
                print(f"  warning: {w}")


def main():
    if not REFS.is_dir():
        sys.exit(f"the references are not at {REFS}")
    for deck, ref_name in CASES.items():
        case, _, res, error = next(iter_deck(HERE / f"{deck}.nml"))
        if error:
            sys.exit(f"{case.where()}: {error}")
        print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged}")
        print("\n".join(compare(res, read_reference(REFS / ref_name))["lines"]))
        what = "F" if deck in ("tc08", "tc09") else "the plant (from Zw, Mw, Mq, Zq, u0)"
        print(f"eigenvalues of {what} {np.linalg.eigvals(plant(res.model))}")
    case, res = filter_error()
    exact_from_the_decks_start(case, res)
    noise_starts(case, res)
    floors(case, res)
    without_the_floor(case)


if __name__ == "__main__":
    main()
