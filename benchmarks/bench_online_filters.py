"""Online estimation (issue 45 item 1): the augmented-state EKF and UKF per
sample on test case 11 (ATTAS short period, fAttasElv1.mat + fAttasElv2.mat
joined, 1,252 samples, 8 parameters; each reference header's settings),
against the real-time budget of a sample (dt = 40 ms) and against the
textbook software's Octave CPU time, read from each reference's header
(../shared/data/refs/recursive/ref_tc11_*.txt: EKF 5.98 s, UKF 10.7 s,
UKFaug 16.1 s, EFRLS 5.40 s).  Target: >= 1,000x the reference.  The whole Python call is
timed (record and model set up, the filter, the history returned).

    python benchmarks/bench_online_filters.py
"""

import re
import sys
from pathlib import Path

import numpy as np

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent))
from timing import interleaved_medians  # noqa: E402

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
REFS = SHARED / "refs" / "recursive"
COLUMNS = ["T[s]", "AXCG[m/s2]", "AYCG[m/s2]", "AZCG[m/s2]", "AYCKP[m/s2]", "AZCKP[m/s2]",
           "PRGX[deg/s]", "QRGY[deg/s]", "RRGZ[deg/s]", "PHI[deg]", "THE[deg]", "PSI[deg]",
           "ALCG[deg]", "BECG[deg]", "VTASCG[m/s]", "HQNH[ft]", "PDOT[deg/s2]",
           "QDOT[deg/s2]", "RDOT[deg/s2]", "HRADIO[m]", "VCAS[m/s]", "DELV[deg]"]
FREE = ["bx(1)", "f(1,1)", "f(1,2)", "g(1,1)", "bx(2)", "f(2,1)", "f(2,2)", "g(2,1)"]
R = [4.10310101e-07, 7.96755798e-07]


def record():
    recs = [mlid.FlightData.load(SHARED / f, time_col="T", input_cols=["DELV"],
                                 output_cols=["ALCG", "QRGY"], columns=COLUMNS)
            for f in ("fAttasElv1.mat", "fAttasElv2.mat")]
    u = np.vstack([r.u for r in recs])
    return mlid.FlightData(np.arange(len(u)) * 0.04, u, np.vstack([r.y for r in recs]))


def model(noise_inputs=False):
    extra = dict(Gamma=np.eye(2), q=[1e-7, 1e-7]) if noise_inputs else {}
    return mlid.LinearModel([[-0.213832, 1.0278189], [-2.73646, -1.08034]],
                            [[0.166147], [-3.1894]], np.eye(2), bx=[-0.00252504, 0.271618],
                            x0=[0.0388778549, -0.0027082274], free=FREE, **extra)


def octave_cpu(method):
    head = (REFS / f"ref_tc11_{method}.txt").read_text()
    return float(re.search(r"CPU: estimator ([0-9.]+) s", head).group(1))


def main():
    if not (REFS / "ref_tc11_EKF.txt").is_file():
        sys.exit(f"the recursive references are not under {REFS}")
    data = record()
    q = [1e-7, 1e-7] + [0.0] * 8
    runs = {"EKF": lambda: mlid.online.ekf(model(), data, p0=10.0, q=q, r=R),
            "UKF": lambda: mlid.online.ukf(model(), data, p0=10.0, q=q, r=R),
            "UKFaug": lambda: mlid.online.ukf(model(True), data, p0=10.0, q=0.0, r=R,
                                              augmented=True),
            "EFRLS": lambda: mlid.online.efrls(model(), data, forgetting=0.998, p0=1e3,
                                               r=[1.0, 1.0])}
    times = interleaved_medians(list(runs.values()), rounds=5, n=3)
    for (name, _), t in zip(runs.items(), times):
        us = 1e6 * t / data.nt
        ref = octave_cpu(name)
        print(f"{name:7s} TC11 {data.nt} samples: {us:7.1f} us/sample; budget 40,000 us "
              f"({40e3 / us:,.0f}x real time); Octave reference {ref:.2f} s "
              f"({1e6 * ref / data.nt:,.0f} us/sample): ratio {ref / t:,.0f}x")


if __name__ == "__main__":
    main()
