"""Speed of a full output-error fit (issue: foundation benchmark).

1. The C-8 case (4 states, 4 outputs, 5 parameters, 301 samples), in-process
   and end to end through mlid-batch on the deck.
2. A synthetic case the size of the HFB-320 record: 4 states, 2 inputs,
   7 outputs, 11 free parameters, 600 samples.  Target: converged in < 20 ms.

Times are the median of repeated runs (wall clock, this machine).
"""

import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import mlid
from mlid.design.signals import input_signal

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
from conftest import c8_record, c8_start  # noqa: E402


def median_time(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


def synthetic_600():
    # Longitudinal-like dynamics (x = V, alpha, theta, q), inputs (delta_e, thrust),
    # outputs (V, alpha, theta, q, qdot, ax, az): qdot and the accelerations are
    # linear combinations of states and inputs.
    F = np.array([[-0.03, 5.0, -9.81, 0.0], [-0.002, -0.8, 0.0, 1.0],
                  [0.0, 0.0, 0.0, 1.0], [0.001, -4.0, 0.0, -1.2]])
    G = np.array([[0.0, 1.3e-4], [-0.06, 0.0], [0.0, 0.0], [-5.0, -7.0e-6]])
    H = np.vstack([np.eye(4), F[3], [-0.03, 5.0, 0.0, 0.0], [0.02, -60.0, 0.0, -3.0]])
    D = np.vstack([np.zeros((4, 2)), G[3], [0.0, 1.3e-4], [-4.0, 0.0]])
    free = ["f(1,1)", "f(1,2)", "f(2,2)", "f(4,2)", "f(4,4)", "g(2,1)", "g(4,1)",
            "h(5,2)", "h(6,2)", "h(7,2)", "d(7,1)"]
    truth = mlid.LinearModel(F, G, H, D, free=free)
    dt, nt = 0.1, 600
    t = np.arange(nt) * dt
    u = np.column_stack([input_signal("3211", 0.02, 2.0, 1.0, dt, nt)
                         + input_signal("pulse", 0.03, 20.0, 2.0, dt, nt),
                         2000.0 * np.sin(0.2 * t)])
    std = np.array([0.2, 0.002, 0.002, 0.002, 0.01, 0.05, 0.1])
    data, _ = mlid.simulate(truth, t, u, std, seed=11)
    th = truth.theta.copy()
    idx = truth.free_indices()
    th[idx] *= np.where(np.arange(idx.size) % 2, 1.3, 0.7)   # start 30% off
    return truth, truth.with_theta(th), data


def report(label, model, data, repeat):
    wall, res = median_time(lambda: mlid.fit(model, data), repeat)
    per_iter = wall / max(res.iterations, 1)
    print(f"{label:<46} {res.iterations:3d} it  {1e3 * wall:8.2f} ms total  "
          f"{1e3 * per_iter:7.3f} ms/it  converged={res.converged}")
    return wall, res


def main():
    print(f"mlid {mlid.__version__}, numpy {np.__version__}")
    c8 = c8_record()
    report("C-8, 301 samples, 5 parameters", c8_start(), c8, 50)
    truth, start, data = synthetic_600()
    wall, res = report("synthetic 4x7, 600 samples, 11 parameters", start, data, 50)
    z = (res.estimate - truth.theta[truth.free_indices()]) / res.sigma
    print(f"  max |estimate - truth| / sigma = {np.max(np.abs(z)):.2f}")
    print(f"  target < 20 ms: {'met' if wall < 0.020 else 'NOT met'}")

    batch = Path(sys.executable).parent / "mlid-batch"
    with tempfile.TemporaryDirectory() as tmp:
        deck = Path(tmp) / "c8.nml"
        shutil.copy(HERE.parent / "cases" / "c8_short_period" / "c8.nml", deck)
        t, _ = median_time(lambda: subprocess.run([str(batch), str(deck)], check=True,
                                                  capture_output=True), 20)
        print(f"{'mlid-batch c8.nml (simulate + fit, process)':<46}        {1e3 * t:8.2f} ms")
        t, _ = median_time(lambda: subprocess.run(
            [str(Path(sys.executable).parent / "mlid"), "run", str(deck)], check=True,
            capture_output=True), 5)
        print(f"{'mlid run c8.nml (same, with Python start-up)':<46}        {1e3 * t:8.2f} ms")


if __name__ == "__main__":
    main()
