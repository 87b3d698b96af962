"""Issue 47 items 1 and 3 rates on held-out seeds (not the ones the rule was
tuned on), the records of tests/test_diagnose_colour.py:

- lateral AR(1) nulls, phi 0.3 / 0.6 / 0.8, seeds 11-40: clean = no effect
  accepted (naming coloured measurement noise is clean);
- longitudinal AR(1) nulls, phi 0.6 / 0.8, seeds 1-20;
- the gust record (tests/scenarios.py), seeds 1-20: the gust alone named;
- outside the library, seeds 1-10: a backlash and a dead-zone on the aileron
  sweep (any effect named is a false claim), a 2.7 Hz mode on q plus a
  q bias of 5 sd (the bias named, the peak not explained).

    python benchmarks/diagnose_colour_rates.py
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import mlid  # noqa: E402
import scenarios  # noqa: E402
import test_diagnose_colour as T  # noqa: E402


def rate(label, make, seeds, ok):
    hits = sum(bool(ok(mlid.diagnose(*make(s)))) for s in seeds)
    print(f"{label:<44} {hits:>3}/{len(seeds)}  (seeds {seeds[0]}-{seeds[-1]})", flush=True)


def mode_and_bias(seed):
    model, data = T.structural_mode(seed)
    y = data.y.copy()
    y[:, 2] += 5 * scenarios.LON_NOISE[2]
    return model, mlid.FlightData(data.t, data.u, y, data.input_names, data.output_names)


def main():
    held = list(range(11, 41))
    for phi in (0.3, 0.6, 0.8):
        rate(f"lateral AR(1) null phi {phi}: clean", lambda s, p=phi: T.ar1_null(s, p), held,
             lambda d: not d.effects)
    for phi in (0.6, 0.8):
        rate(f"longitudinal AR(1) null phi {phi}: clean",
             lambda s, p=phi: T.longitudinal_ar1_null(s, p), list(range(1, 21)),
             lambda d: not d.effects)
    rate("gust: the gust alone named", lambda s: scenarios.make("gust", s),
         list(range(1, 21)), lambda d: [e.family for e in d.effects] == ["process noise"])
    ten = list(range(1, 11))
    rate("backlash (sweep): nothing named", T.backlash, ten, lambda d: not d.effects)
    rate("dead-zone (sweep): nothing named", T.dead_zone, ten, lambda d: not d.effects)
    rate("2.7 Hz mode + q bias: bias named, peak said", mode_and_bias, ten[:5],
         lambda d: [e.name for e in d.effects] == ["bias on q"]
         and any(s.kind == "spectral peak" for s in d.unexplained))


if __name__ == "__main__":
    main()
