"""Synthetic records with a hidden effect, for the discrepancy workflow
(tests/test_diagnose.py, benchmarks/diagnose_scenarios.py).

A lateral model (report eq. 5.1 with HL-10-like derivatives, flown open loop
with an aileron 3-2-1-1 and a rudder doublet) generates each record; the
truth contains one effect (or two, or none) that the analysis model lacks.
The nonlinear-term scenario uses the longitudinal model instead, the state-bias one a
linear longitudinal model with the phugoid (a thrust-like bias on V-dot).  In the
SAS scenario a yaw damper adds K_SAS r to the pilot's rudder; the record holds
the pedal command as the input and the rudder position as a fifth output.

CATALOGUE (issue 47) is the wider set the benchmark runs, by kind: single
effects on both axes (the lateral aircraft and a linear longitudinal one
with the phugoid), pairs, nulls with white and with coloured noise (AR(1),
and the real HFB-320 record's residuals under a simulation of its fitted
model, read from the shared data folder), effects no candidate family can
express (an aileron dead-zone and backlash, a structural mode on the q
gyro), the weak-effect curve (a bias, a missing derivative and a quadratic
term at 2-5 Cramer-Rao sigma, cr_sigma) and effects injected into the real
residuals.  SCENARIOS and make() are the original set the tests iterate.
"""

import functools
from pathlib import Path

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


def _longitudinal(seed, cm_alpha2=-2.5):
    regs = {"CD": ["1", "V/V0", "alpha"], "CL": ["1", "V/V0", "alpha"],
            "Cm": ["1", "V/V0", "alpha", "qhat", "de"]}
    vals = {"CD": [0.117758, -0.0517459, 0.234846], "CL": [-0.204711, 0.363549, 3.21232],
            "Cm": [0.134413, -0.0139045, -1.00241, -27.0570, -1.43707]}
    const = dict(zip(mlid.model.models.CONSTANTS, [9.80665, 4.028e-3, 8.0027e-4, -7.0153e-6, 104.67,
                                            7472.0, 0.0524, 0.792, 1.215]))
    r = [0.33, 5.2e-6, 1.5e-4, 6.9e-6, 6.2e-5, 6.0e-4, 4.7e-2]
    truth_regs = dict(regs, Cm=regs["Cm"] + ["alpha^2"])
    truth_vals = dict(vals, Cm=vals["Cm"] + [cm_alpha2])
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
    xs = _rk4_states(u, l_abs_beta, sub)
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


# --- issue 47: the held-out-like set (both axes, pairs, coloured nulls, effects
# outside the library, weak effects) -----------------------------------------

#: the kinds of scenario, in the order the benchmark prints them
KINDS = ("single", "pair", "null", "coloured null", "outside", "weak", "real")
#: AR(1) coefficients of the coloured-noise nulls (issue 47)
AR1_PHIS = (0.3, 0.6, 0.8)
#: the weak-effect curve: effect sizes in Cramer-Rao sigmas of the effect
#: (cr_sigma), and the effects
WEAK_SIZES = (2, 3, 4, 5)
WEAK_EFFECTS = ("bias", "derivative", "quadratic")
#: the aileron of the out-of-library records: the 3-2-1-1 of inputs() and a
#: smaller doublet (amplitude, start [s], pulse width [s]): a dead-zone or
#: backlash changes a small input by more than a large one, so no gain of
#: the model stands in for it
SMALL_DOUBLET = (0.8, 5.5, 0.4)
#: aileron dead-zone half-width and backlash width [deg] (ours)
DEAD_ZONE = 0.5
BACKLASH = 0.6
#: the structural mode on the q gyro of the longitudinal record: frequency
#: [Hz], damping, and the share c of the mode's rate seen by the gyro; the
#: elevator drives the mode (eta'' + 2 zeta w eta' + w^2 eta = w^2 delta_e)
MODE_HZ, MODE_ZETA, MODE_GAIN = 2.7, 0.03, 0.03
#: lateral pairs and the longitudinal record's effects (ours): Y_p, the p
#: sensor gain, a bias on r [deg/s], M_V [rad/s2 per m/s], a bias on alpha
#: [rad], the elevator recorded this many samples ahead
Y_P, P_GAIN, R_BIAS = -0.15, 1.1, 0.1
M_V, ALPHA_BIAS, LON_DELAY = -0.01, 0.004, 2
#: effects injected into the real HFB-320 residuals (ours): C_m alpha^2 and a
#: bias on q [rad/s]
HFB_CM_ALPHA2, HFB_Q_BIAS = -2.5, 0.002
#: the HFB-320 deck (its record in the shared data folder, found through the
#: deck; the "real" scenarios are skipped when it is absent)
HFB_DECK = Path(__file__).resolve().parent.parent / "cases" / "hfb320" / "hfb320.nml"
HFB_RECORD = HFB_DECK.parents[3] / "shared" / "data" / "hfb320_1_10.asc"


