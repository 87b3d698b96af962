"""Cost of the coloured-residual correction of the Cramer-Rao bound
(fortran/estimation/time_domain/mlid_colored.f90, fortran/numerics/mlid_fft.f90) against the fit it corrects,
on the real records: HFB-320 output error (cases/hfb320 case 1: 601 samples,
7 outputs, 11 coefficients) and the ATTAS lateral linear model (cases/attas_lateral: 1,502 samples, 5
outputs, 22 parameters); then the size of the brief, N = 3000 samples, ny =
4, nf = 10, on synthetic sensitivities and AR(1) residuals.  In this build
and, with --baseline DIR, in another build's mlid package (DIR holds its
`mlid` folder, e.g. a copy of main's site-packages), as
  - callgrind instruction counts (repeatable on a shared machine) of the
    whole fit (inside the core's mlid_fit) and of the correction in it
    (inside colored_covariance), per fit, and the correction's share;
  - wall-clock medians of the fit and of the correction alone (on the
    weighted sensitivities and residuals at the estimate, mlid.evaluate),
    the builds' processes taking turns round by round so that the machine's
    load falls on both.
Two builds cannot be loaded into one process (one module name), hence
processes.  One thread.  Needs valgrind for the counts (skipped without).

    .venv/bin/python benchmarks/bench_colored.py [--baseline DIR] [--rounds N]

Measured (ours, branch colored-fast against main at d84cbd5 (its venv), one
thread, the machine shared; instructions per fit, the correction's share of
the fit in brackets):
  HFB-320 output error (lag 60):  correction 19.70 M -> 9.43 M (19.2 % -> 10.2 %),
      fit 102.5 M -> 92.2 M; wall: fit 8.50 -> 7.91 ms, correction alone
      (with its Python call) 1.90 -> 1.28 ms;
  ATTAS lateral (lag 150):        correction 48.85 M -> 26.27 M (23.7 % -> 14.3 %),
      fit 206.4 M -> 183.8 M; wall: fit 25.4 -> 23.9 ms, correction alone
      8.38 -> 4.14 ms.
  (HFB-320 filter error, case 3: 32.0 M -> 14.1 M, 0.2 % -> 0.1 % of a
  15,000 M fit, left out of the run for its callgrind time.)
Where they went (callgrind_annotate, HFB-320 before -> after): the
transforms, radix 2 with bit reversal, one series at a time, padded to a
power of two (1024 points), 11.3 M -> 4.7 M: Stockham stages of radix 4, 2,
3 and 5 over blocks of 8 series, the series innermost and vectorized, padded
to the next even 2^a 3^b 5^c (720 points), each series scaled by a power
of two (0.5 M of the 4.7 M: exact, and it makes a small parameter's entries
accurate to rounding of their own size, where sharing a transform with a
series 1e7 larger had left them wrong by 1e-9 of the largest entry); G = K
A 3.8 M -> 1.9 M (fewer frequencies, two kernel columns a pass, the inner
frequencies' factor 2 in the kernel); the autocovariance and the rest
(temporaries, zeroing, twiddles) 4.6 M -> 2.8 M.  What is left on ATTAS
lateral (26.3 M): the transforms 13.0 M, Re sum A^H G (dot products) 5.5 M,
G = K A 4.7 M.  The direct filter (chosen for short lags) runs time-first:
7.9 -> 3.8 instructions per multiply-add (benchmarks/bench_colored_bracket.f90).

Measured (ours, branch colored-cut against main at e34fe4f (its venv), one
thread, --rounds 5, the machine loaded: load average 4-5):
  HFB-320 output error (lag 60):  correction 9.43 M -> 7.73 M (11.4 % -> 9.5 %),
      fit 82.8 M -> 81.1 M; wall: fit 16.3 -> 15.5 ms, correction alone
      1.35 -> 1.22 ms;
  ATTAS lateral (lag 150):        correction 26.27 M -> 22.40 M (16.6 % -> 14.5 %),
      fit 158.1 M -> 154.3 M; wall: fit 35.5 -> 37.0 ms, correction alone
      9.10 -> 9.29 ms (noise of the load: 200 calls of the correction alone
      in turn, least of six runs, 8.76 -> 8.52 ms).
The same sums (every case deck bitwise, benchmarks/compare_cases.py), fewer
instructions around them: the transforms' packing, scaling and unpacking,
G = K A two kernel rows a pass, the kernel's and the autocovariance's
series written in place (benchmarks/bench_stage_eval.py has the steps).
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DATA = REPO.parent / "shared" / "data"
CASES = [  # label, deck, case index, record the case reads
    ("HFB-320 output error", REPO / "cases" / "hfb320" / "hfb320.nml", 0, "hfb320_1_10.asc"),
    ("ATTAS lateral", REPO / "cases" / "attas_lateral" / "attas_lat.nml", 0, "fAttasAilRud2.mat"),
]
FIT = "__mlid_api_MOD_mlid_fit"
CORRECTION = "__mlid_colored_MOD_colored_covariance"


def correction_inputs(res, data, options):
    """The correction's arguments at the estimate (evaluate takes the fit's
    options but not its prior or bounds)."""
    from mlid.estimate.evaluate import evaluate
    options = {k: v for k, v in options.items() if k not in ("prior", "prior_weight", "bounds")}
    ev = evaluate(res.model, data, **options)
    return (ev["weighted_sensitivity"], data.y - ev["yhat"], res.covariance, ev["information"],
            ev["information_sensitivity"])


def child(index, nfits, timed):
    """In a child process: nfits fits of case index; with timed, after a
    warm-up, the median wall time of a fit and of the correction alone.
    Prints 'lag ny nt nf wall_fit wall_correction'."""
    sys.path.insert(0, str(REPO / "benchmarks"))
    import mlid
    from mlid.estimate.colored import colored_covariance
    from timing import median
    _, deck, k, _ = CASES[index]
    case = mlid.read_deck(deck)[k]
    data, opts = case.record(), case.options()
    fit = lambda: mlid.fit(case.model, data, **opts)       # noqa: E731
    res = fit()
    t_fit = t_col = 0.0
    args = correction_inputs(res, data, opts)
    if timed:
        t_fit = median(fit, nfits)
        t_col = median(lambda: colored_covariance(*args), 5 * nfits)
        cov_c, lag = colored_covariance(*args)
        assert lag == res.colored_lag
        assert np.allclose(cov_c, res.covariance_corrected, rtol=1e-8)
    else:                                   # the fits' own corrections only (callgrind)
        for _ in range(nfits - 1):
            fit()
    ny, nt, nf = args[0].shape
    print(res.colored_lag, ny, nt, nf, t_fit, t_col)


def run_child(pkg, index, nfits, timed, prefix=()):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    if pkg:
        env["PYTHONPATH"] = str(pkg)
    out = subprocess.run([*prefix, sys.executable, __file__, "--child", str(index), str(nfits),
                          *(["--timed"] if timed else [])],
                         env=env, capture_output=True, text=True, check=True, cwd="/")
    lag, ny, nt, nf, t_fit, t_col = out.stdout.split()[-6:]
    return (int(lag), int(ny), int(nt), int(nf)), float(t_fit), float(t_col), out.stderr


def instructions(pkg, index, nfits, entry):
    """Instructions per fit inside the core routine entry (callgrind)."""
    with tempfile.TemporaryDirectory() as tmp:
        _, _, _, err = run_child(pkg, index, nfits, False, (
            "valgrind", "--tool=callgrind", f"--toggle-collect={entry}",
            f"--callgrind-out-file={Path(tmp) / 'cg.out'}"))
        return int(re.search(r"Collected : (\d+)", err).group(1)) / nfits


def brief_size():
    from mlid.estimate.colored import colored_covariance
    sys.path.insert(0, str(REPO / "benchmarks"))
    from timing import median
    rng = np.random.default_rng(1)
    ny, nt, nf = 4, 3000, 10
    a = rng.standard_normal((ny, nt, nf)).cumsum(axis=1) / 30     # smooth, like sensitivities
    w = rng.standard_normal((nt, ny))
    v = np.empty_like(w)
    v[0] = w[0]
    for k in range(1, nt):
        v[k] = 0.8 * v[k - 1] + 0.6 * w[k]
    m = np.einsum("pif,pig->fg", a, a)
    cov = np.linalg.inv(m)
    for lag in (None, 100, 300):
        t = median(lambda: colored_covariance(a, v, cov, m, m, lag=lag), 10)
        _, used = colored_covariance(a, v, cov, m, m, lag=lag)
        print(f"this build: N = {nt}, ny = {ny}, nf = {nf}, lag {used}"
              f"{' (chosen)' * (lag is None)}: {1e3 * t:.1f} ms")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--baseline", type=Path, help="folder holding another build's mlid package")
    ap.add_argument("--fits", type=int, default=2, help="fits per callgrind run")
    ap.add_argument("--rounds", type=int, default=5, help="timed rounds (10 fits each)")
    ap.add_argument("--child", type=int, nargs=2)
    ap.add_argument("--timed", action="store_true")
    a = ap.parse_args()
    if a.child is not None:
        return child(a.child[0], a.child[1], a.timed)
    builds = [("this build", None)] + ([("baseline", a.baseline.resolve())] if a.baseline else [])
    for index, (label, _, _, record) in enumerate(CASES):
        if not (DATA / record).is_file():
            print(f"skipped {label}: real flight data not found at {DATA / record}")
            continue
        sizes, _, _, _ = run_child(None, index, 1, False)
        lag, ny, nt, nf = sizes
        print(f"{label} (N = {nt}, ny = {ny}, nf = {nf}, lag {lag}):")
        if shutil.which("valgrind"):
            for name, pkg in builds:
                fit = instructions(pkg, index, a.fits, FIT)
                col = instructions(pkg, index, a.fits, CORRECTION)
                print(f"  {name}: {fit / 1e6:.1f} M instructions per fit, correction "
                      f"{col / 1e6:.2f} M ({100 * col / fit:.1f} % of the fit)")
        walls = {name: ([], []) for name, _ in builds}
        for _ in range(a.rounds):
            for name, pkg in builds:
                _, t_fit, t_col, _ = run_child(pkg, index, 10, True)
                walls[name][0].append(t_fit)
                walls[name][1].append(t_col)
        for name, _ in builds:
            t_fit, t_col = (float(np.median(t)) for t in walls[name])
            print(f"  {name}: fit {1e3 * t_fit:.2f} ms, correction alone {1e3 * t_col:.2f} ms "
                  f"(medians of {a.rounds} processes' medians, taking turns)")
    brief_size()


if __name__ == "__main__":
    main()
