"""Peer comparison: the M2/F3 gust problem (cases/m2f3_gusts, filter error,
20 parameters) fitted by mlid and by statsmodels' state-space maximum
likelihood (an MLEModel with the same parameterisation and the same RK4
discretisation, numerical gradients).  Both start from the same values.

Checks: the same maximum (log-likelihood within 1e-6 relative, estimates
within 0.1 sigma) and the speed ratio (target: mlid at least 50x faster).
Also the time per iteration with and without the covariance/gain partials.
Needs statsmodels (make bench installs it).
"""

import sys
import time
from pathlib import Path

import numpy as np
from statsmodels.tsa.statespace.mlemodel import MLEModel

import mlid

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "cases" / "m2f3_gusts"))
import m2f3  # noqa: E402

DERIVS = list(m2f3.WT)
FREE = list(m2f3.ELEMENT.values()) + ["f(5,5)", "q(1)"] + [f"r({i})" for i in range(1, 6)]


def rk4_matrices(F, G, W, h):
    """The RK4 step as x+ = Phi x + B0 u_k + B1 u_k+1 + Wd w (input linear between
    samples, noise held): exactly what mlid integrates for a linear model."""
    n = len(F)
    A = F * h
    I = np.eye(n, dtype=A.dtype)
    phi = I + A + A @ A / 2 + A @ A @ A / 6 + A @ A @ A @ A / 24
    # stages with u(t) = u_k + (u_k+1 - u_k) t/h, by linearity
    P1 = h * (I + A / 2 + A @ A / 6 + A @ A @ A / 24)   # held input
    P2 = h * (I / 2 + A / 6 + A @ A / 24)               # ramp part (times u_k+1 - u_k)
    B1 = P2 @ G
    B0 = P1 @ G - B1
    return phi, B0, B1, P1 @ W


class M2F3(MLEModel):
    """The M2/F3 filter-error problem.  The optimiser sees each parameter
    divided by its start value (scale): the same maximum, but parameters
    from 4e-4 to 75 become comparable for L-BFGS's numerical gradients."""

    def __init__(self, data, scale):
        super().__init__(data.y, k_states=5, k_posdef=1)
        self.u = data.u
        self.h = data.t[1] - data.t[0]
        self.scale = scale
        self.ssm.initialize_known(np.zeros(5), np.zeros((5, 5)))

    def update(self, params, **kwargs):
        params = super().update(params, **kwargs) * self.scale
        values = dict(zip(DERIVS, params[:13]))
        a, q, r = params[13], params[14], params[15:]
        m = model_matrices(values, a)
        phi, B0, B1, Wd = rk4_matrices(m["F"], m["G"], m["Gamma"], self.h)
        self["transition"] = phi
        self["selection"] = Wd
        self["state_cov"] = np.array([[q]])
        self["design"] = m["H"]
        self["obs_cov"] = np.diag(r)
        c = B0 @ self.u.T
        c[:, :-1] += B1 @ self.u[1:].T
        self["state_intercept"] = c
        self["obs_intercept"] = m["D"] @ self.u.T


def model_matrices(v, a):
    s, c, t = np.sin(m2f3.ALPHA), np.cos(m2f3.ALPHA), np.tan(m2f3.ALPHA)
    z = 0 * a
    F = np.array([[v["L_p"], v["L_r"], v["L_beta"], z, v["L_beta"]],
                  [v["N_p"], v["N_r"], v["N_beta"], z, v["N_beta"]],
                  [s + z, -c + z, v["Y_beta"], m2f3.G_V + z, v["Y_beta"]],
                  [1 + z, t + z, z, z, z], [z, z, z, z, a]])
    G = np.array([[v["L_da"], v["L_dr"]], [v["N_da"], v["N_dr"]], [v["Y_da"], v["Y_dr"]],
                  [z, z], [z, z]])
    H = np.array([[1 + z, z, z, z, z], [z, 1 + z, z, z, z], [z, z, 1 + z, z, 1 + z],
                  [z, z, z, 1 + z, z], [z, z, v["Y_beta"], z, v["Y_beta"]]])
    D = np.array([[z, z]] * 4 + [[v["Y_da"], v["Y_dr"]]])
    return {"F": F, "G": G, "H": H, "D": D, "Gamma": np.array([[0.0]] * 4 + [[1.0]])}


def main():
    data, _ = m2f3.record()
    truth = m2f3.model(m2f3.WT, free=FREE)
    start = truth.with_theta(truth.theta * np.where(truth.free_mask == 1, 1.1, 1.0))
    nobs_const = 0.5 * data.nt * data.y.shape[1] * np.log(2 * np.pi)

    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        res = mlid.fit(start, data, method="filter_error")
        times.append(time.perf_counter() - t0)
    t_mlid = float(np.median(times))
    llf_mlid = -res.cost - nobs_const

    # statsmodels parameters in the same order as mlid's free list
    order = [res.names.index(n) for n in DERIVS] + [res.names.index("a (gust)"),
                                                    res.names.index("q (gust)")] \
        + [res.names.index(f"R_{o}") for o in ["p", "r", "beta", "phi", "ay"]]
    x0 = start.theta[start.free_indices()][order]
    scale = np.where(np.abs(x0) > 0, np.abs(x0), 1e-2)
    mod = M2F3(data, scale)
    assert abs(mod.loglike(res.estimate[order] / scale) - llf_mlid) < 1e-8 * abs(llf_mlid), \
        "the two likelihood functions differ"
    t0 = time.perf_counter()
    sm = mod.fit(start_params=x0 / scale, method="lbfgs", maxiter=5000, disp=False,
                 pgtol=1e-8, factr=10.0)
    t_sm = time.perf_counter() - t0
    est_sm = np.asarray(sm.params) * scale
    z = (est_sm - res.estimate[order]) / res.sigma[order]
    print(f"mlid:        {1e3 * t_mlid:9.1f} ms, {res.iterations} iterations, "
          f"log-likelihood {llf_mlid:.10f}")
    print(f"statsmodels: {1e3 * t_sm:9.1f} ms, {sm.mle_retvals.get('iterations', '?')} "
          f"iterations, {sm.mle_retvals.get('fcalls', '?')} likelihood calls, "
          f"log-likelihood {sm.llf:.10f}")
    rel = abs(sm.llf - llf_mlid) / abs(llf_mlid)
    print(f"relative log-likelihood difference {rel:.2e} (target < 1e-6); "
          f"largest estimate difference {np.max(np.abs(z)):.3f} sigma (target < 0.1)")
    print(f"speed ratio statsmodels/mlid = {t_sm / t_mlid:.0f}x (target >= 50x)")

    # time per iteration with and without the covariance/gain partials
    derivs_only = truth.with_free(list(m2f3.ELEMENT.values()))
    for partials in (True, False):
        t0 = time.perf_counter()
        r = mlid.fit(derivs_only, data, method="filter_error", partials=partials)
        dt = time.perf_counter() - t0
        print(f"13 derivatives, gain partials {'on ' if partials else 'off'}: {r.iterations} it, "
              f"{1e3 * dt / max(r.iterations, 1):.1f} ms/iteration, cost {r.cost:.4f}")


if __name__ == "__main__":
    main()