class Scenario:
    """One scenario of the set: its kind (KINDS), axis ('lateral',
    'longitudinal'), what the workflow must name and what the truth holds.
    expected: for 'single', 'weak' and 'real' effects, the (family, name)
    pairs any of which is right first (name None: any of the family); for
    'pair', the (family, name) pairs that must all be accepted; None for
    nulls and out-of-library effects, where naming an effect is wrong."""

    def __init__(self, name, kind, axis, expected, what, make):
        self.name, self.kind, self.axis, self.expected, self.what = name, kind, axis, expected, what
        self._make = make

    def make(self, seed):
        """(analysis model, record) at a seed."""
        return self._make(seed)

    def __repr__(self):
        return f"Scenario({self.name}: {self.kind}, {self.axis})"


def hfb_available():
    """Whether the real HFB-320 record is on this machine."""
    return HFB_RECORD.exists()


def ar1_noise(rng, phi, sd, nt):
    """AR(1) measurement noise, e(k) = phi e(k-1) + sqrt(1 - phi^2) w(k), each
    column of standard deviation sd, stationary from its first sample."""
    w = rng.normal(0.0, 1.0, (nt, len(sd)))
    e = np.empty_like(w)
    e[0] = w[0]
    c = np.sqrt(1.0 - phi * phi)
    for k in range(1, nt):
        e[k] = phi * e[k - 1] + c * w[k]
    return e * np.asarray(sd)


def dead_zone(u, half):
    """A surface that does not move until the command leaves +-half."""
    return np.sign(u) * np.maximum(np.abs(u) - half, 0.0)


def backlash(u, width):
    """A surface in a linkage with play: it follows the command only once
    the command is width/2 beyond it, and stays where it was on reversal."""
    out = np.empty_like(u)
    y = u[0]
    for k, c in enumerate(u):
        if c - y > width / 2:
            y = c - width / 2
        elif y - c > width / 2:
            y = c + width / 2
        out[k] = y
    return out


def _lateral_record(t, u, y):
    return mlid.FlightData(t, u, y, ["delta_a", "delta_r"], ["p", "r", "beta", "phi"])


def _outside_inputs():
    """inputs() with the small aileron doublet after the 3-2-1-1."""
    t, u = inputs()
    a, start, width = SMALL_DOUBLET
    u = u.copy()
    u[:, 0] += input_signal("doublet", a, start, width, DT, NT)
    return t, u


