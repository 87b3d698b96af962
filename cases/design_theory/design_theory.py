"""The report's input-design theory against mlid's numerical design (NASA
CR-2200 §7.4.2, §7.4.3, §7.6):

1. Levadi's example (§7.4.2): coloured measurement noise, the closed form
   against mlid.InputDesign, the noise a state with process noise (§7.5) and
   a vanishing white measurement noise r;
2. the second-order example (§7.4.3): the closed form (two frequencies
   bracketing the natural frequency) against the operator, Riccati and
   transition-matrix solvers;
3. the state-limit penalty of §7.6 on the C-8 short period, against the
   energy rescaling of §8.1 at the same angle-of-attack limit.

    python design_theory.py

Every number and where it comes from: README.md in this folder.
"""

import sys

import numpy as np

import mlid
from mlid.design import closed_forms as cf

# 1. Levadi (§7.4.2): x' = -x + b u, y = x + v, E{v v} = c exp(-a|tau|); ours: a, c, T
A_WIDE, A_NARROW, C_NOISE, T_LEVADI = 3.0, 0.5, 1.0, 2.0
R_WHITE = (1e-4, 1e-6)          # the white measurement noise of the Kalman route, -> 0
R_NARROW = (1e-4, 1e-6, 1e-8)
LEVADI_CELLS = 400

# 2. §7.4.3 with the C-8 short period (§8.1) in the form of eq. 7.69
F_C8 = np.array([[-1.588, -0.562], [1.0, -0.737]])
G_C8 = np.array([[-1.66], [0.005]])
A1, A2 = float(np.trace(F_C8)), float(-np.linalg.det(F_C8))     # s^2 - a1 s - a2
R_Q = 0.02                      # q's noise spectral density (§8.1)
T_SECOND = (1.0, 4.0, 8.0)
CELLS = (50, 100, 200)

# 3. §7.6 on the C-8 short period (§8.1, CASES.md §1)
R_C8 = np.diag([0.02, 0.04])
UNKNOWNS = ["f(1,1)", "f(1,2)", "f(2,2)", "g(1,1)", "g(2,1)"]
T_C8, E_C8 = 4.0, 311.0
ALPHA_LIMIT = 5.0               # |alpha| <= 5 deg: ours, tighter than the free design's 9.5
PENALTIES = (0.0, 30.0, 60.0, 80.0, 100.0, 150.0, 300.0)   # on int alpha^2 dt, ours


def levadi_design(a, r):
    """The coloured noise v as a state driven by white noise of density
    2ac (eq. 7.59), y = x + v + n with E{n n} = r delta: the design of §7.5
    (steady-state Kalman filter) whitens y as Levadi's derivative does."""
    return mlid.InputDesign([[-1.0, 0.0], [0.0, -a]], [[1.0], [0.0]], [[1.0, 1.0]], [[r]],
                            ["g(1,1)"], process_noise=np.diag([0.0, 2 * a * C_NOISE]))


def dominant_frequency(inp):
    """pi times the input's sign changes per second."""
    u = inp.u[:, 0]
    return np.pi * np.count_nonzero(np.sign(u[1:]) != np.sign(u[:-1])) / inp.t_edges[-1]


def levadi():
    """§7.4.2 for wide-band (a = 3) and narrow-band (a = 0.5) noise."""
    T, a, c = T_LEVADI, A_WIDE, C_NOISE
    ours, printed = cf.levadi(a, c, T), cf.levadi(a, c, T, printed=True)
    out = {"closed": ours, "printed": printed, "mu": {}, "shape": {}}
    for r in R_WHITE:
        inp = levadi_design(a, r).optimal_input(T, 1.0, cells=LEVADI_CELLS)
        k = np.sqrt(2 * a * c / r)                     # the filter's gain: 1/K boundary layers
        ref = ours.input(inp.t)
        inner = (inp.t > 10 / k) & (inp.t < T - 10 / k)
        out["mu"][r] = inp.mu
        out["shape"][r] = (np.max(np.abs(inp.u[inner, 0] - ref[inner])) / np.max(ref),
                           np.linalg.norm(inp.u[:, 0] - ref) / np.linalg.norm(ref))
        out["info of the closed-form input", r] = levadi_design(a, r).information(T, ref)[0, 0]
    r1, r2 = R_WHITE                                   # error O(sqrt r): extrapolate
    q = np.sqrt(r1 / r2)
    out["mu extrapolated"] = (q * out["mu"][r2] - out["mu"][r1]) / (q - 1)
    out["limit a -> inf"] = (cf.levadi(1e4, 0.5e4, 1.0).omega[0], cf.first_order(1.0).omega[0])
    out["narrow"] = []
    for r in R_NARROW:
        inp = levadi_design(A_NARROW, r).optimal_input(T, 1.0, cells=200)
        out["narrow"].append((r, inp.M[0, 0], dominant_frequency(inp)))
    out["narrow sup"] = 1.0 / (2 * A_NARROW * c)
    return out


