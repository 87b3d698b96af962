"""M2/F3 with gusts and a stability augmentation system: the remedies of
report §4.6 under filter error (§5.3.4-5.3.6, Table 5.4).

The report's diagnosis (§5.3.6): the SAS provides all the sudden surface
movement, so the rate derivatives and the control derivatives that the
dampers couple are nearly confounded.  This variant of the gust case flies
the record closed loop (roll damper on the aileron, yaw damper on the
rudder) with weak pilot inputs and fits the derivatives by filter error
with the gust model held at its truth; then each remedy side by side, as
cases/hl10_lateral does for output error.

    python remedies.py

Every number and where it comes from: README.md in this folder.
"""

import sys

import numpy as np

import m2f3
import mlid
from mlid.design.signals import input_signal

K_ROLL, K_YAW = -0.3, 1.0         # deg surface per deg/s of p and of r, both damping (ours)
KEY = ["L_p", "N_p", "L_r", "N_r", "L_da", "N_da", "L_dr", "N_dr"]   # the damper-coupled eight


def record():
    """Closed loop: each surface is the pilot's input plus its damper's
    feedback; the record holds the surface positions, as flight data would."""
    m = m2f3.model(m2f3.WT)
    k = np.zeros((2, 5))
    k[0, 0], k[1, 1] = K_ROLL, K_YAW
    closed = mlid.LinearModel(m.F + m.G @ k, m.G, m.H + m.D @ k, m.D, Gamma=m.Gamma, q=m.q,
                              r=m.r)
    t = np.arange(m2f3.NT) * m2f3.DT
    pilot = np.column_stack([input_signal("3211", 0.5, 0.5, 0.4, m2f3.DT, m2f3.NT),
                             input_signal("doublet", 0.1, 4.0, 0.5, m2f3.DT, m2f3.NT)])
    sim, x = mlid.simulate(closed, t, pilot, seed=m2f3.SEED)
    return mlid.FlightData(t, pilot + x @ k.T, sim.y, ["delta_a", "delta_r"],
                           ["p", "r", "beta", "phi", "a_y'"])


def fits(data):
    derivs = list(m2f3.ELEMENT.values())
    start = m2f3.start_values()

    def model(free):
        return m2f3.model(start, free=[m2f3.ELEMENT[n] for n in free])

    allfree = list(m2f3.ELEMENT)
    fe = {"method": "filter_error"}
    out = {"unconstrained": mlid.fit(model(allfree), data, **fe)}
    weights = {n: 1.0 / (0.3 * start[n]) ** 2 for n in KEY}          # 30% a priori sigma
    out["a priori"] = mlid.fit(model(allfree), data, prior_weight=weights, **fe)
    out["fixed L_dr, N_dr"] = mlid.fit(model([n for n in allfree if n not in ("L_dr", "N_dr")]),
                                       data, **fe)
    # three eigenvalues dropped at least, as the report's M2/F3 solution (§5.3.6)
    out["rank-def., staged"] = mlid.fit(model(allfree), data, rank_min=len(derivs) - 3,
                                        rank_rule="staged", **fe)
    signs = {n: (0.0, None) if m2f3.WT[n] > 0 else (None, 0.0) for n in ("L_r", "N_r", "L_dr", "N_dr")}
    out["bounds (signs)"] = mlid.fit(model(allfree), data, bounds=signs, **fe)
    return out


def summary(name, res):
    est = {n: res.estimate[res.names.index(n)] for n in res.names}
    wrong = [n for n, e in est.items() if np.sign(e) * np.sign(m2f3.WT[n]) < 0]   # 0: on a bound
    start = m2f3.start_values()
    dist = np.sqrt(np.mean([((est.get(n, start[n]) - m2f3.WT[n]) / m2f3.WT[n]) ** 2
                            for n in KEY]))
    return {"name": name, "est": est, "wrong": wrong, "cost": res.cost,
            "rms_fit": float(np.sqrt(np.mean((res.residuals / np.std(res.data.y, axis=0)) ** 2))),
            "dist": float(dist), "rank": res.rank, "k": len(res.names)}


def main():
    try:
        rows = [summary(n, r) for n, r in fits(record()).items()]
    except mlid.MlidError as exc:
        print(f"remedies: {exc}", file=sys.stderr)
        return 1
    print(" M2/F3 with gusts and SAS, filter error: the damper-coupled derivatives under each remedy")
    print(f" {'':<18}" + "".join(f"{n:>9}" for n in KEY)
          + f"{'wrong':>7}{'-J':>9}{'fit rms':>9}{'dist':>7}{'rank':>7}")
    print(f" {'truth':<18}" + "".join(f"{m2f3.WT[n]:9.3f}" for n in KEY))
    for r in rows:
        cells = "".join(f"{r['est'][n]:9.3f}" if n in r["est"] else f"{'fixed':>9}" for n in KEY)
        print(f" {r['name']:<18}{cells}{len(r['wrong']):7d}{-r['cost']:9.1f}{r['rms_fit']:9.4f}"
              f"{r['dist']:7.2f}{r['rank']:4d}/{r['k']}")
    print(" wrong: signs opposite the truth; fit rms: innovation rms over output rms; "
          "dist: rms relative error of the eight")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
