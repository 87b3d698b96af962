"""The simulated unstable aircraft (FVSysID test cases 6 to 10): each deck
run through the Python front end and compared with the reference fit of the
textbook software; then filter error on tc08's model (tc08_filter_error.nml),
which has no reference: its estimates against tc06's and tc07's (which recover
the unstable plant) and tc08's wrong, stable model, from other noise start
values, and what R free without the deck's lower bounds does.  Every number
README.md quotes is printed here.

    python cases/unstable_aircraft/unstable.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.deck import iter_deck
from mlid.reference import compare, read_reference

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
# variance (10^-d)^2/12 (the deck's lower bounds on r)
FLOOR = {"r(1)": 1e-12 / 12, "r(2)": 1e-12 / 12, "r(3)": 1e-14 / 12}


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


def filter_error():
    """tc08_filter_error.nml: its estimates, sigma, eigenvalues of F and cost,
    and the comparison with the tc06, tc07 and tc08 references."""
    case, _, res, error = next(iter_deck(HERE / f"{FE_DECK}.nml"))
    if error:
        sys.exit(f"{case.where()}: {error}")
    print(f"\n{case.title}: {res.iterations} iterations, converged={res.converged} "
          f"({res.reason}), {res.wall_time:.2f} s")
    print(f"{'parameter':<9} {'estimate':>16} {'sigma':>11} {'sigma corr.':>11}")
    for n, v, s, sc in zip(res.names, res.estimate, res.sigma, res.sigma_corrected):
        print(f"{n:<9} {v:16.9e} {s:11.4e} {sc:11.4e}")
    print(f"cost {res.cost:.6f}; det B {res.det_r:.6e}; B diagonal (mean innovation covariance) "
          + " ".join(f"{b:.4e}" for b in np.diag(res.rhat)))
    ours = dict(zip(res.names, res.estimate))
    sig = dict(zip(res.names, res.sigma))
    sigc = dict(zip(res.names, res.sigma_corrected))
    lam, lam_sigma = eigenvalues(res.model.F), eigenvalue_sigma(res)
    print(f"eigenvalues of F {lam}; their sigma (corrected, by the delta method) {lam_sigma}")
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


def noise_starts(case, res):
    """The deck from 12 other start values of q and r (the derivatives'
    start: tc08's), where each ends (in the deck's Cramer-Rao sigma); and
    the same starts with the default tol_cost and tol_step, with process
    noise held over each sample, and with the steady-state gain."""
    print("\nfilter error from other noise start values (the derivatives' start: tc08's)")
    print(f"{'q start':>16} {'r start':>26} | {'the deck: it':>12} {'conv':>5} {'cost':>11} "
          f"{'max|d|/sig':>10} {'lambda':>7} | {'default tol':>17} | {'held':>17} | "
          f"{'steady gain':>17}")
    m, opts = case.model, case.options()
    names = m.element_names()
    data = case.record()
    variants = (dict(tol_cost=1e-8, tol_step=1e-8), dict(process_noise="held"),
                dict(steady_state=True))
    for qs in (0.01, 0.1, 1.0, 10.0):
        for rs in (0.1, 1.0, 10.0):
            theta = m.theta.copy()
            start = {"q(1)": qs, "q(2)": qs / 10, "r(1)": 0.05 * rs, "r(2)": 0.02 * rs,
                     "r(3)": 1e-4 * rs}
            for k, v in start.items():
                theta[names.index(k)] = v
            other = mlid.fit(m.with_theta(theta), data, **opts)
            d = np.max(np.abs((other.estimate - res.estimate) / res.sigma)[:len(DERIVATIVES)])
            line = (f"{qs:8.2g} {qs / 10:7.2g} {0.05 * rs:8.2g} {0.02 * rs:8.2g} "
                    f"{1e-4 * rs:8.2g} | {other.iterations:12d} {other.converged!s:>5} "
                    f"{other.cost:11.3f} {d:10.2g} "
                    f"{np.max(np.linalg.eigvals(other.model.F).real):7.4f}")
            for v in variants:
                o = mlid.fit(m.with_theta(theta), data, **dict(opts, **v))
                line += f" | {o.converged!s:>5} {o.cost:11.3f}"
            print(line)


def steady_gain(case):
    """The steady-state gain from the deck's start: where it stops, and how
    far above its floor r(q) lies after the first iteration (the next step,
    scaled to keep it there, is almost nothing)."""
    opts = dict(case.options(), steady_state=True)
    floor = opts["bounds"]["r(3)"][0]
    one = mlid.fit(case.model, case.record(), **dict(opts, max_iter=1))
    full = mlid.fit(case.model, case.record(), **opts)
    print(f"\nsteady-state gain from the deck's start: r(q) - its floor after one iteration "
          f"{one.model.value('r(3)') - floor:.2g}; the fit: converged={full.converged} after "
          f"{full.iterations} iterations ({full.reason}), cost {full.cost:.3f}")


def floors(case, res):
    """The deck with its lower bounds on r multiplied by 0.01, 100 and 1e4:
    the derivatives' change in the deck's Cramer-Rao sigma."""
    print("\nthe floor on r moved (the deck's floor times k)")
    m, opts = case.model, case.options()
    data = case.record()
    for k in (0.01, 100.0, 1e4):
        bounds = {n: ((lo * k if n in FLOOR else lo), hi) for n, (lo, hi) in opts["bounds"].items()}
        other = mlid.fit(m, data, **dict(opts, bounds=bounds))
        d = (other.estimate - res.estimate) / res.sigma
        rel = np.abs(other.estimate / res.estimate - 1)[:len(DERIVATIVES)]
        worst = ", ".join(f"{n} {d[res.names.index(n)]:.2g}" for n in DERIVATIVES)
        r = " ".join(f"{other.model.value(n):.3e}" for n in FLOOR)
        print(f"k = {k:g}: converged={other.converged}, r {r}; (theirs - the deck's)/sigma: "
              f"{worst}; largest relative change {rel.max():.1e}")


def without_the_floor(case):
    """What the deck's lower bounds on r prevent: R free with only q >= 0
    (the deck's tolerances, and the default ones), and r fixed at the
    floor with q free."""
    print("\nwithout the lower bounds on r")
    m, opts = case.model, case.options()
    data = case.record()
    qpos = {k: v for k, v in opts.pop("bounds").items() if k.startswith("q(")}
    runs = {"R free, q >= 0, tol_cost = tol_step = 0": (m, dict(opts, bounds=qpos)),
            "R free, q >= 0, default tol_cost, tol_step":
                (m, dict(opts, bounds=qpos, tol_cost=1e-8, tol_step=1e-8))}
    theta = m.theta.copy()
    for k, v in FLOOR.items():
        theta[m.element_names().index(k)] = v
    fixed = m.with_theta(theta).with_free([f for f in m.free if not f.startswith("r(")])
    runs["r fixed at the floor, q free"] = (fixed, dict(opts, bounds=qpos))
    for what, (model, o) in runs.items():
        try:
            r = mlid.fit(model, data, **o)
            ends = (f"converged={r.converged} after {r.iterations} iterations ({r.reason}), "
                    f"cost {r.cost:.4f}")
        except mlid.MlidError as exc:
            r, ends = exc.result, f"failed: {exc}"
        rs = "; r " + " ".join(f"{model.value(k) if r.failed else r.model.value(k):.3e}"
                               for k in FLOOR) if r is not None else ""
        print(f"{what}: {ends}{rs}")
        if r is not None and not r.failed and r.message:
            print(f"  message: {r.message}")


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
    noise_starts(case, res)
    steady_gain(case)
    floors(case, res)
    without_the_floor(case)


if __name__ == "__main__":
    main()
