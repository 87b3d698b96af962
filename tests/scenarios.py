"""Synthetic records with a hidden effect, for the discrepancy workflow
(tests/test_diagnose.py, benchmarks/diagnose_scenarios.py).

A lateral model (report eq. 5.1 with HL-10-like derivatives, flown open loop
with an aileron 3-2-1-1 and a rudder doublet) generates each record; the
truth contains one effect (or two, or none) that the analysis model lacks.
The nonlinear-term scenario uses the longitudinal model instead, the state-bias one a
linear longitudinal model with the phugoid (a thrust-like bias on V-dot).  In the
SAS scenario a yaw damper adds K_SAS r to the pilot's rudder; the record holds
the pedal command as the input and the rudder position as a fifth output.
"""

import numpy as np

import mlid
from mlid.design.signals import input_signal

ALPHA = np.radians(16.8)
G_V = 32.174 * np.cos(ALPHA) / 1181.0
BASE = {"L_p": -0.3435, "L_r": 0.2723, "L_beta": -30.75, "N_p": 0.0245, "N_r": -0.1290,
        "N_beta": 6.8411, "Y_beta": -0.0916, "L_da": 11.2464, "L_dr": 5.665, "N_da": 0.8135,
        "N_dr": -3.617}
FREE = {"L_p": "f(1,1)", "L_r": "f(1,2)", "L_beta": "f(1,3)", "N_p": "f(2,1)", "N_r": "f(2,2)",
        "N_beta": "f(2,3)", "Y_beta": "f(3,3)", "L_da": "g(1,1)", "L_dr": "g(1,2)",
        "N_da": "g(2,1)", "N_dr": "g(2,2)"}
NOISE = [0.2, 0.1, 0.05, 0.05]          # p, r [deg/s], beta, phi [deg]
DT, NT = 0.02, 400
SCENARIOS = ("null", "bias", "derivative", "gust", "delay", "scale", "lag", "nonlinear", "two",
             "sas", "nonlinear_lateral", "state_bias")
L_ABS_BETA = -1.0                       # roll moment |beta| beta [deg/s2 per deg2] (ours)
K_SAS = 0.5                             # deg rudder per deg/s of yaw rate (ours)
RUDDER_NOISE = 0.05                     # deg
# what the workflow must name first: (family, name)
EXPECTED = {"bias": ("output bias", "bias on beta"),
            "derivative": ("missing derivative", "Y_p"),
            "gust": ("process noise", None),          # any state: the gust drives all three
            "delay": ("input time delay", "delay on delta_a"),
            "scale": ("sensor scale factor", "scale factor on p"),
            "lag": ("sensor lag", "second-order lag on phi"),
            "nonlinear": ("nonlinear term", "alpha^2 in Cm"),
            "two": [("output bias", "bias on beta"), ("input time delay", "delay on delta_a")],
            "sas": ("feedback loop (SAS)", "r fed back to delta_r"),
            "nonlinear_lateral": ("nonlinear term", "|beta|beta in the p equation"),
            "state_bias": ("state-equation bias", "bias in the V equation")}


def matrices(v, y_p=0.0):
    F = np.array([[v["L_p"], v["L_r"], v["L_beta"], 0.0], [v["N_p"], v["N_r"], v["N_beta"], 0.0],
                  [y_p + np.sin(ALPHA), -np.cos(ALPHA), v["Y_beta"], G_V],
                  [1.0, np.tan(ALPHA), 0.0, 0.0]])
    G = np.array([[v["L_da"], v["L_dr"]], [v["N_da"], v["N_dr"]], [0.0, 0.0], [0.0, 0.0]])
    return F, G


def analysis_model(rudder_output=False):
    """The open-loop model; with rudder_output, a fifth output that reads
    the rudder position (y5 = delta_r, the input as recorded)."""
    F, G = matrices(BASE)
    H, D = np.eye(4), np.zeros((4, 2))
    if rudder_output:
        H, D = np.vstack([H, np.zeros(4)]), np.vstack([D, [0.0, 1.0]])
    return mlid.LinearModel(F, G, H, D, free=list(FREE.values()),
                            names={**{e: n for n, e in FREE.items()}, "f(3,1)": "Y_p",
                                   "f(3,2)": "Y_r"})


