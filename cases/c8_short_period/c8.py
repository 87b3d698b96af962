"""C-8 short period: the deck c8.nml run through the Python front end (case
1 simulates the doublet record from the report's values, case 2 fits the
five short-period derivatives to it by output error) and every number
README.md quotes: truth, start, estimate, Cramer-Rao sigma and
(estimate - truth)/sigma of each unknown, the iterations, and R-hat against
the simulated noise variances.  With --runs N, also N seeded Monte Carlo
runs of the same experiment (the deck's doublet, truth, noise, start and
estimator options; run k has seed SEED + k): sample sigma / mean Cramer-Rao
sigma of each estimate, and the mean's distance from the truth in standard
errors.

    python c8.py [--runs N]     (here; writes c8_doublet.dat beside the deck)

Every number and where it comes from: README.md in this folder.
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import mlid

DECK = Path(__file__).with_name("c8.nml")
SEED = 100      # the Monte Carlo's first seed (ours; the deck's record has seed 1)


def monte_carlo(simulate, estimate, data, runs):
    """The deck's experiment flown `runs` times with new noise: case 1's
    model (its noise variances) as the truth, case 2's model and options as
    the fit, on case 2's record's time and input."""
    truth = simulate.model.with_free(estimate.model.free, estimate.model.names)
    mc = mlid.monte_carlo(truth, estimate.model, data.t, data.u, runs=runs, seed=SEED,
                          progress=False, **estimate.options())
    ok = mc["status"] == 0
    est, sig = mc["estimates"][ok], mc["sigma"][ok]
    n = len(est)
    ratio = est.std(axis=0, ddof=1) / sig.mean(axis=0)
    bias = (est.mean(axis=0) - mc["truth"]) / (est.std(axis=0, ddof=1) / np.sqrt(n))
    print(f"\nMonte Carlo, {runs} runs (seeds {SEED} to {SEED + runs - 1}), {n} converged")
    print(f"{'':<34}" + "".join(f"{m:>10}" for m in mc["names"]))
    print(f"{'sample sigma / mean CR sigma':<34}" + "".join(f"{v:10.3f}" for v in ratio)
          + f"   (standard error of a sample sigma {1 / np.sqrt(2 * (n - 1)):.1%})")
    print(f"{'(mean - truth) / standard error':<34}" + "".join(f"{v:10.2f}" for v in bias))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=0, help="Monte Carlo runs (default: none)")
    args = p.parse_args(argv)
    runs = mlid.run_deck(DECK)
    failed = [(case.where(), error) for case, _, _, error in runs if error is not None]
    if failed:
        print(f"c8: {failed}", file=sys.stderr)
        return 1
    (simulate, sim, _, _), (estimate, _, res, _) = runs
    truth, z = res.against_truth(simulate.model)     # case 1's model: report §8.2.1
    print(f"{estimate.title}: {res.iterations} iterations, converged={res.converged}")
    print(f"{'parameter':<10}{'truth (§8.2.1)':>16}{'start (deck)':>14}{'estimate':>11}"
          f"{'sigma (CR)':>12}{'(est - truth)/sigma':>21}{'start: sigma away':>19}")
    start_z = (res.start - truth) / res.sigma
    for k, name in enumerate(res.names):
        print(f"{name:<10}{truth[k]:16.5g}{res.start[k]:14.5g}{res.estimate[k]:11.4f}"
              f"{res.sigma[k]:12.4f}{z[k]:21.2f}{start_z[k]:19.1f}")
    print(f"largest |estimate - truth|/sigma {np.max(np.abs(z)):.2f}; the start up to "
          f"{np.max(np.abs(start_z)):.1f} sigma away")
    # case 1's noise variances (&simulate noise_std squared)
    ratio = np.diag(res.rhat) / np.asarray(simulate.model.r)
    n = sim["samples"]
    print("R-hat / simulated noise variance (u, theta, q, alpha): "
          + " ".join(f"{r:.3f}" for r in ratio)
          + f"; a variance from {n} samples has standard error {np.sqrt(2 / n):.1%}")
    if args.runs:
        monte_carlo(simulate, estimate, estimate.record(), args.runs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
