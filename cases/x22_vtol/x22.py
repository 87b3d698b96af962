"""X-22 VTOL in transition flight: nonlinear model, gusts, extended Kalman
filter (NASA CR-2200 §5.1, Appendix A, Tables 5.1-5.2).

Synthetic records from the Appendix A model with Table 5.1's coefficients as
truth, the pitching-moment derivatives read in deg/s^2 (README: why), gusts
entering through g(x, p) and carried by the q-dot and accelerometer outputs
(the correlated case of §5.1.7).  A single step input against a multistep
input, at the low and moderate noise of Table 5.2; each record identified by
filter error (extended Kalman filter, Q and R known, as the report did) from
the equation-error start-up of §5.1.2; the Cramer-Rao sigmas against Table
5.1's; the effect of the gain partials (Appendix B); the derivatives along
the record (Fig. 5.5 style).

    python x22.py [--plots DIR]

Every number and where it comes from: README.md in this folder.
"""

import argparse
import sys
import time

import numpy as np

import mlid
from mlid.design.signals import input_signal
from mlid.model.models import X22_DERIVATIVES, X22_LABELS

D2R = np.pi / 180
# Table 5.1, first column (CASES.md §2), in the report's units: coefficients of
# (1, u, u^2) in the order of X22_LABELS; M_o, M_w, M_de in deg/s^2 (per ft/s for
# M_w, per unit stick for M_de), M_q per second, X and Z in ft/s^2
TABLE_5_1 = np.array([28.95, -0.176, -0.00035, -0.1, -0.00317, -0.497, -0.00103, 18.66, 0.0669,
                      18.3, -0.0917, -0.0003, 0.2211, -0.00159, -0.778, 0.0184,
                      -32.17, 0.91, -0.007, -0.2939, -0.00287, -0.351, -0.0167])
# report units per model unit: the model's q-dot is in rad/s^2, so M_o, M_w and
# M_de are divided by 180/pi; M_q (q-dot per q) has no angle unit
REPORT_UNITS = np.where([lab.split(".")[0] in ("M_o", "M_w", "M_de") for lab in X22_LABELS],
                        1 / D2R, 1.0)
TRUTH = TABLE_5_1 / REPORT_UNITS
# Table 5.1's Cramer-Rao sigmas (report §5.1.3: diagonal of the inverse
# information), OCR read; None where the OCR lost the cell.  Column 1: the
# Cornell single step, low noise; column 3: SCI's multistep, low noise.
SIGMA_COL1 = [76.18, 1.104, .00405, .695, .00581, .467, .00371, 100.4, .7792, 20.35, .274,
              .000940, .173, .00142, 41.04, .3173, 96.71, 1.276, .00428, .779, .00657, None, None]
SIGMA_COL3 = [2.150, .0352, .000145, .0251, .000236, .0139, .000152, .279, .00306, .873, .0132,
              .00005, .0105, .0000899, .1139, .001134, 2.631, .0427, .000172, .0323, None, None,
              None]
# Table 5.1 column 3's estimates (the last three lost or garbled in the OCR)
ESTIMATE_COL3 = [28.04, -.159, -.000441, -.0947, -.00321, -.489, -.00116, 18.38, .0708, 18.88,
                 -.103, -.00024, .220, -.00159, -.691, .0171, -35.15, .969, -.00728, -.272,
                 None, None, None]
# trim at u = 130 ft/s with q = 0 (ours, solved from the model; CASES.md §2 quotes it)
U0, W0, THETA0, DELTA0 = 130.0, -0.0111438, np.radians(2.31454), -0.00587443
DT, NT = 0.05, 201                # 20 samples/s, 10 s (§5.1.1)
# Table 5.2, low noise (standard deviations); moderate is five times these
GUST_LOW = np.array([1.0, 1.0, 0.2 * D2R])                  # v1, v2 [ft/s], v3 [rad/s]
MEAS_LOW = np.array([0.5, 0.075, 0.03 * D2R, 0.01 * D2R,    # u, w [ft/s], theta, q [rad, rad/s]
                     0.0025 * D2R, 0.001, 0.005])           # qdot [rad/s^2], n_x, n_z [g]
LEVELS = {"low": 1.0, "moderate": 5.0}
STEP = 0.1          # single step, units of stick (ours; Fig. 5.1 lost)
MULTISTEP = 0.6     # the multistep's pulse (ours; Fig. 5.2 lost; README: how it was chosen)
SCAN = (0.5, 0.7)   # the multistep's amplitude either side of ours, to show what it sets
RADIAN_MULTISTEP = 0.1   # the case's former multistep, read in radians
SEED = 3            # ours
FREE = [f"p({k})" for k in range(1, 24)]
# The values the equation-error start-up begins from (ours): zeros.  The
# start-up is a linear least-squares problem and needs no prior values; the
# start enters only through its first weights (the residuals there).
START_UP = np.zeros(len(TABLE_5_1))
RECORDS = [("step", "low"), ("multistep", "low"), ("step", "moderate"),
           ("multistep", "moderate")]