def _sas(seed, rudder_output=True):
    """A yaw damper (K_SAS r added to the pedal command); the record holds the
    command, and with rudder_output the rudder position too."""
    t, u = inputs()
    F, G = matrices(BASE)
    model = analysis_model(rudder_output)
    K = np.zeros((2, 4))
    K[1, 1] = K_SAS
    truth = mlid.LinearModel(F, G, model.H, model.D, K=K,
                             r=np.square(NOISE + [RUDDER_NOISE] * rudder_output))
    data, _ = mlid.simulate(truth, t, u, seed=seed)
    outs = ["p", "r", "beta", "phi"] + ["rudder"] * rudder_output
    return model, mlid.FlightData(t, u, data.y, ["delta_a", "delta_r"], outs)


def inputs():
    t = np.arange(NT) * DT
    da = input_signal("3211", 2.0, 0.5, 0.3, DT, NT)
    dr = input_signal("doublet", 2.0, 4.0, 0.5, DT, NT)
    return t, np.column_stack([da, dr])


def make(scenario, seed):
    """(analysis model, record) for a scenario and a seed."""
    if scenario == "nonlinear":
        return _longitudinal(seed)
    if scenario == "nonlinear_lateral":
        return _rk4_lateral(seed, L_ABS_BETA)
    if scenario == "null":
        return _rk4_lateral(seed, 0.0)
    if scenario == "sas":
        return _sas(seed)
    if scenario == "state_bias":
        return longitudinal_linear(seed)
    t, u = inputs()
    rng = np.random.default_rng(seed)
    F, G = matrices(BASE, y_p=-0.15 if scenario == "derivative" else 0.0)
    H = np.eye(4)
    surf = u.copy()
    if scenario in ("delay", "two"):
        surf[3:, 0] = u[:-3, 0]
        surf[:3, 0] = u[0, 0]
    if scenario == "gust":
        # a first-order gust entering like sideslip (report eq. 5.1), tau = 0.5 s
        Fg = np.zeros((5, 5))
        Fg[:4, :4] = F
        Fg[:3, 4] = F[:3, 2]
        Fg[4, 4] = -2.0
        truth = mlid.LinearModel(Fg, np.vstack([G, [0, 0]]), np.hstack([H, [[0], [0], [1], [0]]]),
                                 Gamma=[[0], [0], [0], [0], [1.0]], q=[4.0], r=np.square(NOISE))
        data, _ = mlid.simulate(truth, t, surf, seed=seed)
    else:
        truth = mlid.LinearModel(F, G, H, r=np.square(NOISE))
        data, x = mlid.simulate(truth, t, surf, seed=seed)
        y = data.y.copy()
        if scenario in ("bias", "two"):
            y[:, 2] += 0.15
        if scenario == "scale":
            y[:, 0] = x[:, 0] * 1.1 + rng.normal(0, NOISE[0], NT)
        if scenario == "lag":
            # a second-order sensor on phi: omega 15 rad/s, damping 0.7
            wn, z = 15.0, 0.7
            s = np.zeros(2)
            out = np.empty(NT)
            for k in range(NT):
                out[k] = s[0]
                for _ in range(10):
                    h = DT / 10
                    acc = wn * wn * (x[k, 3] - s[0]) - 2 * z * wn * s[1]
                    s = s + h * np.array([s[1], acc])
            y[:, 3] = out + rng.normal(0, NOISE[3], NT)
        data = mlid.FlightData(t, u, y)
    data.input_names = ["delta_a", "delta_r"]
    data.output_names = ["p", "r", "beta", "phi"]
    # the record holds the commanded (undelayed) inputs
    data = mlid.FlightData(t, u, data.y, ["delta_a", "delta_r"], ["p", "r", "beta", "phi"])
    return analysis_model(), data