def lateral(seed, y_p=0.0, beta_bias=0.0, r_bias=0.0, p_gain=1.0, delay=0, lag=False,
            surface=None, outside=False, phi=0.0):
    """A lateral record simulated by mlid from the analysis model's truth
    with effects the analysis model lacks: Y_p, output biases on beta and r,
    a p sensor gain, the aileron recorded delay samples ahead, the second-
    order lag on phi of make('lag'), a surface function of the aileron
    command (dead_zone, backlash; outside: the out-of-library aileron
    input); phi > 0: AR(1) measurement noise instead of white."""
    t, u = _outside_inputs() if outside else inputs()
    rng = np.random.default_rng(seed)
    F, G = matrices(BASE, y_p=y_p)
    surf = u.copy()
    if delay:
        surf[delay:, 0] = u[:-delay, 0]
        surf[:delay, 0] = u[0, 0]
    if surface is not None:
        surf[:, 0] = surface(surf[:, 0])
    data, x = mlid.simulate(mlid.LinearModel(F, G, np.eye(4), r=np.square(NOISE)), t, surf,
                            seed=seed)
    y = data.y.copy() if phi == 0 else x + ar1_noise(rng, phi, NOISE, NT)
    y[:, 0] += (p_gain - 1.0) * x[:, 0]
    y[:, 1] += r_bias
    y[:, 2] += beta_bias
    if lag:
        y[:, 3] = _second_order_sensor(x[:, 3]) + (y[:, 3] - x[:, 3])
    return analysis_model(), _lateral_record(t, u, y)


def _second_order_sensor(x, wn=15.0, z=0.7):
    """x read through a second-order sensor (make('lag')'s), held over each
    sample interval, ten Euler substeps."""
    s = np.zeros(2)
    out = np.empty(len(x))
    for k in range(len(x)):
        out[k] = s[0]
        for _ in range(10):
            acc = wn * wn * (x[k] - s[0]) - 2 * z * wn * s[1]
            s = s + DT / 10 * np.array([s[1], acc])
    return out


def coloured_null(seed, phi, l_abs_beta=0.0):
    """The null record of make('null') (the scenarios' own RK4) with AR(1)
    measurement noise of the same standard deviations."""
    t, u = inputs()
    xs = _rk4_states(u, l_abs_beta)
    y = xs + ar1_noise(np.random.default_rng(seed), phi, NOISE, NT)
    return analysis_model(), _lateral_record(t, u, y)


def _rk4_states(u, l_abs_beta, sub=10):
    """The lateral truth's states with a roll moment l_abs_beta |beta| beta
    (calm air), integrated here by RK4, sub steps a sample, the inputs
    linear between samples: another integrator than mlid's."""
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
    return xs


def nonlinear_with_bias(seed):
    """make('nonlinear_lateral')'s roll moment |beta| beta and a bias on r."""
    model, data = _rk4_lateral(seed, L_ABS_BETA)
    y = data.y.copy()
    y[:, 1] += R_BIAS
    return model, _lateral_record(data.t, data.u, y)


def _lon_matrices(m_v=0.0):
    F = np.zeros((4, 4))
    G = np.zeros((4, 1))
    for name, (e, v) in LON_FREE.items():
        (F if e[0] == "f" else G)[int(e[2]) - 1, int(e[4]) - 1] = v
    F[1, 2], F[0, 3], F[3, 2] = 1.0, -9.81, 1.0
    F[2, 0] = m_v
    return F, G


#: names of the longitudinal model's fixed elements a candidate may free
LON_NAMES = {"f(1,3)": "X_q", "f(2,3)": "Z_q", "f(3,1)": "M_V", "f(1,4)": "X_theta",
             "f(2,4)": "Z_theta", "f(3,4)": "M_theta", "g(1,1)": "X_de"}


def lon_analysis_model():
    """The linear longitudinal analysis model of longitudinal_linear, its
    fixed elements named (LON_NAMES)."""
    F, G = _lon_matrices()
    return mlid.LinearModel(F, G, np.eye(4), free=[e for e, _ in LON_FREE.values()],
                            names={**{e: n for n, (e, _) in LON_FREE.items()}, **LON_NAMES})