def second_order():
    """§7.4.3: b1 of eq. 7.69 with the C-8 short period."""
    d = mlid.InputDesign([[A1, 1.0], [A2, 0.0]], [[G_C8[0, 0]], [0.0]], [[1.0, 0.0]], [[R_Q]],
                         ["g(1,1)"])
    rows = []
    for T in T_SECOND:
        cfm = cf.second_order(A1, A2, R_Q, T)
        row = {"T": T, "closed": cfm, "operator": d.mu_max(T),
               "riccati": d.mu_max(T, method="riccati"),
               "T riccati": d.critical_length(cfm.mu, "riccati", tmax=4 * T),
               "T transition": d.critical_length(cfm.mu, "transition", tmax=4 * T)[0]}
        for n in CELLS:
            inp = d.optimal_input(T, 1.0, cells=n)
            ref = cfm.input(inp.t)
            row[n] = (np.max(np.abs(inp.u[:, 0] - ref)) / np.max(np.abs(ref)),
                      inp.M[0, 0] / cfm.mu - 1.0)
        rows.append(row)
    return {"rows": rows, "wn": np.sqrt(-A2), "sup": 1.0 / (R_Q * A1**2)}


def state_penalty():
    """§7.6 on the C-8 short period: each penalised design (weight on
    int alpha^2 dt) rescaled to |alpha| <= ALPHA_LIMIT; weight 0 is the
    report's energy rescaling."""
    d = mlid.InputDesign(F_C8, G_C8, np.eye(2), R_C8, UNKNOWNS)
    free = d.optimal_input(T_C8, E_C8)
    rows, checks = [], []
    for k in PENALTIES:
        p = d.state_penalised(T_C8, E_C8, [0.0, k])
        crit = p.summary["trace"] - k * d.state_integral(T_C8, p.u)[1, 1]
        checks.append((k, p.mu * E_C8, crit))
        _, x = d.response(T_C8, p.u)
        s = ALPHA_LIMIT / np.max(np.abs(x[:, 1]))
        rows.append({"k": k, "mu": p.mu, "energy": E_C8 * s**2, "peak q": np.max(np.abs(x[:, 0])) * s,
                     "peak u": np.max(np.abs(p.u)) * s,
                     "summary": mlid.design.input_design.summary(p.M * s**2)})
    k_check = 80.0
    mu80 = d.state_penalised(T_C8, E_C8, [0.0, k_check]).mu
    lengths = (d.penalised_length(mu80, [0.0, k_check]),
               d.penalised_length(mu80, [0.0, k_check], "transition")[0])
    return {"free": free, "rows": rows, "checks": checks, "lengths": (k_check, lengths)}


def verdict(ok):
    return "agrees" if ok else "DIFFERS"


