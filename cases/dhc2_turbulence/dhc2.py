"""A lateral record flown in turbulence, its outputs free of measurement noise
(like the textbook's DHC-2 filter-error example; the record and the numbers are
ours): process noise on the roll- and yaw-rate equations as standard deviations
of continuous white noise, 24 parameters, the steady-state filter.

    python dhc2.py [--record FILE]

Fits (README.md gives the numbers and their sources):
  1. exact ML with R free: no maximum, since the outputs carry no noise; the
     fit ends with one line that names them and the remedies;
  2. exact ML with a lower bound on R (R_FLOOR): from the start of the others
     the search stalls, not converged; from larger r (R_START_2B) it reaches
     the bounded problem's maximum, every r on its bound;
  3. exact ML with R fixed at a small floor (FIXED_R of each output's variance);
  4. the innovations criterion (noise_criterion = 'innovations').
3 and 4: the derivatives against the truth, the process noise against the
noise actually realised in the record.
"""

import argparse
import sys
import time
import warnings

import numpy as np

import mlid
from mlid.design.signals import input_signal

DT, T_END = 0.05, 30.0
SUB = 50                      # steps per sample in the truth simulation
SEED = 7

# the truth (ours): p, r [rad/s]; inputs aileron, rudder [rad], lateral velocity v [m/s]
F = np.array([[-5.0, 2.4], [-0.6, -1.1]])
G = np.array([[-9.0, 1.1, -0.12], [-0.35, -2.6, 0.045]])
AY = np.array([-0.3, 0.8, -0.05, 1.4, -0.18])          # a_y = Y_p p + Y_r r + Y_da da + Y_dr dr + Y_v v
BX = np.array([0.01, -0.005])                          # state-equation biases
BIAS = np.array([0.002, -0.001, 0.05, 0.003, -0.002])  # output biases: pdot, rdot, a_y, p, r
SIGMA = np.array([0.25, 0.09])                         # continuous turbulence, sd on pdot, rdot
R_FLOOR = 1e-8                                         # lower bound of every r (fit 2)
R_START_2B = 1e-2                                      # fit 2 again, r started at this of the variance
FIXED_R = 1e-6                                         # r fixed at this of each output's variance (fit 3)
OUTPUTS = ["pdot", "rdot", "ay", "p", "r"]

NAMES = {"f(1,1)": "L_p", "f(1,2)": "L_r", "f(2,1)": "N_p", "f(2,2)": "N_r",
         "g(1,1)": "L_da", "g(1,2)": "L_dr", "g(1,3)": "L_v",
         "g(2,1)": "N_da", "g(2,2)": "N_dr", "g(2,3)": "N_v",
         "h(3,1)": "Y_p", "h(3,2)": "Y_r", "d(3,1)": "Y_da", "d(3,2)": "Y_dr", "d(3,3)": "Y_v",
         "bx(1)": "b_pdot", "bx(2)": "b_rdot", "q(1)": "sigma_p", "q(2)": "sigma_r",
         **{f"bias({i})": f"bias_{o}" for i, o in enumerate(["pdot", "rdot", "ay", "p", "r"], 1)},
         **{f"r({i})": f"R_{o}" for i, o in enumerate(["pdot", "rdot", "ay", "p", "r"], 1)}}
# the pdot and rdot outputs are the state equations themselves
TIES = {"h(1,1)": "f(1,1)", "h(1,2)": "f(1,2)", "h(2,1)": "f(2,1)", "h(2,2)": "f(2,2)",
        **{f"d({i},{j})": f"g({i},{j})" for i in (1, 2) for j in (1, 2, 3)}}
FREE = [n for n in NAMES if not n.startswith("r(")]     # 24


def model(f, g, ay, bx, bias, sigma, r, free=FREE):
    H = np.vstack([f, np.eye(2)[:0], np.zeros((3, 2))])
    H[2] = ay[:2]
    H[3:] = np.eye(2)
    D = np.zeros((5, 3))
    D[:2] = g
    D[2] = ay[2:]
    return mlid.LinearModel(f, g, H, D, x0=[0.0, 0.0], bias=bias, bx=bx, Gamma=np.eye(2),
                            q=list(sigma), r=list(r), free=list(free), names=NAMES, ties=TIES)