def lon_inputs():
    t = np.arange(LON_NT) * LON_DT
    de = input_signal("3211", 0.02, 2.0, 0.6, LON_DT, LON_NT) \
        + input_signal("pulse", -0.03, 15.0, 2.0, LON_DT, LON_NT)
    return t, de.reshape(-1, 1)


def longitudinal(seed, v_dot_bias=0.0, m_v=0.0, alpha_bias=0.0, delay=0, mode=False, phi=0.0):
    """A linear longitudinal record (longitudinal_linear's aircraft, with the
    phugoid) with effects its analysis model lacks: a thrust-like bias on
    V-dot, M_V, a bias on alpha, the elevator recorded delay samples ahead,
    the structural mode on the q gyro (MODE_HZ); phi > 0: AR(1) measurement
    noise."""
    t, u = lon_inputs()
    F, G = _lon_matrices(m_v)
    surf = u.copy()
    if delay:
        surf[delay:, 0] = u[:-delay, 0]
        surf[:delay, 0] = u[0, 0]
    H = np.eye(4)
    bx = [v_dot_bias, 0.0, 0.0, 0.0]
    if mode:                     # two more states: the mode's eta and eta-dot
        w = 2 * np.pi * MODE_HZ
        F = np.block([[F, np.zeros((4, 2))],
                      [np.zeros((2, 4)), np.array([[0.0, 1.0], [-w * w, -2 * MODE_ZETA * w]])]])
        G = np.vstack([G, [[0.0], [w * w]]])
        H = np.hstack([H, np.zeros((4, 2))])
        H[2, 5] = MODE_GAIN
        bx += [0.0, 0.0]
    truth = mlid.LinearModel(F, G, H, bx=bx, r=np.square(LON_NOISE))
    data, x = mlid.simulate(truth, t, surf, seed=seed)
    y = data.y.copy()
    if phi:
        y = x @ H.T + ar1_noise(np.random.default_rng(seed), phi, LON_NOISE, LON_NT)
    y[:, 1] += alpha_bias
    return lon_analysis_model(), mlid.FlightData(t, u, y, ["delta_e"], ["V", "alpha", "q", "theta"])


def _hfb_case():
    return mlid.read_deck(HFB_DECK)[0]


@functools.lru_cache(maxsize=1)
def hfb_fit():
    """The HFB-320 deck's first case fitted to its real record: (analysis
    model as the deck starts it, record, fit).  Read from the shared data
    folder, never copied."""
    case = _hfb_case()
    data = case.record()
    return case.model, data, mlid.fit(case.model, data)


#: the real residuals are moved round the record by this many samples a
#: seed (a circular shift), so that each seed puts other residuals under
#: the simulation; 61 is prime to the record's 601 samples
HFB_SHIFT = 61


def hfb_residuals(seed, cm_alpha2=0.0, q_bias=0.0):
    """The real HFB-320 record's residuals from its fit, shifted by seed *
    HFB_SHIFT samples, added to a noise-free simulation of the fitted model
    (with C_m alpha^2 = cm_alpha2 added and a bias q_bias on q): a record
    whose noise is real flight-test noise and model error, coloured
    (Ljung-Box Q in the thousands).  Seed 0 with no effect is the record
    itself."""
    model, data, res = hfb_fit()
    e = data.y - res.yhat
    truth = res.model
    if cm_alpha2:
        regs = {k: list(v) for k, v in truth.regressors.items()}
        vals = {k: list(v) for k, v in truth.coefficients.items()}
        regs["Cm"].append("alpha^2")
        vals["Cm"].append(cm_alpha2)
        truth = mlid.LongitudinalModel(regs, vals, truth.constants, **truth._common())
    yhat = mlid.evaluate(truth, data)["yhat"] if cm_alpha2 else res.yhat
    y = yhat + np.roll(e, seed * HFB_SHIFT % data.nt, axis=0)
    y[:, 3] += q_bias
    return model, mlid.FlightData(data.t, data.u, y, data.input_names, data.output_names,
                                  data.source, data.input_units, data.output_units)


