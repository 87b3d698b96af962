"""Cost of the frequency-domain tools (fortran/estimation/frequency_domain/mlid_freq_response.f90,
fortran/estimation/frequency_domain/mlid_transfer_fit.f90) on the C-8 longitudinal model (4 states,
5 free derivatives), measured side by side in one run:

- the frequency response q/delta_e of a 1,500-sample record (Welch, 256-sample
  segments, half overlap), against scipy.signal's csd + welch (a second
  implementation: the same numbers, tests/test_frequency.py);
- the identified model's response with Cramer-Rao bands at 200 frequencies
  (analytic derivatives, delta method), against plots.bode_data (the same
  bands for every input-output pair at 300 frequencies, with the record's
  response of each pair: not the same work, what the Bode figure draws);
- a LOES fit, q/delta_e = (b1 s + b0) e^-ts / (s^2 + a1 s + a0), to the
  model's response at 100 frequencies over 0.5-10 rad/s (above the phugoid,
  as handling-qualities fits of the short period take it).

    python benchmarks/bench_freq_tools.py
"""

import sys
from pathlib import Path

import numpy as np

import mlid
from mlid.report import plots
from timing import interleaved_medians

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import C8_STD, c8_start, c8_truth  # noqa: E402


def main():
    dt, nt = 0.02, 1500
    t = np.arange(nt) * dt
    u = 0.02 * np.random.default_rng(1).standard_normal(nt)       # white elevator noise
    data, _ = mlid.simulate(c8_truth(), t, u, noise_std=C8_STD, seed=2, input_names=["de"],
                            output_names=["u", "theta", "q", "alpha"])
    res = mlid.fit(c8_start(), data)
    freq = np.logspace(-2, np.log10(0.5 / dt), 200)
    model = mlid.model_response(res, freq, "de", "q")
    loes_f = np.logspace(np.log10(0.5), 1, 100) / (2 * np.pi)
    loes_in = mlid.model_response(res, loes_f, "de", "q")

    from scipy import signal
    kw = dict(fs=1 / dt, window="hann", nperseg=256, noverlap=128, detrend="constant")

    def scipy_response():
        _, guy = signal.csd(data.u[:, 0], data.y[:, 2], **kw)
        _, guu = signal.welch(data.u[:, 0], **kw)
        _, gyy = signal.welch(data.y[:, 2], **kw)
        return guy / guu, abs(guy)**2 / (guu * gyy)

    fns = [lambda: mlid.record_response(data, "de", "q", segment=256),
           scipy_response,
           lambda: mlid.model_response(res, freq, "de", "q"),
           lambda: plots.bode_data(res),
           lambda: mlid.fit_transfer_function(loes_in, 1, 2)]
    t_rec, t_sci, t_mod, t_sampled, t_loes = interleaved_medians(fns, rounds=5, n=10)
    fit = mlid.fit_transfer_function(loes_in, 1, 2)
    print(f"C-8 record of {nt} samples, q/delta_e")
    print(f"  record response (Welch, 256-sample segments): {1e3 * t_rec:8.3f} ms"
          f"   scipy csd+welch: {1e3 * t_sci:8.3f} ms   ratio {t_rec / t_sci:.2f}")
    print(f"  model response + CR bands, 200 frequencies:   {1e3 * t_mod:8.3f} ms"
          f"   bode_data (all pairs, record's too): {1e3 * t_sampled:8.1f} ms")
    print(f"  LOES fit (1/2 with delay, 100 frequencies):   {1e3 * t_loes:8.3f} ms"
          f"   ({fit.iterations} iterations, mismatch {fit.mismatch:.3g})")
    print(f"  max sigma of the gain over 200 frequencies: {model.sigma_gain.max():.3f} dB")


if __name__ == "__main__":
    main()