def truth():
    return model(F, G, AY, BX, BIAS, SIGMA, [R_FLOOR] * 5)


def truth_by_label(realised):
    """The truth by parameter label; the process noise as realised."""
    v = {"f(1,1)": F[0, 0], "f(1,2)": F[0, 1], "f(2,1)": F[1, 0], "f(2,2)": F[1, 1],
         **{f"g({i},{j})": G[i - 1, j - 1] for i in (1, 2) for j in (1, 2, 3)},
         "h(3,1)": AY[0], "h(3,2)": AY[1], "d(3,1)": AY[2], "d(3,2)": AY[3], "d(3,3)": AY[4],
         "bx(1)": BX[0], "bx(2)": BX[1], "q(1)": realised[0], "q(2)": realised[1],
         **{f"bias({i})": BIAS[i - 1] for i in range(1, 6)}}
    return {NAMES[k]: x for k, x in v.items()}


def inputs(t):
    da = input_signal("3211", 0.08, 1.0, 0.5, DT, t.size)
    dr = input_signal("doublet", 0.06, 9.0, 1.0, DT, t.size)
    # the lateral velocity, measured and used as an input: a lightly damped
    # response to the rudder, as the Dutch roll gives it
    v, vd, om, ze = 0.0, 0.0, 1.8, 0.15
    out = np.zeros_like(t)
    h = DT / SUB
    for j in range(t.size):
        out[j] = v
        for _ in range(SUB):
            vd += h * (-2 * ze * om * vd - om**2 * v - 40.0 * dr[j])
            v += h * vd
    return np.column_stack([da, dr, out])


def rk4(x, ua, ub, h):
    def f(x, u):
        return F @ x + G @ u + BX
    um = 0.5 * (ua + ub)
    k1 = f(x, ua)
    k2 = f(x + 0.5 * h * k1, um)
    k3 = f(x + 0.5 * h * k2, um)
    k4 = f(x + h * k3, ub)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def record():
    """The truth simulated with continuous white noise on pdot and rdot
    (SUB steps a sample: a Runge-Kutta step of the deterministic part plus the
    noise's increment, inputs linear between samples), the
    outputs sampled without noise; and the turbulence's realised sd."""
    rng = np.random.default_rng(SEED)
    t = np.arange(0.0, T_END + DT / 2, DT)
    u = inputs(t)
    h = DT / SUB
    x = np.zeros(2)
    xs = np.zeros((t.size, 2))
    sq = np.zeros(2)
    for j in range(t.size):
        xs[j] = x
        if j + 1 == t.size:
            break
        for k in range(SUB):
            ua, ub = (u[j] + (k + e) / SUB * (u[j + 1] - u[j]) for e in (0.0, 1.0))
            dw = rng.standard_normal(2) * np.sqrt(h) * SIGMA
            sq += dw**2
            x = rk4(x, ua, ub, h) + dw
    m = truth()
    y = xs @ m.H.T + u @ m.D.T + BIAS
    y[:, :2] += BX                          # pdot, rdot: the state equations, bias included
    realised = np.sqrt(sq / t[-1])
    data = mlid.FlightData(t, u, y, input_names=["delta_a", "delta_r", "v"],
                           output_names=["pdot", "rdot", "a_y", "p", "r"],
                           input_units=["rad", "rad", "m/s"],
                           output_units=["rad/s2", "rad/s2", "m/s2", "rad/s", "rad/s"])
    return data, realised


def start():
    """The truth 30% off, alternately up and down (ours); r at 1e-4 of each
    output's variance, process noise sd at 0.1."""
    k = np.array([1.3, 0.7])
    f = F * np.resize(k, 4).reshape(2, 2)
    g = G * np.resize(k[::-1], 6).reshape(2, 3)
    return f, g, AY * np.resize(k, 5), BX * 0.0, BIAS * 0.0, np.array([0.1, 0.1])


def fit(data, r_free=False, bounds=None, r_scale=1e-4, **opts):
    """From start(); r at r_scale of each output's variance (free or fixed)."""
    f, g, ay, bx, bias, sigma = start()
    r0 = r_scale * np.var(data.y, axis=0)
    free = FREE + ([f"r({i})" for i in range(1, 6)] if r_free else [])
    m = model(f, g, ay, bx, bias, sigma, r0, free)
    return mlid.fit(m, data, method="filter_error", steady_state=True,
                    process_noise="continuous_sd", max_iter=50, bounds=bounds, **opts)


