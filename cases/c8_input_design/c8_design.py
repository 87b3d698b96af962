"""Optimal inputs for the C-8 short period (NASA CR-2200 §7.4, §8.1, §8.3).

The first-order example of §7.4.1 by the three solvers against its closed
form; the C-8 two-state design against the report's and the recomputed
numbers of CASES.md §1; the weighted-trace design; the 10%-changed model;
then what the report left out: standard flight-test inputs of equal energy
and equal peak, an amplitude-limited square wave, a state limit, a servo
between command and surface, and gusts.

    python c8_design.py [--plots DIR]

Every number and where it comes from: README.md in this folder.
"""

import argparse
import sys
import time

import numpy as np

import mlid

# CASES.md §1 (report §8.1): states (q, alpha), elevator input, H = I
F = np.array([[-1.588, -0.562], [1.0, -0.737]])
G = np.array([[-1.66], [0.005]])
R = np.diag([0.02, 0.04])                       # spectral density of the measurement noise
UNKNOWNS = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "g(2,1)"]
NAMES = ["M_q", "M_alpha", "Z_alpha", "M_delta", "Z_delta"]
F_CHANGED = np.array([[-1.429, -0.613], [1.0, -0.663]])   # ~10% off (CASES.md §1)
T_LONG, E_LONG = 4.0, 311.0                     # §8.1
T_SHORT, E_SHORT = 0.77, 62.61                  # §8.1
ALPHA_LIMIT = 10.0                              # |alpha| <= 10 deg (§7.6), ours to apply
SERVO_TAU = 0.2                                 # first-order servo (§8.3)
CELLS = 200


def design(F_=F, weights=None, process_noise=None):
    return mlid.InputDesign(F_, G, np.eye(2), R, UNKNOWNS, weights, process_noise)


def first_order_example(T=1.0):
    """§7.4.1: x' = -x + theta u, y = x, r = 1: the closed form and the three solvers."""
    d = mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[1.0]], ["g(1,1)"])
    lo, hi = np.pi / (2 * T) + 1e-12, np.pi / T
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.tan(mid * T) + mid < 0 else (lo, mid)
    omega = 0.5 * (lo + hi)
    mu = 1.0 / (1.0 + omega**2)
    out = {"omega": omega, "mu closed form": mu, "mu operator": d.mu_max(T),
           "mu Riccati (eq. 7.89)": d.mu_max(T, method="riccati"),
           "T Riccati": d.critical_length(mu, "riccati"),
           "T transition": d.critical_length(mu, "transition")[0]}
    for TT in (1.0, 10.0):
        opt = d.optimal_input(TT, 1.0)
        out[f"optimal/doublet at T = {TT:g}"] = float(opt.M[0, 0] / d.information(
            TT, standard_input("doublet", TT, len(opt.u), energy=1.0))[0, 0])
    return out


def process_noise_example(T, q=3.0, r=1.0):
    """§7.5.1: x' = -x + theta u + eta (variance q, ours), y = x + noise (r):
    the steady-state gain k moves the sensitivity pole to -(1 + k), so
    mu = 1/(r (omega^2 + (1+k)^2)) with tan(omega T) = -omega/(1+k)."""
    d = mlid.InputDesign([[-1.0]], [[1.0]], [[1.0]], [[r]], ["g(1,1)"], process_noise=[[q]])
    a = np.sqrt(1.0 + q / r)                  # 1 + k: Sigma/r from -2 Sigma + q - Sigma^2/r = 0
    lo, hi = np.pi / (2 * T) + 1e-12, np.pi / T
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.tan(mid * T) + mid / a < 0 else (lo, mid)
    omega = 0.5 * (lo + hi)
    closed, ours = 1.0 / (r * (omega**2 + a**2)), d.mu_max(T)
    return q, closed, ours