def elevator(kind, amplitude=None):
    """A single step, or our multistep: a 3 s pulse that moves the speed and
    a 3-2-1-1 and a doublet of 0.6 of its amplitude for the short period
    (Fig. 5.2 is lost)."""
    if kind == "step":
        d = input_signal("step", amplitude or STEP, 1.0, 0.0, DT, NT)
    else:
        a = amplitude or MULTISTEP
        d = (input_signal("pulse", a, 0.5, 3.0, DT, NT)
             + input_signal("3211", 0.6 * a, 4.5, 0.3, DT, NT)
             + input_signal("doublet", -0.6 * a, 7.5, 0.6, DT, NT))
    return DELTA0 + d


def model(p, level, free=FREE, x0=(U0, W0, THETA0, 0.0), noise=1.0):
    k = LEVELS[level] * noise
    return mlid.X22Model(p, x0=list(x0), q=(k * GUST_LOW) ** 2, r=(k * MEAS_LOW) ** 2,
                         free=free)


def record(kind, level, seed=SEED, timing="forward", amplitude=None, truth=TRUTH):
    t = np.arange(NT) * DT
    data, states = mlid.simulate(model(truth, level), t, elevator(kind, amplitude)[:, None],
                                 seed=seed, timing=timing)
    data.input_names = ["delta_es"]
    data.output_names = ["u", "w", "theta", "q", "qdot", "n_x", "n_z"]
    return data, states


def identify(data, level, partials=True, startup="equation_error", start=None):
    """Filter error from the equation-error start-up (begun at START_UP
    unless `start` is given), or from the values `start` (startup='none',
    which needs them; the tests also start at the truth, as a check).  The
    raw polynomial coefficients are nearly collinear: rcond is lowered so
    that no direction is dropped, and the halvings raised.  A fit that stops
    short is returned with converged False, not raised."""
    if start is None and startup == "none":
        raise ValueError("identify: startup='none' needs the start values")
    begin = model(START_UP if start is None else start, level)
    t0 = time.perf_counter()
    try:
        res = mlid.fit(begin, data, method="filter_error", startup=startup, partials=partials,
                       rcond=1e-15, halvings=10, max_iter=40)
    except mlid.NonConvergenceError as exc:
        res = exc.result
    res.seconds = time.perf_counter() - t0
    return res


def trim_modes(p):
    """Eigenvalues of df/dx at trim, by central differences of f: the
    accelerometer and q-dot outputs are the aerodynamic accelerations, so f
    follows from h at the state (noise-free one-sample records)."""
    def f(x):
        m = model(p, "low", x0=x, noise=0.0)
        y = mlid.simulate(m, [0.0, DT], np.full((2, 1), DELTA0))[0].y[0]
        g = 32.174           # as fortran/models/mlid_x22.f90
        return np.array([g * y[5] - x[3] * x[1] - g * np.sin(x[2]),
                         g * y[6] + x[3] * x[0] + g * np.cos(x[2]), x[3], y[4]])
    x0, a = np.array([U0, W0, THETA0, 0.0]), np.zeros((4, 4))
    for j, h in enumerate((1e-3, 1e-3, 1e-6, 1e-6)):
        e = np.eye(4)[j] * h
        a[:, j] = (f(x0 + e) - f(x0 - e)) / (2 * h)
    return np.linalg.eigvals(a)


def run(plots=None):
    """Each record fitted from the equation-error start-up, as the report
    did.  A single-step record is also fitted from the multistep record's
    estimate at the same noise (the well-identified manoeuvre starts the
    poor one); its table comes from the higher of the two maxima."""
    fits = {}
    for kind, level in sorted(RECORDS, key=lambda r: r[0] != "multistep"):
        data, states = record(kind, level)
        ee = identify(data, level)
        fit = {"ee": ee, "states": states, "best": ee}
        if kind == "step":
            cont = identify(data, level, startup="none",
                            start=fits["multistep", level]["best"].estimate)
            fit["continued"] = cont
            fit["best"] = cont if -cont.cost > -ee.cost else ee
        fits[kind, level] = fit
    data, _ = record("multistep", "low")
    fits["multistep", "low"]["no partials"] = identify(data, "low", partials=False)
    for a in SCAN:
        data, states = record("multistep", "low", amplitude=a)
        fits["scan", a] = {"best": identify(data, "low"), "states": states}
    # the former reading: Table 5.1 in rad/s^2, with the multistep of 0.1
    # the case had then (0.6 would leave the model's range)
    data, _ = record("multistep", "low", amplitude=RADIAN_MULTISTEP, truth=TABLE_5_1)
    fits["radians"] = identify(data, "low")
    if plots:
        plot_derivatives(fits["multistep", "low"], fits["step", "low"], plots)
    return fits


