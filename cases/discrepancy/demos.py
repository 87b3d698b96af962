"""The discrepancy workflow on the project's own records (issue 7):

  1. M2/F3 with the gust hidden: the record of cases/m2f3_gusts analysed by
     output error with a model that has no gust.
  2. HL-10 with Y_p and Y_r hidden: the record of cases/hl10_lateral analysed
     with the side-force derivatives Y_p, Y_r set to zero.
  3. The real HFB-320 record: what the reference model misses that holds on
     the held-out last third of the record.

    python demos.py [--plots DIR]

Every number and where it comes from: README.md in this folder.
"""

import argparse
import math
import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.discrepancy import effects

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "m2f3_gusts"))
sys.path.insert(0, str(HERE.parent / "hl10_lateral"))
import hl10  # noqa: E402
import m2f3  # noqa: E402

HFB_DECK = HERE.parent / "hfb320" / "hfb320.nml"


def m2f3_demo():
    data, _ = m2f3.record()
    model = m2f3.model(m2f3.start_values(), free=list(m2f3.ELEMENT.values()), gust=False)
    # the analysis model: the four aircraft states only, no gust state
    four = mlid.LinearModel(model.F[:4, :4], model.G[:4], model.H[:, :4], model.D,
                            r=np.square(m2f3.NOISE_STD), free=list(model.free),
                            names={e: n for n, e in m2f3.ELEMENT.items()},
                            ties={k: v for k, v in model.ties.items() if not k.endswith(",5)")})
    return mlid.diagnose(four, data, families=("bias", "derivative", "noise", "delay", "lag"))


def hl10_demo():
    data = hl10.record()
    wt = dict(hl10.wind_tunnel(), Y_p=0.0, Y_r=0.0)          # Y_p and Y_r hidden
    F, G, H, D = hl10.matrices(wt)
    model = mlid.LinearModel(F, G, H, D, free=[hl10.ELEMENT[n] for n in hl10.ELEMENT],
                             names={e: n for n, e in hl10.ELEMENT.items()} | {
                                 "f(3,1)": "Y_p (f)", "f(3,2)": "Y_r (f)", "h(5,1)": "Y_p (a_y)",
                                 "h(5,2)": "Y_r (a_y)"}, ties=hl10.TIES)
    return mlid.diagnose(model, data, families=("bias", "derivative", "noise"))


def hfb_demo():
    """The real HFB-320 record, every family its model kind takes, the
    held-out verdicts built in (mlid.discrepancy.holdout: the last third)."""
    case = mlid.read_deck(HFB_DECK)[0]
    return mlid.diagnose(case.model, case.record())


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--plots", metavar="DIR")
    args = p.parse_args(argv)
    try:
        print(" 1. M2/F3, the gust hidden")
        d = m2f3_demo()
        print(d.report())
        rms = math.sqrt(effects.gust_variance(m2f3.TAU, m2f3.DT)[0] * m2f3.Q_GUST)
        print(f"  truth (cases/m2f3_gusts, ours): gust time constant {m2f3.TAU} s, gust "
              f"standard deviation {rms:.4g} deg (mlid.discrepancy.effects.gust_variance, q = "
              f"{m2f3.Q_GUST})")
        if args.plots:
            print(f" plot: {d.plot(Path(args.plots) / 'm2f3')}")
        print("\n 2. HL-10, Y_p and Y_r hidden")
        d = hl10_demo()
        print(d.report())
        if args.plots:
            print(f" plot: {d.plot(Path(args.plots) / 'hl10')}")
        if HFB_DECK.is_file() and (HERE.parents[2] / "shared" / "data" / "hfb320_1_10.asc").is_file():
            print("\n 3. HFB-320, real record (the last third held out)")
            d = hfb_demo()
            print(d.report())
            if args.plots:
                print(f" plot: {d.plot(Path(args.plots) / 'hfb320')}")
        else:
            print("\n 3. HFB-320: the real record is not at ../shared/data; skipped")
    except mlid.MlidError as exc:
        print(f"demos: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