def standard_input(kind, T, n, energy=None, peak=None):
    """The standard flight-test inputs on n equal cells of [0, T], scaled to
    an energy or a peak: doublet, 3-2-1-1, multistep (a 2-1-1 pattern of
    alternating steps, twice, unit T/8), Schroeder-phased multisine (8
    harmonics of 1/T), PRBS (31-bit maximal-length sequence)."""
    t = (np.arange(n) + 0.5) * T / n
    if kind == "doublet":
        u = np.where(t < T / 2, 1.0, -1.0)
    elif kind == "3211":
        unit = T / 7
        u = np.select([t < 3 * unit, t < 5 * unit, t < 6 * unit], [1.0, -1.0, 1.0], -1.0)
    elif kind == "multistep":
        ends = np.cumsum([2, 1, 1, 2, 1, 1]) * T / 8
        u = np.array([(-1.0) ** np.searchsorted(ends, x, side="right") for x in t])
    elif kind == "multisine":
        k = np.arange(1, 9)
        phase = -np.pi * k * (k - 1) / len(k)              # Schroeder's phases
        u = np.cos(2 * np.pi * np.outer(t, k) / T + phase).sum(axis=1)
    elif kind == "prbs":
        reg, bits = [1, 0, 0, 0, 0], []
        for _ in range(31):                                 # x^5 + x^3 + 1
            bits.append(reg[-1])
            reg = [reg[4] ^ reg[2]] + reg[:-1]
        u = np.array([1.0 if bits[int(x / T * 31)] else -1.0 for x in t])
    else:
        raise ValueError(kind)
    if energy is not None:
        u = u * np.sqrt(energy / (np.sum(u**2) * T / n))
    if peak is not None:
        u = u * peak / np.max(np.abs(u))
    return u[:, None]


def states_of(u, T, F_=F):
    """q and alpha [deg] of the C-8 model under u held on cells."""
    n = len(u)
    t = np.arange(n + 1) * T / n
    m = mlid.LinearModel(F_, G, np.eye(2), input_hold="zoh", substeps=4)
    _, x = mlid.simulate(m, t, np.vstack([u, u[-1:]]))
    return t, x


def servo_design(T, energy):
    """§8.3: a first-order servo between the command and the surface; the
    design acts on the command, the unknowns stay the aircraft's."""
    Fs = np.zeros((3, 3))
    Fs[:2, :2] = F
    Fs[:2, 2] = G[:, 0]
    Fs[2, 2] = -1.0 / SERVO_TAU
    Gs = np.array([[0.0], [0.0], [1.0 / SERVO_TAU]])
    Hs = np.hstack([np.eye(2), np.zeros((2, 1))])
    d = mlid.InputDesign(Fs, Gs, Hs, R, ["f(1,1)", "f(1,2)", "f(2,2)", "f(1,3)", "f(2,3)"])
    return d, d.optimal_input(T, energy, CELLS)


def run(plots=None):
    out = {"first order": first_order_example(), "process noise": process_noise_example(1.0)}
    d = design()
    t0 = time.perf_counter()
    mu4 = d.mu_max(T_LONG)
    long = d.optimal_input(T_LONG, E_LONG, CELLS)
    out["design seconds"] = time.perf_counter() - t0
    out["mu(T=4)"] = mu4
    out["mu(T=4) Riccati"] = d.mu_max(T_LONG, method="riccati")
    out["long"] = long
    out["short"] = d.optimal_input(T_SHORT, E_SHORT, CELLS)
    # det M at T = 0.77 s converged in the cells, and by the transition-matrix input
    out["short cells"] = {n: d.optimal_input(T_SHORT, E_SHORT, n).summary["det"]
                          for n in (100, 400, 800)}
    out["short transition"] = d.optimal_input(T_SHORT, E_SHORT, CELLS,
                                              method="transition").summary["det"]
    out["weighted"], out["ratios"] = d.equalised(T_SHORT, E_SHORT, iterations=12)
    out["T changed"] = design(F_CHANGED).critical_length(mu4)
    out["T changed, transition"] = design(F_CHANGED).critical_length(mu4, "transition")[0]
    # the mu-T curve (Fig. 8.1), for the model and the changed one
    Ts = np.linspace(0.5, 6.0, 23)
    out["curve"] = (Ts, [d.mu_max(T, cells=60) for T in Ts],
                    [design(F_CHANGED).mu_max(T, cells=60) for T in Ts])
    # standard inputs, equal energy and equal peak
    peak = float(np.max(np.abs(long.u)))
    rows = [("optimal", long.u)]
    for kind in ("doublet", "3211", "multistep", "multisine", "prbs"):
        rows.append((f"{kind}, equal energy", standard_input(kind, T_LONG, 2 * CELLS, E_LONG)))
        rows.append((f"{kind}, equal peak", standard_input(kind, T_LONG, 2 * CELLS, peak=peak)))
    # the best square wave a pilot can fly: |u| <= the optimal's peak, pulses >= 0.2 s
    square = d.amplitude_limited(T_LONG, peak, 0.2)
    rows.append(("square wave, optimal's peak, 0.2 s pulses", square.u))
    # the same under the equalised weights of §7.8 (eq. 7.88) for T = 4 s, E = 311
    weights = d.equalised(T_LONG, E_LONG, iterations=12)[0].weights
    out["square, equalised"] = (square.u, design(weights=weights).amplitude_limited(
        T_LONG, peak, 0.2).u)
    out["table"] = [(name, u, mlid.design.input_design.summary(d.information(T_LONG, u)))
                    for name, u in rows]
    # state limit (§7.6): scale the energy so that |alpha| reaches the limit
    t, x = states_of(long.u, T_LONG)
    scale = ALPHA_LIMIT / np.max(np.abs(x[:, 1]))
    out["alpha limit"] = (float(np.max(np.abs(x[:, 1]))), float(E_LONG * scale**2))
    # servo (§8.3) against a command doublet of equal energy through it
    ds, servo = servo_design(T_LONG, E_LONG)
    dbl = standard_input("doublet", T_LONG, len(servo.u), E_LONG)
    out["servo"] = (servo, mlid.design.input_design.summary(ds.information(T_LONG, dbl)))
    # gusts (§7.5): process noise on both equations, Gamma Q Gamma' = 0.5 I
    out["gusts"] = design(process_noise=0.5 * np.eye(2)).mu_max(T_LONG)
    if plots:
        out["plots"] = make_plots(out, plots)
    return out


