"""A user's own model, the worked example: the deck cubic_short_period.nml
run through the Python front end (case 1 simulates the large doublet from
the deck's values, case 2 fits all six parameters from values 30% off) and
every number README.md quotes: the iterations, and truth, start, estimate,
Cramer-Rao sigma and (estimate - truth)/sigma of each parameter.

Needs the example compiled in (fortran/models/mlid_user_model.f90, kind = 'user').

    python user_model.py        (here; writes cubic_doublet.dat beside the deck)

Every number and where it comes from: README.md in this folder.
"""

import sys
from pathlib import Path

import numpy as np

import mlid

DECK = Path(__file__).with_name("cubic_short_period.nml")


def main():
    runs = mlid.run_deck(DECK)
    failed = [(case.where(), error) for case, _, _, error in runs if error is not None]
    if failed:
        print(f"user_model: {failed}", file=sys.stderr)
        return 1
    (simulate, _, _, _), (estimate, _, res, _) = runs
    truth, z = res.against_truth(simulate.model)     # case 1's model: the deck's values
    print(f"{estimate.title}: {res.iterations} iterations, converged={res.converged}")
    print(f"{'parameter':<10}{'truth':>10}{'start':>10}{'estimate':>14}{'sigma (CR)':>14}"
          f"{'(est - truth)/sigma':>21}")
    for k, name in enumerate(res.names):
        print(f"{name:<10}{truth[k]:10.5g}{res.start[k]:10.5g}{res.estimate[k]:14.7g}"
              f"{res.sigma[k]:14.5g}{z[k]:21.2f}")
    worst = int(np.argmax(np.abs(z)))
    print(f"largest |estimate - truth|/sigma {abs(z[worst]):.2f} ({res.names[worst]})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