def derivative_at(res, u):
    """Each derivative of Appendix A at speed u in the report's units, with
    its Cramer-Rao sigma and the truth, from the coefficients and their
    covariance."""
    out, k = {}, 0
    est, cov = res.estimate * REPORT_UNITS, res.covariance * np.outer(REPORT_UNITS, REPORT_UNITS)
    for name, n in X22_DERIVATIVES:
        phi = np.array([u ** j for j in range(n)])
        out[name] = (float(phi @ est[k:k + n]), float(np.sqrt(phi @ cov[k:k + n, k:k + n] @ phi)),
                     float(phi @ TABLE_5_1[k:k + n]))
        k += n
    return out


def plot_derivatives(multi, step, folder):
    """Fig. 5.5 style: derivatives along each record's own speed history,
    true and estimated (band: one Cramer-Rao sigma), in the report's units."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path
    t = np.arange(NT) * DT
    fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True)
    for ax, name in zip(axes.ravel(), ("M_q", "M_w", "M_de", "Z_w")):
        k = X22_LABELS.index(name)
        n = dict(X22_DERIVATIVES)[name]
        scale = REPORT_UNITS[k:k + n]
        for fit, style, label in ((multi, "C0", "multistep"), (step, "C3", "single step")):
            res, states = fit["best"], fit["states"]
            phi = np.vstack([states[:, 0] ** j for j in range(n)]).T * scale
            ax.plot(t, phi @ TRUTH[k:k + n], style, lw=1.8, alpha=0.5,
                    label=f"truth, {label} record")
            val = phi @ res.estimate[k:k + n]
            sd = np.sqrt(np.einsum("ij,jk,ik->i", phi, res.covariance[k:k + n, k:k + n], phi))
            ax.plot(t, val, style, lw=1, ls="--", label=f"estimate, {label}")
            ax.fill_between(t, val - sd, val + sd, color=style, alpha=0.15)
        ax.set_title(f"{name}(u(t))")
    for ax in axes[1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("X-22: derivatives along the record, low noise (report Fig. 5.5 style)")
    fig.tight_layout()
    Path(folder).mkdir(parents=True, exist_ok=True)
    path = Path(folder) / "x22_derivatives.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _ratios(ours, report):
    """ours / report where the report has the cell."""
    return np.array([o / r if r else np.nan for o, r in zip(ours, report)])


def verdict(ratio):
    """Table 5.1's rule (README): a sigma ratio within a factor 1.5 either
    way 'agrees', within 2 'close', else 'differs' by the factor; a dash where
    the report lost the cell."""
    if ratio is None or np.isnan(ratio):
        return "—"
    f = max(ratio, 1 / ratio)
    return "agrees" if f <= 1.5 else "close" if f <= 2 else f"differs {f:.1f}×"


def _summary(r):
    r = r[~np.isnan(r)]
    return (f"{r.size} cells: median {np.median(r):.2f}, range {r.min():.2f} to {r.max():.2f}, "
            f"{np.sum((r >= 0.5) & (r <= 2))} within a factor 2")


def print_units():
    print(f" trim: u {U0:g} ft/s, w {W0:.4f} ft/s, theta {np.degrees(THETA0):.4f} deg, delta_es "
          f"{DELTA0:.5f}")
    for label, p in (("radians (M in rad/s^2)", TABLE_5_1), ("degrees (M in deg/s^2)", TRUTH)):
        ev = trim_modes(p)
        sp, ph = sorted([e for e in ev if e.imag > 0], key=lambda e: -abs(e))
        print(f" modes at trim, Table 5.1 read in {label}: short period {sp.real:.3f} ± "
              f"{sp.imag:.3f}j (wn {abs(sp):.2f} rad/s, zeta {-sp.real / abs(sp):.3f}), phugoid "
              f"{ph.real:.4f} ± {ph.imag:.4f}j; M_delta at trim {p[7] + p[8] * U0:.3f} rad/s^2 "
              "per unit stick")


def print_sigmas(fits):
    multi, step = fits["multistep", "low"]["best"], fits["step", "low"]["best"]
    sm, ss = multi.sigma * REPORT_UNITS, step.sigma * REPORT_UNITS
    em = multi.estimate * REPORT_UNITS
    print(" Table 5.1 against mlid, low noise, report units: truth; column 3 (multistep) estimate "
          "(sigma); mlid multistep estimate (sigma); sigma ratio mlid/report; column 1 (single "
          "step) sigma; mlid single step sigma; ratio; verdicts (multistep, single step)")
    for k, lab in enumerate(X22_LABELS):
        c3 = (f"{ESTIMATE_COL3[k]:10.4g} ({SIGMA_COL3[k]:9.3g})" if SIGMA_COL3[k]
              else f"{'lost':>22}")
        r3 = f"{sm[k] / SIGMA_COL3[k]:6.2f}" if SIGMA_COL3[k] else f"{'':>6}"
        c1 = f"{SIGMA_COL1[k]:9.4g}" if SIGMA_COL1[k] else f"{'lost':>9}"
        r1 = f"{ss[k] / SIGMA_COL1[k]:6.2f}" if SIGMA_COL1[k] else f"{'':>6}"
        v3 = verdict(sm[k] / SIGMA_COL3[k] if SIGMA_COL3[k] else None)
        v1 = verdict(ss[k] / SIGMA_COL1[k] if SIGMA_COL1[k] else None)
        print(f" {lab:<7}{TABLE_5_1[k]:10.4g}{c3}{em[k]:10.4g} ({sm[k]:9.3g}){r3}"
              f"{c1}{ss[k]:10.4g}{r1}  {v3}, {v1}")
    print(f" multistep sigma / column 3: {_summary(_ratios(sm, SIGMA_COL3))}")
    print(f" single step sigma / column 1: {_summary(_ratios(ss, SIGMA_COL1))}")
    zr = [(e - t) / s for e, t, s in zip(ESTIMATE_COL3, TABLE_5_1, SIGMA_COL3) if s and e]
    zm = (multi.estimate - TRUTH) / multi.sigma
    print(f" (estimate - truth)/sigma: report column 3 largest {np.max(np.abs(zr)):.2f}, rms "
          f"{np.sqrt(np.mean(np.square(zr))):.2f} ({len(zr)} cells); mlid multistep largest "
          f"{np.max(np.abs(zm)):.2f}, rms {np.sqrt(np.mean(zm ** 2)):.2f} (23)")
    cells, k = [], 0
    for name, n in X22_DERIVATIVES:          # k: index of the derivative's c0
        pairs = [(k + j, k + j + 1) for j in range(n - 1)]
        if all(SIGMA_COL3[b] for _, b in pairs):
            cells.append(f"{name} " + ", ".join(
                f"{SIGMA_COL3[a] / SIGMA_COL3[b]:.0f} | {sm[a] / sm[b]:.0f}" for a, b in pairs))
        k += n
    print(" centring, report | mlid: sigma(c0)/sigma(c1) (a first-order derivative: at least "
          "the speed [ft/s] where it is best known; a second-order one: u0/2, then "
          "sigma(c1)/sigma(c2) = 2 u0, about u = 0): " + "; ".join(cells))


def print_amplitude(fits):
    """What the multistep's amplitude sets: the speed range, and with it the
    sigmas' level and where the first-order derivatives are best known."""
    lin = [X22_LABELS.index(n) for n, k in X22_DERIVATIVES if k == 2]
    rep = np.mean([SIGMA_COL3[k] / SIGMA_COL3[k + 1] for k in lin if SIGMA_COL3[k + 1]])
    for a in sorted(SCAN + (MULTISTEP,)):
        f = fits["scan", a] if a in SCAN else fits["multistep", "low"]
        res, u = f["best"], f["states"][:, 0]
        s = res.sigma * REPORT_UNITS
        r = _ratios(s, SIGMA_COL3)
        c = np.mean([s[k] / s[k + 1] for k in lin if SIGMA_COL3[k + 1]])
        print(f" multistep of {a:.1f}{' (ours)' if a == MULTISTEP else '':7}: speed {u.min():3.0f} "
              f"to {u.max():3.0f} ft/s, {'converged' if res.converged else 'stopped'} from the "
              f"equation-error start-up, sigma / column 3 median {np.nanmedian(r):.2f} (range "
              f"{np.nanmin(r):.2f} to {np.nanmax(r):.2f}); mean sigma(c0)/sigma(c1) of the "
              f"first-order derivatives {c:.0f} (report {rep:.0f})")