def make_plots(out, folder):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path
    Path(folder).mkdir(parents=True, exist_ok=True)
    paths = []
    Ts, mus, mus_c = out["curve"]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(Ts, 1 / np.array(mus), label="C-8 model")
    ax.plot(Ts, 1 / np.array(mus_c), "--", label="F changed ~10%")
    ax.set_xlabel("T [s]")
    ax.set_ylabel("1/mu_max")
    ax.set_title("Fig. 8.1: 1/mu_max against the interval length")
    ax.legend()
    paths.append(_save(fig, folder, "fig8_1_mu_T.png"))
    long = out["long"]
    t, x = states_of(long.u, T_LONG)
    fig, axes = plt.subplots(3, 1, figsize=(7, 6), sharex=True)
    axes[0].step(long.t_edges[:-1], long.u[:, 0], where="post")
    axes[0].set_ylabel("delta_e [deg]")
    axes[1].plot(t, x[:, 0])
    axes[1].set_ylabel("q [deg/s]")
    axes[2].plot(t, x[:, 1])
    axes[2].set_ylabel("alpha [deg]")
    axes[2].set_xlabel("t [s]")
    axes[0].set_title(f"Figs 8.2-8.3: optimal input, T = {T_LONG:g} s, E = {E_LONG:g}")
    paths.append(_save(fig, folder, "fig8_2_optimal_input.png"))
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, u, _ in out["table"][:3]:
        inp = mlid.DesignedInput(np.linspace(0, T_LONG, len(u) + 1), u, np.eye(1))
        w, spec = inp.spectrum()
        ax.plot(w, spec, label=name)
    ax.set_xlim(0, 20)
    ax.set_xlabel("omega [rad/s]")
    ax.set_ylabel("|U(omega)|")
    ax.set_title("Fig. 8.4: Fourier transform of the inputs")
    ax.legend(fontsize=8)
    paths.append(_save(fig, folder, "fig8_4_spectrum.png"))
    fig, ax = plt.subplots(figsize=(6, 4))
    for inp, label in ((out["short"], "unit weights"), (out["weighted"], "weighted trace")):
        ax.step(inp.t_edges[:-1], inp.u[:, 0], where="post", label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("delta_e [deg]")
    ax.set_title(f"Figs 8.7-8.8: T = {T_SHORT} s, E = {E_SHORT}")
    ax.legend()
    paths.append(_save(fig, folder, "fig8_7_short_inputs.png"))
    servo = out["servo"][0]
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.step(servo.t_edges[:-1], servo.u[:, 0], where="post", label="command (servo design)")
    ax.step(long.t_edges[:-1], long.u[:, 0], where="post", alpha=0.6, label="no servo")
    ax.set_xlabel("t [s]")
    ax.set_title("Fig. 8.9 style: optimal command through a 0.2 s servo")
    ax.legend()
    paths.append(_save(fig, folder, "fig8_9_servo.png"))
    return paths


def _save(fig, folder, name):
    """The figure written whole or not at all (mlid.files.atomic_savefig)."""
    import matplotlib.pyplot as plt
    from pathlib import Path

    from mlid.files import atomic_savefig
    fig.tight_layout()
    path = Path(folder) / name
    atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
    return path


def verdict(ours, report, approx=False, note=""):
    """'agrees' when every value is within 2% of the report's (10% for a
    value the report gives as approximate), 'close' within 5%, else
    'differs'; and a note."""
    worst = np.max(np.abs(np.atleast_1d(ours) / np.atleast_1d(report) - 1))
    v = ("agrees" if worst <= (0.1 if approx else 0.02) else "close" if worst <= 0.05
         else "differs")
    return f"{v} ({note})" if note else v


def report_rows(out):
    """(quantity, report, recomputed, mlid, verdict) of §7.4.1 and §8.1."""
    L, S, W = out["long"].summary, out["short"].summary, out["weighted"].summary
    fo = out["first order"]
    rec_det = "ours is converged in the cells; recomputed 7.46e3"
    return [
        ("first order, T = 1: omega", "2.028758 (CASES)", "2.028758", f"{fo['omega']:.6f}",
         verdict(fo["omega"], 2.028758)),
        ("  mu_max", "0.195471 (CASES)", "0.195471", f"{fo['mu operator']:.6f}",
         verdict(fo["mu operator"], 0.195471)),
        ("  optimal/doublet at T = 1, 10", "~4.2, 1.4 (CASES)", "4.2, 1.4",
         f"{fo['optimal/doublet at T = 1']:.2f}, {fo['optimal/doublet at T = 10']:.2f}",
         verdict([fo["optimal/doublet at T = 1"], fo["optimal/doublet at T = 10"]], [4.2, 1.4],
                 approx=True)),
        ("mu_max, T = 4 s", "1/mu ~ 0.015", "65.89", f"{out['mu(T=4)']:.3f} "
         f"(1/mu {1 / out['mu(T=4)']:.5f}; Riccati {out['mu(T=4) Riccati']:.3f})",
         verdict(1 / out["mu(T=4)"], 0.015, approx=True)),
        ("E = 311: tr M", "20,460", "20,492", f"{L['trace']:,.0f}",
         verdict(L["trace"], 20460, note="the report's check mu E: 20,200")),
        ("det M", "~1e15", "1.10e15", f"{L['det']:.3e}", verdict(L["det"], 1e15, approx=True)),
        ("sigma " + ", ".join(NAMES), "0.167 0.0639 0.035 0.095 0.025",
         "0.1625 0.0622 0.0348 0.0934 0.0247", " ".join(f"{s:.4f}" for s in L["sigma"]),
         verdict(L["sigma"], [0.167, 0.0639, 0.035, 0.095, 0.025])),
        ("eigenvalue spread of M", "~3 orders", "438", f"{L['spread']:.0f}",
         "agrees" if 100 < L["spread"] < 1000 else "differs"),
        ("T = 0.77, E = 62.61: tr M", "611", "612.7", f"{S['trace']:.1f}",
         verdict(S["trace"], 611)),
        ("  det M", "8.11e3", "7.46e3", f"{S['det']:.4g}", verdict(S["det"], 8110, note=rec_det)),
        ("  sigma M_q, M_alpha", "2.03 5.57", "2.05 5.65",
         f"{S['sigma'][0]:.3f} {S['sigma'][1]:.3f}", verdict(S["sigma"][:2], [2.03, 5.57])),
        ("weighted (12 it.): diag(WM) max/min", "1.14", "-> 1.00", f"{out['ratios'][-1]:.4f} "
         f"({len(out['ratios']) - 1} accepted updates)",
         verdict(out["ratios"][-1], 1.14, note="ours iterates to convergence")),
        ("  det M", "2.27e4", "2.30e4", f"{W['det']:.4g}", verdict(W["det"], 22700)),
        ("  sigma M_q, M_alpha", "1.56 4.04", "1.57 4.20",
         f"{W['sigma'][0]:.3f} {W['sigma'][1]:.3f}", verdict(W["sigma"][:2], [1.56, 4.04])),
        ("F changed ~10%: T for the same mu", "3.21", "3.15", f"{out['T changed']:.4f}",
         verdict(out["T changed"], 3.21, note="recomputed 3.15")),
    ]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--plots", metavar="DIR")
    args = p.parse_args(argv)
    try:
        out = run(args.plots)
    except mlid.MlidError as exc:
        print(f"c8_design: {exc}", file=sys.stderr)
        return 1
    fo = out["first order"]
    print(" First-order example (§7.4.1), T = 1, r = 1")
    for k, v in fo.items():
        print(f"  {k:<28} {v:.7f}")
    q, closed, ours = out["process noise"]
    print(f"  with process noise q = {q:g} (§7.5.1): mu {ours:.7f}, closed form {closed:.7f}, "
          f"relative difference {abs(ours / closed - 1):.1e}")
    print("\n C-8 two-state (§8.1); verdict against the report (README: the rule)")
    print(f"  {'quantity':<46}{'report':>32}{'recomputed':>37}{'mlid':>44}  verdict")
    for q, rep, rec, ours, v in report_rows(out):
        print(f"  {q:<46}{rep:>32}{rec:>37}{ours:>44}  {v}")
    print(f"  design time (mu and the T = 4 s input): {1e3 * out['design seconds']:.0f} ms")
    det = out["short"].summary["det"]
    print(f"  T = 0.77 s: det M relative to {CELLS} cells: " + ", ".join(
        f"{n} cells {v / det - 1:+.1e}" for n, v in out["short cells"].items())
          + f"; the transition-matrix input {out['short transition'] / det - 1:+.1e}")
    print(f"\n Inputs on T = {T_LONG:g} s (energy of the optimal input {E_LONG:g})")
    print(f"  {'input':<44}{'energy':>9}{'peak':>8}{'tr M':>11}{'det M':>11}{'trM trM^-1':>12}"
          f"{'max sigma/opt':>14}")
    opt_sigma = out["table"][0][2]["sigma"]
    for name, u, s in out["table"]:
        energy = float(np.sum(u**2) * T_LONG / len(u))
        print(f"  {name:<44}{energy:9.1f}{np.max(np.abs(u)):8.2f}{s['trace']:11.4g}"
              f"{s['det']:11.3e}{s['trace_product']:12.4g}{np.max(s['sigma'] / opt_sigma):14.2f}")
    peak_alpha, e_limit = out["alpha limit"]
    print(f"\n State limit (§7.6): the optimal input of energy {E_LONG:g} reaches |alpha| = "
          f"{peak_alpha:.2f} deg; energy {e_limit:.1f} holds |alpha| to {ALPHA_LIMIT:g} deg")
    servo, dbl = out["servo"]
    print(f" Servo tau = {SERVO_TAU} s (§8.3): optimal command tr M {servo.summary['trace']:.4g}, "
          f"det {servo.summary['det']:.3e}; command doublet of equal energy tr M "
          f"{dbl['trace']:.4g}, det {dbl['det']:.3e}")
    print(f" Gusts (§7.5, Gamma Q Gamma' = 0.5 I): mu_max(T = 4) falls from "
          f"{out['mu(T=4)']:.2f} to {out['gusts']:.2f}")
    print(f" F changed ~10%: T for the same mu, Riccati {out['T changed']:.7f}, transition "
          f"{out['T changed, transition']:.7f} (differ by "
          f"{abs(out['T changed'] / out['T changed, transition'] - 1):.1e} relative)")
    plain, weighted = out["square, equalised"]
    steps = lambda u: "a single step" if np.all(u == u[0]) else "several pulses"   # noqa: E731
    print(f" Amplitude-limited square wave, T = {T_LONG:g} s: unit weights {steps(plain)}, "
          f"equalised weights (§7.8) {steps(weighted)}; the same cells: "
          f"{'yes' if np.array_equal(plain, weighted) else 'no'}")
    for path in out.get("plots", []):
        print(f" plot: {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