def _longitudinal_alpha2(seed, cm_alpha2):
    """make('nonlinear')'s record (the HFB-like longitudinal model) with C_m
    alpha^2 = cm_alpha2 in the truth."""
    return _longitudinal(seed, cm_alpha2)


def _weak_extended(effect):
    """A weak effect's analysis model with its parameter free (last), at the
    truth without it, and seed 0's record."""
    if effect == "quadratic":
        model, data = _longitudinal(0, 0.0)
        regs = {k: list(v) for k, v in model.regressors.items()}
        vals = {k: list(v) for k, v in model.coefficients.items()}
        regs["Cm"].append("alpha^2")
        vals["Cm"].append(0.0)
        ext = mlid.LongitudinalModel(regs, vals, model.constants, **model._common())
        return ext.with_free(list(model.free) + [f"cm({len(regs['Cm'])})"]), data
    model, data = lateral(0)
    return model.with_free(list(model.free) + [{"bias": "bias(3)", "derivative": "f(3,1)"}[
        effect]]), data


def _last_sigma(model, data):
    return float(np.sqrt(np.linalg.inv(mlid.evaluate(model, data)["information"])[-1, -1]))


@functools.lru_cache(maxsize=None)
def cr_sigma(effect):
    """The Cramer-Rao sigma of a weak effect's parameter (WEAK_EFFECTS: the
    bias on beta, Y_p, C_m alpha^2) in the analysis model with it free, at
    the truth without it, on seed 0's record: the unit of the weak-effect
    curve."""
    return _last_sigma(*_weak_extended(effect))


def heldout_share(effect):
    """The share of a weak effect's information in the part of the record
    the workflow holds out (mlid.discrepancy.holdout's split): 1 - sigma^2
    of the whole record over sigma^2 of the part fitted."""
    from mlid.discrepancy.holdout import Split
    ext, data = _weak_extended(effect)
    head = Split.of(data).head(data)
    return 1.0 - cr_sigma(effect) ** 2 / _last_sigma(ext, head) ** 2


def weak(effect, size, seed):
    """A record whose truth holds a weak effect of size CR sigmas (cr_sigma):
    a bias on beta, Y_p (negative, as make('derivative')'s) or C_m alpha^2
    (negative, as make('nonlinear')'s)."""
    s = size * cr_sigma(effect)
    if effect == "bias":
        return lateral(seed, beta_bias=s)
    if effect == "derivative":
        return lateral(seed, y_p=-s)
    return _longitudinal(seed, -s)


