"""Speed at the arithmetic floor (issue 18): three output-error fits timed
in-process, each against the floating-point work it cannot avoid.

(a) HFB-320 (cases/hfb320/hfb320.nml case 1: real record, 601 samples, 11
    free coefficients of the nonlinear longitudinal model) against scipy's
    least_squares on the same problem, timed side by side round by round
    (timing.interleaved_medians): the same simulator (mlid.simulate, the
    core's RK4 without noise), the same free parameters and start.  The
    maximum-likelihood estimate with R-hat diagonal is the weighted least
    squares one with the weights 1/R-hat_ii it gives itself, so scipy solves
    that problem by relaxation: least_squares (trust region, Jacobian by
    forward differences, as a user would call it) on the residuals divided
    by sqrt(R-hat_ii), R-hat again from the residuals, until the estimates
    stop moving.  Both estimates are checked to agree within 0.01 sigma.
(b) ATTAS lateral (cases/attas_lateral/attas_lat.nml: the real record, 1,502
    samples, 22 free parameters of the linear model).  Measured on branch
    attas-acc against main at d84cbd5, one thread (an old measurement: the
    tiles and the wsens are different now, see the end).  callgrind inside
    mlid_fit: 206.4 M -> 183.3 M instructions per fit (19.6 k -> 17.4 k per
    sample and iteration, 7 iterations): the information by weighted output
    over the columns that move it (an output's own bias, one equation's
    coefficients: 535 products a sample instead of 1,265; the 4 x 4 and
    4 x 2 tiles compute 752), the gradient as the same product's last
    column, wsens row by row.  CPU time of the fit (this script's linear_case,
    the builds alternating, twice): 17.0 and 16.9 ms (main), 16.1 and 16.4
    ms (attas-acc), 2.9x and 2.8x the scalar floor; wall 17.8 -> 16.9 ms
    (benchmarks/bench_lti.py, 5 rounds).  The target (10 ms, 2x the floor)
    is not met.  What is left, per fit: the LTI sensitivities 40 M and their
    block products 19 M, the tiles 28 M, gathering the weighted outputs and
    wsens 26 M, the coloured-residual correction about 45 M (its FFT 23 M).
    The LTI products with four terms to a statement took 12 M more off but
    no time, and cost the C-8 Monte Carlo 6 %: not kept.  C-8 (every column
    moves every output: main's stacked product, the same sums): 10.44 M ->
    10.39 M a fit, 1.06 ms CPU both; its Monte Carlo 4,140 -> 4,010 fits
    per CPU second (-3 %: the per-output bookkeeping of each fit).
(c) C-8 short period (cases/c8_short_period/c8.nml: its simulated doublet
    record, 301 samples, made by the deck's first case).

The flop floor: per sample and evaluation with sensitivities, counted by hand
from the algorithm (flops below, each term named), times the samples and the
evaluations a fit makes (iterations + 1: each Newton step's trial point is the
next evaluation); at this core's clock (read from /proc/cpuinfo) and its peak
for scalar code (2 fused multiply-adds a cycle: 4 flops) and for vector code
(two 256-bit FMA pipes, AVX-512 double-pumped on Zen 4: 16 flops a cycle).
The cost-only evaluations of the step halvings and the final covariance
(coloured-residual correction) are not in the floor: the ratio is the whole
fit's CPU time (one thread; on a shared machine its wall time also holds the
others' work) over it, so it says how far the fit as a whole is from the floor.

Measured (ours, one thread, a quiet spell): main at d84cbd5 against the
stop that merged hfb-eval (model interface at explicit shapes), attas-acc
(information by output), colored-fast (the coloured-residual correction's
batched FFT) and fe-alloc (filter error), the two builds run alternately,
twice: (a) HFB-320 CPU time 8.46 / 8.55 ms -> 7.40 / 7.34 ms, scipy's
ratio 57x -> 61-62x, scalar floor ratio 3.4-3.5 -> 3.0; (b) ATTAS lateral
17.3 / 16.7 ms -> 14.6 / 14.4 ms CPU, floor ratio 2.9-3.0 -> 2.5; (c) C-8
1.05 / 1.09 ms -> 1.01 ms (one of the merged build's rounds 1.52 ms, the
machine's other work), floor ratio 3.7.  Issue 18's 3 ms, 500x, 10 ms and
2x-floor targets: not met.

Measured (ours, one thread) at the stop that merged aero-eval, colored-cut,
lti-vec and info-acc (and eig_inverse without spread), against main at
e34fe4f, the builds' processes taking turns (benchmarks/bench_stage_eval.py
--case all --rounds 5, least CPU time of 100 fits each): (a) HFB-320 82.8 ->
77.1 M instructions, 6.79 -> 6.44 ms CPU (scalar floor ratio 2.6); (b) ATTAS
lateral 158.1 -> 103.3 M instructions, 14.42 -> 11.65 ms CPU (floor ratio
2.0); (c) C-8 9.0 -> 7.2 M, 0.98 -> 0.90 ms (floor ratio 3.3).  Native
build (-Dnative=true) beside the portable one, alternating, least CPU of
140 fits: ATTAS 9.6 against 11.9 ms, C-8 0.85 against 0.90 ms, HFB-320 6.4
against 6.5 ms.  The portable build's 3 ms, 500x and 10 ms targets: not
met; the 2x floor: met by ATTAS lateral only, borderline.  A branch (rk-fuse)
that took each sensitivity column's RK4 step in registers cut HFB-320 by
another 4.9 M instructions but not its time (6.77 against 6.75 ms CPU: a
column's four stages are one dependent chain) and was not merged.

Measured (ours, one thread) at the stop that merged tiles, wsens-once,
py-overhead, lti-sens and hfb-outputs and made the allocator keep freed
memory (python/mlid/heap.py), this script on a quiet spell: (a) HFB-320
5.18 ms CPU (was 6.44-6.62 ms), scalar floor ratio 2.1 (was 2.6-2.7),
scipy's ratio 70x (scipy's side runs mlid.simulate, itself faster: 363 ms
against 398-428 ms); (b) ATTAS lateral 6.92 ms CPU (was 11.65-11.98 ms),
floor ratio 1.2 (was 2.0); (c) C-8 0.48 ms (was 0.90-0.97 ms), floor
ratio 1.7 (was 3.3-3.6).  A third of ATTAS lateral's time and a fifth of
HFB-320's had been the kernel's page faults: each fit's freed work arrays
went back to the system and came back as fresh pages (about 1,850 faults a
fit, getrusage's ru_minflt).  Issue 18's 10 ms and the 2x floor of ATTAS
and C-8: met; HFB-320's 3 ms, 500x and 2x floor: not met.

Measured (ours, one thread) at the stop that merged sparse-forcing (the
model names the rows of df/dp and dh/dp its parameters move: model_t's
param_rows), al-eval-lean (the longitudinal model's coefficients summed in
registers) and gave the longitudinal model its own sine and cosine
(fortran/base/mlid_trig.f90): (a) HFB-320 4.70 ms CPU (was 5.18 ms), scalar floor
ratio 1.9 (was 2.1): the 2x floor met; scipy's ratio 77x (364 ms: 561
simulations of 0.44 ms and scipy's own work; 500x would ask the fit to
cost 1.1 simulations while it integrates the record 8 times with 11
sensitivity columns, so on mlid's own simulator 500x cannot be reached:
the issue set it when the simulator, and so scipy's side, was four times
slower, where 3 ms was the same goal); (b) ATTAS lateral 6.72 ms, ratio 1.2;
(c) C-8 0.49 ms, ratio 1.8 (both unchanged).  Issue 18's 3 ms: not met.
"""