def first_order_lag(seed, tau=0.1):
    """The null record with phi read through a first-order lag tau (the
    order check of the lag family: it must not say second order)."""
    t, u = inputs()
    F, G = matrices(BASE)
    data, x = mlid.simulate(mlid.LinearModel(F, G, np.eye(4)), t, u, seed=seed)
    rng = np.random.default_rng(seed)
    a = np.exp(-DT / tau)
    z = np.zeros(NT)
    for k in range(1, NT):          # exact for phi linear over the interval's mean
        z[k] = a * z[k - 1] + (1 - a) * 0.5 * (x[k, 3] + x[k - 1, 3])
    y = x + rng.normal(0.0, 1.0, x.shape) * NOISE
    y[:, 3] = z + rng.normal(0.0, NOISE[3], NT)
    return analysis_model(), mlid.FlightData(t, u, y, ["delta_a", "delta_r"],
                                             ["p", "r", "beta", "phi"])


def _longitudinal(seed):
    regs = {"CD": ["1", "V/V0", "alpha"], "CL": ["1", "V/V0", "alpha"],
            "Cm": ["1", "V/V0", "alpha", "qhat", "de"]}
    vals = {"CD": [0.117758, -0.0517459, 0.234846], "CL": [-0.204711, 0.363549, 3.21232],
            "Cm": [0.134413, -0.0139045, -1.00241, -27.0570, -1.43707]}
    const = dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                            7472.0, 0.0524, 0.792, 1.215]))
    r = [0.33, 5.2e-6, 1.5e-4, 6.9e-6, 6.2e-5, 6.0e-4, 4.7e-2]
    truth_regs = dict(regs, Cm=regs["Cm"] + ["alpha^2"])
    truth_vals = dict(vals, Cm=vals["Cm"] + [-2.5])
    truth = mlid.LongitudinalModel(truth_regs, truth_vals, const, x0=[106.0, 0.11, 0.105, -0.003],
                                   r=r)
    t = np.arange(601) * 0.1
    de = -0.008 + input_signal("3211", 0.03, 2.0, 1.5, 0.1, 601) \
        + input_signal("pulse", -0.04, 40.0, 2.0, 0.1, 601)
    u = np.column_stack([de, np.full(601, 11600.0)])
    data, _ = mlid.simulate(truth, t, u, seed=seed,
                            output_names=["V", "alpha", "theta", "q", "qdot", "a_x", "a_z"],
                            input_names=["delta_e", "thrust"])
    free = [f"cd({k})" for k in (1, 2, 3)] + [f"cl({k})" for k in (1, 2, 3)] + \
        [f"cm({k})" for k in (1, 2, 3, 4, 5)]
    model = mlid.LongitudinalModel(regs, vals, const, x0=[106.0, 0.11, 0.105, -0.003], r=r,
                                   free=free)
    return model, data


def _rk4_lateral(seed, l_abs_beta, sub=10):
    """The lateral truth with a roll moment l_abs_beta |beta| beta (calm
    air), integrated here (RK4, sub steps a sample, inputs linear between
    samples), not by mlid: with l_abs_beta = 0 the null record is truly
    null, made by another integrator than the one that fits it."""
    t, u = inputs()
    F, G = matrices(BASE)

    def f(x, uu):
        xd = F @ x + G @ uu
        xd[0] += l_abs_beta * abs(x[2]) * x[2]
        return xd
    h = DT / sub
    x = np.zeros(4)
    xs = np.empty((NT, 4))
    for j in range(NT):
        xs[j] = x
        if j + 1 == NT:
            break
        for k in range(sub):
            ua = u[j] + k / sub * (u[j + 1] - u[j])
            ub = u[j] + (k + 1) / sub * (u[j + 1] - u[j])
            um = 0.5 * (ua + ub)
            k1 = f(x, ua)
            k2 = f(x + 0.5 * h * k1, um)
            k3 = f(x + 0.5 * h * k2, um)
            k4 = f(x + h * k3, ub)
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    rng = np.random.default_rng(seed)
    y = xs + rng.normal(0.0, 1.0, xs.shape) * NOISE
    return analysis_model(), mlid.FlightData(t, u, y, ["delta_a", "delta_r"],
                                             ["p", "r", "beta", "phi"])


