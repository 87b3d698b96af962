"""Filter error: the steady-state gain against the time-varying one, per
iteration (one evaluation of the cost, gradient and information matrix, gain
partials included), measured side by side.

  - the 24-parameter lateral case of cases/dhc2_turbulence (2 states,
    5 outputs, 601 samples, continuous process noise on both rate equations),
    the issue's target: steady <= 0.5x time-varying;
  - the M2/F3 case of cases/m2f3_gusts (5 states, 20 parameters, 401 samples).

    python benchmarks/bench_filter_error.py
    python benchmarks/bench_filter_error.py --callgrind [--python OTHER_PYTHON]

--callgrind: per evaluation (mlid.evaluate with the gradient and the
information), the instructions and the malloc/calloc/realloc calls inside
the core's mlid_evaluate, counted by valgrind's callgrind, for these two
problems and the HFB-320 filter-error cases (cases/hfb320, cases 3 and 4:
the extended Kalman filter and the steady-state gain of the nonlinear
model; and case 3 with continuous process noise, whose covariance over an
interval takes a matrix exponential at every sample), each on its whole
record and on the first half of it: allocations
that grow with the samples show as the difference; then whole fits of
FITS inside mlid_fit.  --python: the interpreter of another build (say
main's .venv/bin/python) run the same way.

Measured (branch fe-alloc against main at d84cbd5, one thread; issue 18:
nothing allocated per sample, the model evaluated once per point): the
filter's per-sample steps (kf_innovations, the covariance update and
prediction, the EKF's interval and its continuous-noise exponential, the
innovation covariance's Cholesky inverse, the cost's sum) write into work
arrays sized once per filter run; the outputs, dh/dx and dh/dp at a sample
come from one model evaluation (were three: h, dh/dx, then eval for the
sensitivities), and the EKF's df/dx with the first RK4 stage of its
interval (were two).  Per evaluation, instructions and allocations (on the
whole record / on its first half):

  problem           instructions (M)    allocations before      after
  dhc2-tv           217.6 -> 201.1      119,802 / 60,504     1,424 / 1,424
  dhc2-ss            42.1 ->  39.6       18,390 /  9,962     1,402 / 1,402
  m2f3-tv           212.7 -> 197.6       65,182 / 33,224     1,484 / 1,484
  m2f3-ss            33.1 ->  31.5       11,328 /  6,504     1,618 / 1,618
  hfb320-ekf        600.7 -> 544.0      243,886 / 123,486    4,432 / 4,432
  hfb320-ss         122.3 -> 120.5       20,953 / 14,331     8,194 / 8,194
  hfb320-ekf-cont  1251.9 -> 1225.0     533,686 / 267,903    4,432 / 4,432

Whole fits: dhc2-ss (7 iterations) 403.0 -> 382.1 M instructions, 155,609
-> 11,122 allocations; hfb320-ss (22 iterations) 2952 -> 2906 M, 482,348 ->
155,879 (what is left is per filter run: numerical_partials' run per free
parameter, each with its set-up and steady-state solve; none per sample).
Every case deck's results are unchanged to the bit (compare_cases.py, 40
of 40 bitwise), and so are the evaluations above, with and without the
gain partials.  Wall clock per iteration (this script, main's and this
build's processes taking turns, 5 rounds on a quiet machine, medians of
the rounds' medians): DHC-2 time-varying 13.56 -> 12.88 ms, steady-state
3.25 -> 3.14 ms; M2/F3 11.96 -> 11.40 ms, 2.40 -> 2.30 ms.  The malloc
calls were a small part of the time; the issue's gain here is that the
count no longer grows with the record.
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import mlid
from timing import interleaved_medians

HERE = Path(__file__).resolve().parent
ENTRY = "__mlid_api_fit_MOD_mlid_evaluate"    # what callgrind counts
HFB320 = HERE.parent / "cases" / "hfb320" / "hfb320.nml"
sys.path.insert(0, str(HERE.parent / "cases" / "dhc2_turbulence"))
sys.path.insert(0, str(HERE.parent / "cases" / "m2f3_gusts"))
import dhc2  # noqa: E402
import m2f3  # noqa: E402


def dhc2_problem():
    data, realised = dhc2.record()
    f, g, ay, bx, bias, sigma = dhc2.start()
    model = dhc2.model(f, g, ay, bx, bias, sigma, 1e-3 * np.var(data.y, axis=0))
    return model, data, {"process_noise": "continuous_sd"}


def m2f3_problem():
    data = m2f3.record()[0]
    free = list(m2f3.ELEMENT.values()) + ["f(5,5)", "q(1)"] + [f"r({i})" for i in range(1, 6)]
    return m2f3.model(m2f3.start_values(), free=free), data, {}


def hfb320_problem(case, **extra):
    c = mlid.read_deck(HFB320)[case - 1]
    return c.model, c.record(), dict(c.options(), **extra)


PROBLEMS = {
    "dhc2-tv": lambda: dhc2_problem(), "dhc2-ss": lambda: dhc2_problem(),
    "m2f3-tv": lambda: m2f3_problem(), "m2f3-ss": lambda: m2f3_problem(),
    "hfb320-ekf": lambda: hfb320_problem(3), "hfb320-ss": lambda: hfb320_problem(4),
    "hfb320-ekf-cont": lambda: hfb320_problem(3, process_noise="continuous"),
}


FITS = ("dhc2-ss", "hfb320-ss")      # whole fits too (--callgrind), with their decks' options


def child(name, nt, n):
    """n evaluations of problem name on its first nt samples (0: all); a
    name 'fit:problem': n fits instead (printing the iterations too)."""
    fit = name.startswith("fit:")
    name = name.removeprefix("fit:")
    model, data, extra = PROBLEMS[name]()
    if nt:
        data = mlid.FlightData(data.t[:nt], data.u[:nt], data.y[:nt], data.input_names,
                               data.output_names)
    extra = dict(extra, method="filter_error")
    if name.endswith("-ss"):
        extra["steady_state"] = True
    if fit:
        for _ in range(n):
            res = mlid.fit(model, data, **extra)
        print(res.iterations, data.nt)
        return
    for _ in range(n):
        mlid.evaluate(model, data, **mlid.estimate.options.evaluate_options(extra))
    print(data.nt)


def callgrind(python, name, nt, n=2):
    """Instructions and allocator calls per evaluation inside mlid_evaluate
    (per fit inside mlid_fit)."""
    entry = ENTRY.replace("evaluate", "fit") if name.startswith("fit:") else ENTRY
    from bench_stage_eval import allocator_calls
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "cg.out"
        proc = subprocess.run(
            ["valgrind", "--tool=callgrind", f"--toggle-collect={entry}",
             f"--callgrind-out-file={out}", "--compress-strings=yes", python, __file__,
             "--child", name, str(nt), str(n)],
            env=dict(os.environ, OMP_NUM_THREADS="1"), capture_output=True, text=True,
            check=True)
        ir = int(re.search(r"Collected : (\d+)", proc.stderr).group(1))
        return ir / n, allocator_calls(out) / n, int(proc.stdout.split()[-1])


def count(python):
    for name in PROBLEMS:
        full = callgrind(python, name, 0)
        half = callgrind(python, name, full[2] // 2)
        print(f"{name}: {full[0] / 1e6:.2f} M instructions per evaluation ({full[2]} samples), "
              f"{full[1]:.0f} allocations ({half[1]:.0f} on the first {half[2]} samples)")
    for name in FITS:
        ir, allocs, _ = callgrind(python, "fit:" + name, 0, n=1)
        print(f"{name}: {ir / 1e6:.1f} M instructions and {allocs:.0f} allocations per fit")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--callgrind", action="store_true")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--child", nargs=3)
    a = ap.parse_args()
    if a.child:
        return child(a.child[0], int(a.child[1]), int(a.child[2]))
    if a.callgrind:
        return count(a.python)
    print(f"threads: OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    for name, (model, data, extra) in [("DHC-2-like lateral", dhc2_problem()),
                                       ("M2/F3 with gusts", m2f3_problem())]:
        calls = [lambda s=s: mlid.evaluate(model, data, method="filter_error", steady_state=s,
                                           **extra) for s in (False, True)]
        tv, ss = interleaved_medians(calls, rounds=5, n=5)
        nf = int(model.free_mask.sum())
        print(f"{name}: {nf} free parameters, {data.nt} samples, {model.nx} states; per iteration "
              f"time-varying {tv * 1e3:.2f} ms, steady-state {ss * 1e3:.2f} ms, ratio {ss / tv:.2f}")


if __name__ == "__main__":
    main()
