"""A synthetic campaign with hidden tables, for the two-step table fit
(tests/test_table_fit.py, benchmarks/bench_table_fit.py) and the one-step
global fit (tests/test_global_fit.py, benchmarks/bench_global_fit.py).

Each manoeuvre is a short-period record (states alpha, q; elevator 3-2-1-1;
alpha and q measured, with the trim alpha as the alpha vane's offset) at its
own flight condition (alpha_trim, Mach).  The truth's M_alpha is a table
over (alpha, Mach) and M_q one over alpha, both nonlinear in alpha: the
local model is linear with constant derivatives, fitted per manoeuvre with
its output biases free, from a start off the truth (START; the vane's
offset at 0 where it is free).  A faulty manoeuvre is fitted with the vane's
offset held at the deck's alpha_trim while the vane reads 0.01 rad more
(a wrong sensor bias), or flies with a M_alpha 30 % off the table (a wrong
derivative: a configuration the deck does not say).

The global model is the same aircraft written as equations with the five
derivatives tables over the manoeuvre's condition (alpha_trim, Mach: inputs
constant over a manoeuvre), started off the truth.
"""

import numpy as np

import mlid
from mlid.design.signals import input_signal
from mlid.model.tables import Table

NAMES = {"f(1,1)": "Z_alpha", "f(2,1)": "M_alpha", "f(2,2)": "M_q", "g(1,1)": "Z_de",
         "g(2,1)": "M_de"}
FREE = list(NAMES) + ["bias(1)", "bias(2)"]
Z_ALPHA, Z_DE, M_DE = -1.2, -0.1, -6.0

BA = [0.0, 0.06, 0.12, 0.18]              # alpha [rad]
BM = [0.3, 0.7]                           # Mach
SHAPE_A = np.array([-4.0, -3.0, -1.6, -1.1])
MA_TRUTH = np.outer(SHAPE_A, [1.0, 1.32])            # M_alpha[i, j] at (BA[i], BM[j]) [1/s^2]
BQ = [0.0, 0.09, 0.18]
MQ_TRUTH = np.array([-1.2, -1.8, -1.5])              # M_q [1/s]
VANE_BIAS = 0.03                                     # rad: the faulty manoeuvre's
DERIVATIVE_ERROR = 1.1                               # the faulty M_alpha's factor

DT, NT = 0.02, 500
NOISE = [0.002, 0.004]                               # alpha [rad], q [rad/s]


def tables(extra_q_breakpoint=None):
    """The tables to fit (their breakpoints; the values are the fit's):
    M_alpha and M_q as the truth's, the constant derivatives as straight
    lines in alpha (a test of their constancy)."""
    bq = BQ + ([extra_q_breakpoint] if extra_q_breakpoint is not None else [])
    lines = {n: Table("alpha", [BA[0], BA[-1]]) for n in ("Z_alpha", "Z_de", "M_de")}
    return {"M_alpha": Table(["alpha", "Mach"], [BA, BM]), "M_q": Table("alpha", bq), **lines}


def lookup(bps, values, point):
    """Multilinear interpolation on the breakpoints (the reference)."""
    out = np.asarray(values, dtype=float)
    for b, v in zip(bps, point):
        i = min(np.searchsorted(b, v, side="right") - 1, len(b) - 2)
        f = (v - b[i]) / (b[i + 1] - b[i])
        w = np.zeros(len(b))
        w[i], w[i + 1] = 1 - f, f
        out = np.tensordot(w, out, axes=(0, 0))
    return float(out)


def truth_at(alpha, mach):
    """The true (M_alpha, M_q) at a condition."""
    return lookup([BA, BM], MA_TRUTH, [alpha, mach]), lookup([BQ], MQ_TRUTH, [alpha])


def grid(n_alpha, machs):
    """Conditions {alpha, Mach}: n_alpha values over [0, 0.18] at each Mach."""
    return [{"alpha": float(a), "Mach": float(m)} for m in machs
            for a in np.linspace(BA[0], BA[-1], n_alpha)]


#: Start values of the fits (the global tables' and the local fits'): off
#: the truth's (MA_TRUTH, MQ_TRUTH, Z_ALPHA, Z_DE, M_DE) by 20 % or more.
START = {"M_alpha": -2.0, "M_q": -1.0, "Z_alpha": -1.0, "Z_de": -0.2, "M_de": -5.0}


def model(m_alpha, m_q, alpha_trim, free=FREE, z_alpha=Z_ALPHA, z_de=Z_DE, m_de=M_DE):
    """The linear short period (the truth's Z_alpha, Z_de, M_de unless given)."""
    F = [[z_alpha, 1.0], [m_alpha, m_q]]
    return mlid.LinearModel(F, [[z_de], [m_de]], np.eye(2), bias=[alpha_trim, 0.0],
                            free=list(free), names=NAMES)