#: yaw moment per degree of bank in the equivalence record [deg/s2 per deg] (ours)
N_PHI = -0.5


def equivalent_pair(seed):
    """A record where two candidates are the same model (issue 47's "V fed
    back to delta_e" and M_V with Z_V free, laterally): the truth has a yaw
    moment N_phi f(2,4) the analysis model lacks, and the analysis model
    has L_phi f(1,4) free (zero in the truth).  phi fed back to an aileron
    or the rudder moves f(1,4), which is free, and f(2,4) by k N_da (or k
    N_dr): each is the same model as N_phi free."""
    t, u = inputs()
    F, G = matrices(BASE)
    F[1, 3] = N_PHI
    truth = mlid.LinearModel(F, G, np.eye(4), r=np.square(NOISE))
    data, _ = mlid.simulate(truth, t, u, seed=seed)
    model = analysis_model()
    model = model.with_free(list(model.free) + ["f(1,4)"],
                            names={**model.names, "f(1,4)": "L_phi", "f(2,4)": "N_phi"})
    return model, mlid.FlightData(t, u, data.y, ["delta_a", "delta_r"],
                                  ["p", "r", "beta", "phi"])


#: a linear longitudinal model with the phugoid (states V [m/s], alpha, q,
#: theta [rad], input delta_e [rad]; ours): its free derivatives, their
#: values and the noise of V, alpha, q, theta
LON_FREE = {"X_V": ("f(1,1)", -0.03), "X_alpha": ("f(1,2)", 4.0), "Z_V": ("f(2,1)", -0.002),
            "Z_alpha": ("f(2,2)", -1.2), "M_alpha": ("f(3,2)", -6.0), "M_q": ("f(3,3)", -1.6),
            "Z_de": ("g(2,1)", -0.1), "M_de": ("g(3,1)", -9.0)}
LON_NOISE = [0.1, 0.002, 0.002, 0.002]
LON_DT, LON_NT = 0.05, 800
#: the thrust-like bias on V-dot [m/s2] (ours)
V_DOT_BIAS = 0.05


def longitudinal_linear(seed, v_dot_bias=V_DOT_BIAS):
    """A linear longitudinal record (40 s: an elevator 3-2-1-1 and a pulse,
    the phugoid) whose truth has a constant v_dot_bias in the V equation
    (a thrust offset) that the analysis model lacks (issue 47 item 2)."""
    F = np.zeros((4, 4))
    G = np.zeros((4, 1))
    for name, (e, v) in LON_FREE.items():
        (F if e[0] == "f" else G)[int(e[2]) - 1, int(e[4]) - 1] = v
    F[1, 2], F[0, 3], F[3, 2] = 1.0, -9.81, 1.0
    t = np.arange(LON_NT) * LON_DT
    de = input_signal("3211", 0.02, 2.0, 0.6, LON_DT, LON_NT) \
        + input_signal("pulse", -0.03, 15.0, 2.0, LON_DT, LON_NT)
    u = de.reshape(-1, 1)
    truth = mlid.LinearModel(F, G, np.eye(4), bx=[v_dot_bias, 0.0, 0.0, 0.0],
                             r=np.square(LON_NOISE))
    data, _ = mlid.simulate(truth, t, u, seed=seed)
    model = mlid.LinearModel(F, G, np.eye(4), free=[e for e, _ in LON_FREE.values()],
                             names={e: n for n, (e, _) in LON_FREE.items()})
    return model, mlid.FlightData(t, u, data.y, ["delta_e"], ["V", "alpha", "q", "theta"])