def print_radians(fits):
    """Table 5.1 read in rad/s^2: the sigmas' pattern, not only their level,
    differs from the report's."""
    res = fits["radians"]
    r = _ratios(res.sigma, SIGMA_COL3)
    groups = {g: r[[k for k, lab in enumerate(X22_LABELS) if lab[0] == g]] for g in "MXZ"}
    print(f" Table 5.1 read in radians, multistep of {RADIAN_MULTISTEP}: "
          f"{'converged' if res.converged else 'stopped'} from the equation-error start-up, "
          f"sigma / column 3 median {np.nanmedian(r):.2f}, range {np.nanmin(r):.2f} to "
          f"{np.nanmax(r):.2f}; " + ", ".join(
              f"{g} coefficients {np.nanmin(v):.2f} to {np.nanmax(v):.2f}"
              for g, v in groups.items()))


def print_fits(fits):
    for c in RECORDS:
        f = fits[c]
        ee, best = f["ee"], f["best"]
        line = (f" {c[0]:>9}, {c[1]:<8}: equation-error start-up {ee.iterations:2d} iterations, "
                f"{'converged' if ee.converged else 'stopped'}, -J {-ee.cost:.1f}")
        if "continued" in f:
            cont = f["continued"]
            line += (f"; from the multistep estimate {cont.iterations:2d} iterations, "
                     f"{'converged' if cont.converged else 'stopped'}, -J {-cont.cost:.1f}")
        z = (best.estimate - TRUTH) / best.sigma
        print(line + f"; table from -J {-best.cost:.1f}, {np.sum(np.abs(z) > 3)} of 23 beyond "
              f"3 sigma of the truth, largest {np.max(np.abs(z)):.1f}")
    print(" the records' speed range [ft/s]: " + ", ".join(
        f"{k} {fits[k, 'low']['states'][:, 0].min():.0f}-{fits[k, 'low']['states'][:, 0].max():.0f}"
        for k in ("step", "multistep")))