def _catalogue():
    single = [(n, "lateral") for n in ("bias", "derivative", "gust", "delay", "scale", "lag",
                                       "sas", "nonlinear_lateral")]
    single += [("nonlinear", "longitudinal"), ("state_bias", "longitudinal")]
    out = [Scenario(n, "single", axis, [EXPECTED[n]], n, lambda seed, n=n: make(n, seed))
           for n, axis in single]
    lon = [("lon_derivative", ("missing derivative", "M_V"), f"M_V = {M_V} missing",
            dict(m_v=M_V)),
           ("lon_bias", ("output bias", "bias on alpha"), f"bias {ALPHA_BIAS} rad on alpha",
            dict(alpha_bias=ALPHA_BIAS)),
           ("lon_delay", ("input time delay", "delay on delta_e"),
            f"elevator recorded {LON_DELAY} samples ahead", dict(delay=LON_DELAY))]
    out += [Scenario(n, "single", "longitudinal", [e], what,
                     lambda seed, kw=kw: longitudinal(seed, **kw)) for n, e, what, kw in lon]
    pairs = [("two", "lateral", EXPECTED["two"], "bias on beta and aileron delay",
              lambda seed: make("two", seed)),
             ("pair_yp_scale", "lateral", [("missing derivative", "Y_p"),
                                           ("sensor scale factor", "scale factor on p")],
              f"Y_p = {Y_P} and p sensor gain {P_GAIN}",
              lambda seed: lateral(seed, y_p=Y_P, p_gain=P_GAIN)),
             ("pair_nonlinear_bias", "lateral", [EXPECTED["nonlinear_lateral"],
                                                 ("output bias", "bias on r")],
              f"{L_ABS_BETA} |beta|beta and bias {R_BIAS} on r", nonlinear_with_bias),
             ("pair_lag_yp", "lateral", [EXPECTED["lag"], ("missing derivative", "Y_p")],
              f"second-order lag on phi and Y_p = {Y_P}",
              lambda seed: lateral(seed, y_p=Y_P, lag=True)),
             ("lon_pair", "longitudinal", [EXPECTED["state_bias"],
                                           ("input time delay", "delay on delta_e")],
              f"{V_DOT_BIAS} on V-dot and elevator {LON_DELAY} samples ahead",
              lambda seed: longitudinal(seed, v_dot_bias=V_DOT_BIAS, delay=LON_DELAY))]
    out += [Scenario(n, "pair", axis, e, what, f) for n, axis, e, what, f in pairs]
    out += [Scenario("null", "null", "lateral", None, "white noise, another integrator",
                     lambda seed: make("null", seed)),
            Scenario("lon_null", "null", "longitudinal", None, "white noise",
                     lambda seed: longitudinal(seed))]
    out += [Scenario(f"ar1_{phi}", "coloured null", "lateral", None,
                     f"AR(1) noise phi {phi}, another integrator",
                     lambda seed, phi=phi: coloured_null(seed, phi)) for phi in AR1_PHIS]
    out += [Scenario("lon_ar1_0.8", "coloured null", "longitudinal", None,
                     "AR(1) noise phi 0.8", lambda seed: longitudinal(seed, phi=0.8)),
            Scenario("hfb_residuals", "coloured null", "longitudinal", None,
                     "real HFB-320 residuals under the fitted model", hfb_residuals)]
    out += [Scenario("dead_zone", "outside", "lateral", None,
                     f"aileron dead-zone +-{DEAD_ZONE} deg",
                     lambda seed: lateral(seed, outside=True,
                                          surface=lambda a: dead_zone(a, DEAD_ZONE))),
            Scenario("backlash", "outside", "lateral", None, f"aileron backlash {BACKLASH} deg",
                     lambda seed: lateral(seed, outside=True,
                                          surface=lambda a: backlash(a, BACKLASH))),
            Scenario("structural_mode", "outside", "longitudinal", None,
                     f"{MODE_HZ} Hz structural mode on q", lambda seed: longitudinal(
                         seed, mode=True))]
    names = {"bias": ("output bias", "bias on beta"), "derivative": ("missing derivative", "Y_p"),
             "quadratic": ("nonlinear term", "alpha^2 in Cm")}
    out += [Scenario(f"weak_{e}_{k}", "weak", "longitudinal" if e == "quadratic" else "lateral",
                     [names[e]], f"{names[e][1]} at {k} CR sigma",
                     lambda seed, e=e, k=k: weak(e, k, seed))
            for e in WEAK_EFFECTS for k in WEAK_SIZES]
    out += [Scenario("hfb_alpha2", "real", "longitudinal", [("nonlinear term", "alpha^2 in Cm")],
                     f"C_m alpha^2 = {HFB_CM_ALPHA2} under the real residuals",
                     lambda seed: hfb_residuals(seed, cm_alpha2=HFB_CM_ALPHA2)),
            Scenario("hfb_q_bias", "real", "longitudinal", [("output bias", "bias on q")],
                     f"bias {HFB_Q_BIAS} rad/s on q under the real residuals",
                     lambda seed: hfb_residuals(seed, q_bias=HFB_Q_BIAS))]
    return {s.name: s for s in out}


#: the set by name (issue 47 item 8): every kind of KINDS
CATALOGUE = _catalogue()