def timed(*args, **kw):
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        res = fit(*args, **kw)
        wall = time.perf_counter() - t0
    return res, wall, [str(w.message) for w in said]


def bounded(res):
    """Where a fit with every r bounded below by R_FLOOR ends (after its
    iterations, converged and time)."""
    est = dict(zip(res.names, res.estimate))
    on_bound = sum(est[f"R_{o}"] <= R_FLOOR * 1.0001 for o in OUTPUTS)
    return (f"cost {res.cost:.1f}; L_p {est['L_p']:.3f} (truth {F[0, 0]}), "
            f"sigma_p {est['sigma_p']:.3f}, r at the bound: {on_bound} of 5")


def table(fits, tv):
    """Estimate, sigma and error/sigma of each fit against the truth (the
    process noise against the noise realised in the record)."""
    head = "".join(f" | {k:>26s}" for k in fits)
    print(f"   {'parameter':10s} {'truth':>9s}{head}")
    worst = {k: 0.0 for k in fits}
    first = next(iter(fits.values()))
    for i, n in enumerate(first.names):
        row = f"   {n:10s} {tv[n]:9.4f}"
        for k, r in fits.items():
            z = (r.estimate[i] - tv[n]) / r.sigma[i]
            worst[k] = max(worst[k], abs(z))
            row += f" | {r.estimate[i]:9.4f} {r.sigma[i]:8.4f} {z:7.2f}"
        print(row)
    print("   largest |error|/sigma: " + ", ".join(f"{k} {v:.2f}" for k, v in worst.items()))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--record", help="also write the generated record here")
    args = ap.parse_args(argv)
    data, realised = record()
    if args.record:
        data.save(args.record)
    print(f"record: {data.nt} samples at {DT} s; turbulence sd realised "
          f"{realised[0]:.4f}, {realised[1]:.4f} (truth {SIGMA[0]}, {SIGMA[1]}; ours)")

    print("\n1. exact ML, R free (29 parameters):")
    r1, wall, _ = timed(data, r_free=True)
    print(f"   {r1.iterations} iterations, converged: {r1.converged}, {wall:.2f} s")
    print(f"   {r1.message}")

    print(f"\n2. exact ML, every r bounded below by {R_FLOOR:g}:")
    lower = {f"r({i})": (R_FLOOR, None) for i in range(1, 6)}
    r2, wall, _ = timed(data, r_free=True, bounds=lower)
    print(f"   {r2.iterations} iterations, converged: {r2.converged}, {wall:.2f} s; {bounded(r2)}")
    print(f"   {r2.message}")
    r2b, wall, _ = timed(data, r_free=True, bounds=lower, r_scale=R_START_2B)
    print(f"   the same bounds, r started at {R_START_2B:g} of each output's variance: "
          f"{r2b.iterations} iterations, converged: {r2b.converged}, {wall:.2f} s; {bounded(r2b)}")

    print(f"\n3. exact ML, every r fixed at {FIXED_R:g} of its output's variance "
          f"(24 parameters):")
    r3, wall3, _ = timed(data, r_scale=FIXED_R)
    print(f"   {r3.iterations} iterations, converged: {r3.converged}, {wall3:.2f} s")

    print("\n4. innovations criterion (24 parameters; R after each step from the innovations):")
    r4, wall4, said = timed(data, noise_criterion="innovations")
    print(f"   {r4.iterations} iterations, converged: {r4.converged}, {wall4:.2f} s")
    for s in said:
        print(f"   warning: {s}")
    print("   R from the innovations / mean squared innovation: " +
          ", ".join(f"{o} {r:.2e}/{b:.2e}" for o, r, b in
                    zip(OUTPUTS, r4.r_innovations, np.diag(r4.rhat))))

    print("\n   estimate, sigma, error/sigma against the truth (sigma_p, sigma_r: the realised):")
    table({"3. exact, r fixed": r3, "4. innovations": r4}, truth_by_label(realised))
    return r4


if __name__ == "__main__":
    sys.exit(0 if main() is not None else 1)