def show(lev, so, pen):
    c, p = lev["closed"], lev["printed"]
    print(f"1. Levadi's example (§7.4.2): a = {A_WIDE:g}, c = {C_NOISE:g}, T = {T_LEVADI:g}")
    print(f"   {'quantity':44s} | {'report':24s} | {'mlid':24s} | verdict")
    print(f"   {'w, our eq. tan(wT+phi) = -w/a':44s} | {'-':24s} | {c.omega[0]:<24.10f} |")
    print(f"   {'w, printed eq. 7.65 tan(wT+phi) = +w/a':44s} | {p.omega[0]:<24.10f} | {'-':24s} |")
    print(f"   {'mu (eq. 7.68), our w':44s} | {'-':24s} | {c.mu:<24.10f} |")
    print(f"   {'mu (eq. 7.68), printed w':44s} | {p.mu:<24.10f} | {'-':24s} |")
    for r in R_WHITE:
        print(f"   {'mu, Kalman route r = %g (operator)' % r:44s} | {'-':24s} | {lev['mu'][r]:<24.10f} |")
    mx = lev["mu extrapolated"]
    print(f"   {'mu, extrapolated to r = 0 (O(sqrt r))':44s} | {p.mu:<24.10f} | {mx:<24.10f} | "
          f"ours {verdict(abs(mx / c.mu - 1) < 1e-4)}, printed {verdict(abs(mx / p.mu - 1) < 1e-4)}")
    for r in R_WHITE:
        e_in, e_l2 = lev["shape"][r]
        print(f"   {'input sin(wt+phi) (7.67), r = %g: max, L2' % r:44s} | {'shape':24s} | "
              f"{e_in:.2e}, {e_l2:.2e}{'':10s} | {verdict(e_l2 < 0.05)}")
    wl, w1 = lev["limit a -> inf"]
    print(f"   {'a -> inf, 2c/a = 1: w -> §7.4.1 w':44s} | {w1:<24.7f} | {wl:<24.7f} | "
          f"{verdict(abs(wl - w1) < 1e-3)}")
    print(f"   narrow band a = {A_NARROW:g}: report, mu -> sup 1/(2ac) = {lev['narrow sup']:g} "
          f"as w -> inf (eq. 7.68)")
    for r, m, w in lev["narrow"]:
        print(f"     r = {r:g}: M/E of the design {m:.6f}, its frequency {w:.1f} rad/s")
    print(f"\n2. Second-order example (§7.4.3): a1 = {A1:.4f}, a2 = {A2:.6f} (C-8, §8.1), "
          f"r = {R_Q:g}, b1 unknown")
    print(f"   natural frequency sqrt(-a2) = {so['wn']:.6f}; sup of mu over T, 1/(r a1^2) = "
          f"{so['sup']:.6f}")
    print(f"   {'T':>4s} | {'w1':>9s} {'w2':>9s} {'w1 w2':>9s} | {'mu closed':>12s} | "
          f"{'operator':>12s} | {'Riccati 7.89':>12s} | {'T Riccati':>10s} | {'T transit.':>10s}")
    for row in so["rows"]:
        cfm = row["closed"]
        w1, w2 = cfm.omega
        print(f"   {row['T']:4.1f} | {w1:9.6f} {w2:9.6f} {w1 * w2:9.6f} | {cfm.mu:12.8f} | "
              f"{row['operator']:12.8f} | {row['riccati']:12.8f} | {row['T riccati']:10.7f} | "
              f"{row['T transition']:10.7f}")
    print("   input shape (eq. 7.78) and M/(mu E) - 1 of the designed input by cells (2n cells):")
    for row in so["rows"]:
        print(f"   T = {row['T']:3.1f}: " + "; ".join(
            f"n = {n}: {row[n][0]:.2e}, {row[n][1]:+.2e}" for n in CELLS))
    print(f"\n3. State-limit penalty (§7.6), C-8 short period, T = {T_C8:g} s, designs at E = "
          f"{E_C8:g}, then rescaled to |alpha| <= {ALPHA_LIMIT:g} deg")
    f = pen["free"].summary
    print(f"   free design (E = {E_C8:g}, no limit): tr M {f['trace']:.0f}, det M {f['det']:.3g}")
    print(f"   {'weight':>6s} {'mu':>8s} | {'energy':>7s} {'peak u':>7s} {'peak q':>7s} | "
          f"{'tr M':>7s} {'det M':>9s} | sigma M_q M_alpha Z_alpha M_delta Z_delta")
    for row in pen["rows"]:
        s = row["summary"]
        print(f"   {row['k']:6.0f} {row['mu']:8.3f} | {row['energy']:7.1f} {row['peak u']:7.2f} "
              f"{row['peak q']:7.2f} | {s['trace']:7.0f} {s['det']:9.3g} | "
              + " ".join(f"{x:.4f}" for x in s["sigma"]))
    print("   check: mu E (operator) against tr M - weight int alpha^2 dt (states sampled):")
    for k, mue, crit in pen["checks"]:
        print(f"     weight {k:5.0f}: {mue:12.3f} {crit:12.3f}  ({mue / crit - 1:+.1e})")
    k, (tr, tt) = pen["lengths"]
    print(f"   weight {k:g}: the critical length of its mu, Riccati {tr:.6f}, transition {tt:.6f} "
          f"(T = {T_C8:g})")


def run():
    out = {"levadi": levadi(), "second order": second_order(), "penalty": state_penalty()}
    show(out["levadi"], out["second order"], out["penalty"])
    return out


if __name__ == "__main__":
    run()
    sys.exit(0)