import os
import sys
import time
from pathlib import Path

# One thread unless asked otherwise, before numpy and the core load: the
# figures and targets are one thread's, scipy's side on one BLAS thread
# included: the OpenBLAS threads it leaves spinning are charged to the next
# mlid fit's CPU time (both unset: 8.7 ms for a 4.8 ms fit; OpenBLAS on one
# thread: 4.8 for 4.8).
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

import mlid  # noqa: E402
from mlid.cli.deck import run_case  # noqa: E402
from timing import interleaved_medians  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
HFB = REPO / "cases" / "hfb320" / "hfb320.nml"
ATTAS = REPO / "cases" / "attas_lateral" / "attas_lat.nml"
C8 = REPO / "cases" / "c8_short_period" / "c8.nml"
SCALAR_FLOPS_PER_CYCLE = 4       # 2 FMA pipes x 1 double x 2 flops
VECTOR_FLOPS_PER_CYCLE = 16      # 2 FMA pipes x 4 doubles (256 bits) x 2 flops


def clock_hz():
    """The core's clock from /proc/cpuinfo (the first 'cpu MHz'), else 2.6 GHz."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("cpu MHz"):
                return float(line.split(":")[1]) * 1e6
    except OSError:
        pass
    return 2.6e9


def flops_per_sample(nx, nu, ny, nf, model_flops):
    """Flops of one sample of one evaluation (cost, gradient, information).

    RK4 with sensitivity columns S (nx x nf): four stages of A S + df/dtheta
    (2 nx^2 nf + nx nf), three intermediate points S + c K and the weighted
    sum of four K (2 nx nf each, 7 in all), and the model's f, A = df/dx and
    df/dtheta at each stage (model_flops, per stage); outputs y = h(x, u) and
    their sensitivities C S + dh/dtheta (2 ny nx nf + ny nf); the weighted
    sensitivities w = R^-1/2 dy (ny nf), the information's upper triangle
    w'w (ny nf (nf + 1)), the gradient w' R^-1/2 nu (2 ny nf) and the
    residual and cost (3 ny).
    """
    rk4 = 4 * (2 * nx * nx * nf + nx * nf) + 7 * 2 * nx * nf + 4 * model_flops
    outputs = 2 * ny * nx * nf + ny * nf + 2 * ny * (nx + nu)
    accumulation = ny * nf + ny * nf * (nf + 1) + 2 * ny * nf + 3 * ny
    return {"rk4": rk4, "outputs": outputs, "accumulation": accumulation,
            "total": rk4 + outputs + accumulation}


def floor_report(name, seconds, res, nt, nx, nu, ny, nf, model_flops):
    counts = flops_per_sample(nx, nu, ny, nf, model_flops)
    evaluations = res.iterations + 1
    per_sample = seconds / (nt * evaluations)
    hz = clock_hz()
    scalar = counts["total"] / (SCALAR_FLOPS_PER_CYCLE * hz)
    vector = counts["total"] / (VECTOR_FLOPS_PER_CYCLE * hz)
    print(f"  flops per sample and evaluation: {counts['total']} (RK4 with sensitivities "
          f"{counts['rk4']}, outputs {counts['outputs']}, accumulation {counts['accumulation']}); "
          f"{evaluations} evaluations x {nt} samples")
    print(f"  measured (CPU time) {1e9 * per_sample:.0f} ns per sample and evaluation; floor at "
          f"{hz / 1e9:.2f} GHz: scalar {1e9 * scalar:.0f} ns (ratio {per_sample / scalar:.1f}), "
          f"vector {1e9 * vector:.0f} ns (ratio {per_sample / vector:.1f})")


def hfb320():
    case = mlid.read_deck(HFB)[0]
    data = case.record()
    opts = case.options()
    model = case.model
    mask = model.free_indices()               # in the order of res.estimate
    start = model.theta[mask].copy()

    def outputs(p):
        theta = model.theta.copy()
        theta[mask] = p
        sim, _ = mlid.simulate(model.with_theta(theta), data.t, data.u,
                               noise_std=np.zeros(model.ny))
        return sim.y

    def scipy_fit():
        p, r, calls = start.copy(), None, [0, 0]
        for _ in range(20):
            nu = data.y - outputs(p)
            r = np.mean(nu**2, axis=0)
            w = 1.0 / np.sqrt(r)
            sol = least_squares(lambda q: ((data.y - outputs(q)) * w).ravel(), p)
            done = np.all(np.abs(sol.x - p) <= 1e-9 * np.maximum(np.abs(p), 1e-12))
            p = sol.x
            calls[0] += 1
            calls[1] += sol.nfev + sol.njev * len(p)
            if done:
                break
        return p, calls

    def mlid_fit():
        return mlid.fit(model, data, **opts)

    res = mlid_fit()
    p, calls = scipy_fit()
    (t_mlid, t_scipy) = interleaved_medians([mlid_fit, scipy_fit], rounds=3, n=1)
    (c_mlid, c_scipy) = interleaved_medians([mlid_fit, scipy_fit], rounds=3, n=1,
                                            clock=time.process_time)
    (c_sim,) = interleaved_medians([lambda: outputs(start)], rounds=3, n=20,
                                   clock=time.process_time)
    dev = np.max(np.abs(p - res.estimate) / res.sigma)
    print(f"(a) HFB-320 output error, {len(data.t)} samples, {mask.size} parameters, "
          f"{res.iterations} iterations (medians of 3 interleaved rounds):")
    print(f"  mlid.fit {1e3 * t_mlid:.2f} ms; scipy least_squares (relaxed weights) "
          f"{1e3 * t_scipy:.0f} ms ({calls[0]} least_squares calls, {calls[1]} simulations); "
          f"ratio {t_scipy / t_mlid:.0f}x (target >= 500x)")
    print(f"  CPU time (a loaded machine's other work left out): mlid.fit {1e3 * c_mlid:.2f} ms, "
          f"scipy {1e3 * c_scipy:.0f} ms, ratio {c_scipy / c_mlid:.0f}x")
    # scipy's time is its simulations': the ratio is calls x (one simulation) / (one fit),
    # so 500x asks a fit to cost calls/500 simulations, while the fit itself integrates
    # the record (iterations + 1) times, with 11 sensitivity columns besides the state
    need = calls[1] / 500
    print(f"  one simulation (mlid.simulate, CPU) {1e3 * c_sim:.3f} ms: scipy's time is "
          f"{c_scipy / (calls[1] * c_sim):.2f} x its {calls[1]} simulations; 500x would need the "
          f"fit in {1e3 * need * c_sim:.2f} ms = {need:.2f} simulations, where it integrates the "
          f"record {res.iterations + 1} times with sensitivities")
    print(f"  issue 18's target of 3 ms CPU time per fit: {'met' if c_mlid <= 0.003 else 'NOT met'} "
          f"(benchmarks/bench_stage_eval.py counts its instructions)")
    # both stop at a relative change of about 1e-8: a hundredth of a standard error
    # is far inside that and far outside rounding
    print(f"  estimates agree within {dev:.1e} sigma")
    assert dev < 1e-2, f"scipy's estimate differs from mlid's by {dev:.2e} sigma"
    # the aerodynamic model per stage: 3 coefficients (11 regressor terms), forces
    # and moments with sin/cos, 4 state derivatives, their 4 x 4 Jacobian and
    # 4 x 11 parameter Jacobian: about 300 flops (an estimate from the code)
    floor_report("HFB-320", c_mlid, res, len(data.t), model.nx, model.nu, model.ny,
                 int(mask.sum()), 300)


def linear_case(label, deck, index, make_record=None):
    cases = mlid.read_deck(deck)
    if make_record is not None:
        run_case(cases[make_record])
    case = cases[index]
    data = case.record()
    opts = case.options()
    model = case.model
    res = mlid.fit(model, data, **opts)
    (t_fit,) = interleaved_medians([lambda: mlid.fit(model, data, **opts)], rounds=5, n=3)
    (c_fit,) = interleaved_medians([lambda: mlid.fit(model, data, **opts)], rounds=5, n=3,
                                   clock=time.process_time)
    nf = len(model.free)
    print(f"{label}, {len(data.t)} samples, {nf} parameters, {res.iterations} iterations: "
          f"{1e3 * t_fit:.2f} ms (median of 15; CPU time {1e3 * c_fit:.2f} ms)")
    # a linear model's f = F x + G u per stage; its Jacobians are F and G as they are
    floor_report(label, c_fit, res, len(data.t), model.nx, model.nu, model.ny, nf,
                 2 * model.nx * (model.nx + model.nu))
    return t_fit


def main():
    if not (REPO.parent / "shared" / "data").is_dir():
        print("skipped: the real flight records (../shared/data) are not there")
        return
    print(f"OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}, "
          f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}")
    hfb320()
    t = linear_case("(b) ATTAS lateral, linear model", ATTAS, 0)
    print(f"  target <= 10 ms: {'met' if t <= 0.010 else 'NOT met'}")
    linear_case("(c) C-8 short period", C8, 1, make_record=0)


if __name__ == "__main__":
    sys.exit(main())