def print_derivatives(fits):
    print(f" derivatives at u = {U0:g} ft/s, report units, estimate (Cramer-Rao sigma), at the "
          "table's maximum")
    print(f" {'':<6}{'truth':>10}" + "".join(f"{k + ', ' + n:>22}" for k, n in RECORDS))
    at = {c: derivative_at(fits[c]["best"], U0) for c in RECORDS}
    for name, _ in X22_DERIVATIVES:
        line = f" {name:<6}{at[RECORDS[0]][name][2]:10.4f}"
        for c in RECORDS:
            v, s, _ = at[c][name]
            line += f"{v:12.4f} ({s:7.4f})"
        print(line)
    r1 = _ratios(SIGMA_COL1, SIGMA_COL3)
    r1 = r1[~np.isnan(r1)]
    print(f" report, sigma column 1 / column 3: {r1.size} coefficients, ratio {r1.min():.1f} to "
          f"{r1.max():.1f}, median {np.median(r1):.1f}, {np.sum(r1 >= 10)} at 10 or more")
    for level in ("low", "moderate"):
        ratio = [at["step", level][n][1] / at["multistep", level][n][1]
                 for n, _ in X22_DERIVATIVES]
        coef = fits["step", level]["best"].sigma / fits["multistep", level]["best"].sigma
        print(f" mlid, sigma single step / multistep, {level} noise: 23 coefficients, ratio "
              f"{coef.min():.1f} to {coef.max():.1f}, median {np.median(coef):.1f}, "
              f"{np.sum(coef >= 10)} at 10 or more; derivatives at trim: "
              + " ".join(f"{n} {r:.1f}" for (n, _), r in zip(X22_DERIVATIVES, ratio)))


def print_partials(fits):
    w, wo = fits["multistep", "low"]["ee"], fits["multistep", "low"]["no partials"]
    z = (wo.estimate - w.estimate) / w.sigma
    print(f" multistep, low, from the start-up: with gain partials {1e3 * w.seconds:.0f} ms, "
          f"{w.iterations} iterations; without: {1e3 * wo.seconds:.0f} ms, {wo.iterations} "
          f"iterations, {'converged' if wo.converged else 'stopped'}, -J {-wo.cost:.1f} against "
          f"{-w.cost:.1f}, largest distance from the maximum {np.max(np.abs(z)):.1f} sigma")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--plots", metavar="DIR")
    args = p.parse_args(argv)
    try:
        print_units()
        fits = run(args.plots)
    except mlid.MlidError as exc:
        print(f"x22: {exc}", file=sys.stderr)
        return 1
    print_fits(fits)
    print_sigmas(fits)
    print_amplitude(fits)
    print_radians(fits)
    print_derivatives(fits)
    print_partials(fits)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
