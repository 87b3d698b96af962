"""The numbers docs/guide/campaign_tables.md quotes for the one-step global
table fit (issue 46 item 2, mlid.fit_global) on the synthetic campaign of
tests/table_campaign.py (30 manoeuvres, alpha 0 .. 0.18 x Mach 0.3, 0.5,
0.7), each printed on a line headed by the guide's check:

- z: every value of seed 0 against the truth in its sigma (max |z|);
- mc: each value's spread over seeds against its mean Cramer-Rao sigma, on
  seeds 0 .. 149 (the test's), 150 .. 299 and all 300; the mean's bias in
  standard errors;
- two-step: the local fits + fit_tables against the one-step fit on seed 0:
  the difference in the combined sigma, in the theory's root (test_global_fit
  two-step test), the sigma ratio;
- test: the local fits' chi-square test against the global tables over
  seeds 300 .. 349 (mean chi2 / dof, fraction named at 1 %), and the degrees
  of freedom of the one- and two-step tests on the sparse campaign;
- filter error: ten manoeuvres, against output error in the combined sigma,
  and its sigma over output error's.

    .venv/bin/python benchmarks/global_fit_numbers.py [--seeds 300]

About 2 minutes on this machine (the Monte Carlo is most of it).
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import mlid

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
import table_campaign as tc  # noqa: E402
import test_global_fit as tg  # noqa: E402   (its campaign, sparse model and records)

CONDS = tc.grid(10, [0.3, 0.5, 0.7])


def records(seed, conds=CONDS):
    return [tc.record(c, 1000 * seed + k) for k, c in enumerate(conds)]


def global_fit(seed, **kw):
    return mlid.fit_global(tc.global_model(), records(seed), CONDS, variables=tc.VARIABLES,
                           **kw)


def ratio_line(what, values, sigma, names):
    r = values.std(axis=0, ddof=1) / sigma.mean(axis=0)
    k = int(np.argmax(r))
    print(f"mc {what}: spread / sigma {r.min():.2f} .. {r.max():.2f} (max {names[k]}), mean "
          f"{r.mean():.2f}; Z_alpha[1] {r[names.index('Z_alpha[1]')]:.2f}")


def monte_carlo(n):
    fits = [global_fit(s) for s in range(n)]
    names = fits[0].names
    values = np.array([np.asarray(f.values) for f in fits])
    sigma = np.array([np.asarray(f.sigma) for f in fits])
    truth = tc.global_truth(tc.global_tables())
    z = (values[0] - truth) / sigma[0]
    print(f"z seed 0: every value within {np.abs(z).max():.2f} sigma of the truth")
    half = min(150, n)
    ratio_line(f"seeds 0..{half - 1}", values[:half], sigma[:half], names)
    bias = (values[:half].mean(0) - truth) / (values[:half].std(0, ddof=1) / np.sqrt(half))
    print(f"mc seeds 0..{half - 1}: mean's bias at most {np.abs(bias).max():.2f} standard "
          "errors")
    if n > half:
        ratio_line(f"seeds {half}..{n - 1}", values[half:], sigma[half:], names)
        ratio_line(f"seeds 0..{n - 1}", values, sigma, names)


def two_step():
    recs = records(0)
    local = [mlid.fit(tc.local_model(c), d) for c, d in zip(CONDS, recs)]
    one = mlid.fit_global(tc.global_model(), recs, CONDS, variables=tc.VARIABLES, local=local)
    two = mlid.fit_tables(local, tc.global_tables(), CONDS, variables=tc.VARIABLES)
    s1, s2 = np.asarray(one.sigma), np.asarray(two.sigma)
    dv = np.abs(np.asarray(one.values) - np.asarray(two.values))
    theory = np.sqrt(np.abs(s2**2 - s1**2) + 2 / tc.NT * s1**2)
    print(f"two-step seed 0: difference at most {(dv / np.hypot(s1, s2)).max():.2f} of the "
          f"combined sigma, {(dv / theory).max():.2f} of the theory's root; sigma two/one "
          f"{(s2 / s1).min():.3f} .. {(s2 / s1).max():.3f}")


def test_calibration(seeds):
    chi2, flagged, dof = [], [], set()
    for seed in seeds:
        recs = records(seed)
        local = [mlid.fit(tc.local_model(c), d) for c, d in zip(CONDS, recs)]
        one = mlid.fit_global(tc.global_model(), recs, CONDS, variables=tc.VARIABLES,
                              local=local)
        chi2 += list(one.chi2 / one.dof)
        flagged += list(one.p_value < 0.01)
        dof |= set(one.dof.tolist())
    print(f"test seeds {seeds[0]}..{seeds[-1]} ({len(chi2)} tests, dof {sorted(dof)}): mean "
          f"chi2/dof {np.mean(chi2):.3f}, named at 1 %: {100 * np.mean(flagged):.1f} %")
    from mlid.model.tables import Table
    for seed in (1, 2, 3):
        recs = records(seed, tg.SPARSE)
        local = [mlid.fit(tc.local_model(c), d) for c, d in zip(tg.SPARSE, recs)]
        one = mlid.fit_global(tg.sparse_model(), recs, tg.SPARSE, variables=tc.VARIABLES,
                              local=local)
        tabs = tc.global_tables()
        tabs["M_q"] = Table("alpha_trim", tg.BQ_SPARSE)
        two = mlid.fit_tables(local, tabs, tg.SPARSE, variables=tc.VARIABLES)
        print(f"test sparse seed {seed}: dof one-step {one.dof.tolist()}, two-step "
              f"{two.dof.tolist()}")


def filter_error():
    recs, conds = records(0)[::3], CONDS[::3]
    model = tc.global_model()
    oe = mlid.fit_global(model, recs, conds, variables=tc.VARIABLES)
    stab = [f"stab({i},{j})" for i in (1, 2) for j in (1, 2)]
    fe = mlid.fit_global(model.with_free(list(model.free_names()) + stab), recs, conds,
                         variables=tc.VARIABLES, method="filter_error", filter_params="gain")
    d = np.abs(np.asarray(fe.values) - np.asarray(oe.values)) / np.hypot(fe.sigma, oe.sigma)
    r = np.asarray(fe.sigma) / np.asarray(oe.sigma)
    print(f"filter error: within {d.max():.2f} of the combined sigma of output error's; its "
          f"sigma {r.min():.2f} .. {r.max():.2f} of output error's")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=300, help="Monte Carlo seeds (300)")
    ap.add_argument("--test-seeds", type=int, default=50, help="calibration seeds (50)")
    args = ap.parse_args()
    monte_carlo(args.seeds)
    two_step()
    test_calibration(list(range(300, 300 + args.test_seeds)))
    filter_error()


if __name__ == "__main__":
    main()
