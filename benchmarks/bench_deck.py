"""Speed of reading decks and setting cases up through the core's one reader.

- decks/s: every deck under cases/ read by mlid.read_deck (the Fortran
  reader, then each case spec turned into a model and options), median of 20
  passes over all of them;
- the cost of one case set-up against the fit it prepares: the HFB-320 case
  (deck read, model, options, the real 601-sample record read through the
  core's record reader) beside the fit itself, in one run;
- the record alone: FlightData.load (the core's reader) beside numpy.loadtxt
  on the same file, side by side.
"""

from pathlib import Path

import numpy as np

import mlid
from timing import median

REPO = Path(__file__).resolve().parent.parent
DECKS = sorted(p for p in (REPO / "cases").glob("*/*.nml"))
HFB = REPO / "cases" / "hfb320" / "hfb320.nml"
HFB_DATA = REPO.parent / "shared" / "data" / "hfb320_1_10.asc"


def main():
    ncases = sum(len(mlid.read_deck(d)) for d in DECKS)
    t = median(lambda: [mlid.read_deck(d) for d in DECKS], 20)
    print(f"{len(DECKS)} decks ({ncases} cases) read in {t * 1e3:.2f} ms: "
          f"{len(DECKS) / t:,.0f} decks/s, {t / ncases * 1e6:.0f} us per case")
    if not HFB_DATA.is_file():
        print(f"skipped the HFB-320 set-up: real flight data not found at {HFB_DATA}")
        return

    def setup():
        case = mlid.read_deck(HFB)[0]
        return case, case.record(), case.options()

    case, data, opts = setup()
    t_setup = median(setup, 20)
    t_fit = median(lambda: mlid.fit(case.model, data, **opts), 10)
    print(f"HFB-320 case set-up (deck, model, options, record): {t_setup * 1e3:.2f} ms; "
          f"its fit {t_fit * 1e3:.1f} ms; set-up / fit = {t_setup / t_fit:.3f}")
    cols = dict(time_col=1, input_cols=[2, 4], output_cols=[5, 6, 7, 8, 9, 10, 11])
    t_core = median(lambda: mlid.FlightData.load(HFB_DATA, **cols), 20)
    t_np = median(lambda: np.loadtxt(HFB_DATA, comments="#", ndmin=2), 20)
    print(f"record {HFB_DATA.name} ({data.nt} rows): core reader {t_core * 1e3:.2f} ms, "
          f"numpy.loadtxt {t_np * 1e3:.2f} ms, ratio {t_core / t_np:.2f}")


if __name__ == "__main__":
    main()