def local_model(cond, free=FREE):
    """The local model to fit at cond, started off the truth: START's
    derivatives, the vane's offset at 0 where it is free (the deck's
    alpha_trim where it is held)."""
    vane = 0.0 if "bias(1)" in free else cond["alpha"]
    return model(START["M_alpha"], START["M_q"], vane, free, START["Z_alpha"], START["Z_de"],
                 START["M_de"])


def record(cond, seed, fault=None):
    """A manoeuvre's record at cond (fault 'derivative': its M_alpha off)."""
    ma, mq = truth_at(cond["alpha"], cond["Mach"])
    if fault == "derivative":
        ma *= DERIVATIVE_ERROR
    vane = cond["alpha"] + (VANE_BIAS if fault == "bias" else 0.0)
    t = np.arange(NT) * DT
    u = input_signal("3211", 0.02, 0.4, 1.0, DT, NT)[:, None]
    return mlid.simulate(model(ma, mq, vane), t, u, noise_std=NOISE, seed=seed,
                         input_names=["de"], output_names=["alpha", "q"])[0]


def local_fit(cond, seed, fault=None):
    """The manoeuvre's own fit from a start off the truth (local_model);
    with fault 'bias' the vane's offset is held at the deck's alpha_trim."""
    d = record(cond, seed, fault)
    free = [f for f in FREE if f != "bias(1)"] if fault == "bias" else FREE
    return mlid.fit(local_model(cond, free), d)


def campaign(conds, seed, faults=None):
    """The local fits of a campaign (manoeuvre k's record from seed
    1000 seed + k); faults {k: 'bias' or 'derivative'}."""
    faults = faults or {}
    return [local_fit(c, 1000 * seed + k, faults.get(k)) for k, c in enumerate(conds)]


def true_values(tabs):
    """The true table values in the fit's order (NaN where the truth has
    none: a breakpoint outside the truth's)."""
    out = list(MA_TRUTH.ravel(order="F"))
    bq = tabs["M_q"].breakpoints[0]
    out += [lookup([BQ], MQ_TRUTH, [b]) if b <= BQ[-1] else np.nan for b in bq]
    return np.array(out + [Z_ALPHA] * 2 + [Z_DE] * 2 + [M_DE] * 2)


# ---- the one-step global fit -------------------------------------------------------------

#: The global model's table variables and the conditions' names of them.
VARIABLES = {"alpha_trim": "alpha", "Mach": "Mach"}


def global_tables(extra_q_breakpoint=None):
    """tables() over the global model's variables: alpha_trim for alpha."""
    out = {}
    for name, tab in tables(extra_q_breakpoint).items():
        variables = ["alpha_trim" if v == "alpha" else v for v in tab.variables]
        out[name] = Table(variables, tab.breakpoints)
    return out


def global_model(free_vane_bias=True, corrections=0, extra_q_breakpoint=None):
    """The short period with its derivatives tables over (alpha_trim, Mach),
    every table value free and started at START; the alpha vane reads
    alpha_trim + alpha (+ its own bias, free unless free_vane_bias is
    False: the vane's offset known), q its own bias free.  corrections = n:
    each of n manoeuvres its own scale-factor error k_alpha of the vane (a
    table over the manoeuvre's number)."""
    defs = {name: Table(tab.variables, tab.breakpoints, np.full(tab.shape, START[name]))
            for name, tab in global_tables(extra_q_breakpoint).items()}
    vane = "alpha + alpha_trim"
    if corrections:
        defs["k_alpha"] = Table("manoeuvre", np.arange(1.0, corrections + 1))
        vane = "(1 + k_alpha)*alpha + alpha_trim"
    free = [n for name, tab in defs.items() for n in tab.value_names(name)]
    free += (["bias(1)"] if free_vane_bias else []) + ["bias(2)"]
    return mlid.EquationModel(
        {"alpha_m": vane, "q_m": "q"},
        states={"alpha": "Z_alpha*alpha + q + Z_de*de", "q": "M_alpha*alpha + M_q*q + M_de*de"},
        inputs=["de", "alpha_trim", "Mach"] + (["manoeuvre"] if corrections else []),
        definitions=defs, free=free)


def local_equation_model(cond):
    """The local model of local_fit written as equations (the global
    model's kind, constant derivatives), started as local_model (START, the
    vane's offset at 0): the benchmark's like-for-like baseline."""
    names = dict(START)
    return mlid.EquationModel(
        {"alpha_m": "alpha", "q_m": "q"},
        states={"alpha": "Z_alpha*alpha + q + Z_de*de", "q": "M_alpha*alpha + M_q*q + M_de*de"},
        inputs=["de"], params=names, bias=[0.0, 0.0],
        free=list(names) + ["bias(1)", "bias(2)"])


def global_truth(tabs):
    """The true values of global_tables in the fit's order (true_values)."""
    return true_values({"M_q": Table("alpha", tabs["M_q"].breakpoints)})
