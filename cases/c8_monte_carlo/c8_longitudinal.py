"""The C-8 four-state longitudinal model of NASA CR-2200 §8.2.1, in one
place: its matrices, the five short-period unknowns, the sampling, the
input's length and energy, and our reading of the report's measurement
noise line.  Every case that uses the four-state model asks here.

Why the noise reading (README.md, "The noise line"): the OCR shows
".125 .125 .250" for a diagonal of four.  We read u, theta, q: .125 and
alpha: .250, a lost repeat of .125.  That keeps the q : alpha ratio 1 : 2 of
the two-state R of §8.1 (0.02, 0.04), and it reproduces Table 8.1's bound
columns better than the other reading (.125 .125 .25 .25): c8_mc.py
--readings prints both scores.  Values are per sample, in the model's units.
"""

import numpy as np

import mlid

# x = (u, theta, q, alpha), z = x + n (H = I), one input delta_e (§8.2.1)
F0 = np.array([[-0.02, -32.2, 0.0, 33.74], [0.0, 0.0, 1.0, 0.0],
               [0.003, 0.0, -1.588, -0.562], [-0.004, 0.0, 1.0, -0.737]])
G0 = np.array([[0.0], [0.0], [-1.658], [0.005]])
UNKNOWNS = ["f(3,3)", "f(3,4)", "f(4,4)", "g(3,1)", "g(4,1)"]
NAMES = {"f(3,3)": "M_q", "f(3,4)": "M_alpha", "f(4,4)": "Z_alpha", "g(3,1)": "M_delta",
         "g(4,1)": "Z_delta"}
OUTPUTS = ["u", "theta", "q", "alpha"]
R_READINGS = {"u, theta, q .125; alpha .25": np.array([0.125, 0.125, 0.125, 0.25]),
              "u, theta .125; q, alpha .25": np.array([0.125, 0.125, 0.25, 0.25])}
R_SAMPLE = R_READINGS["u, theta, q .125; alpha .25"]      # ours: see the docstring
DT, T, ENERGY = 0.02, 2.0, 58.0                            # §8.2.1: 0.02 s, 2 s, 58.0
DESIGN_VALUES = np.array([F0[2, 2], F0[2, 3], F0[3, 3], G0[2, 0], G0[3, 0]])


def matrices(theta):
    """F and G with the five unknowns (M_q, M_alpha, Z_alpha, M_delta,
    Z_delta) set to theta."""
    F, G = F0.copy(), G0.copy()
    F[2, 2], F[2, 3], F[3, 3], G[2, 0], G[3, 0] = theta
    return F, G


def design(theta=DESIGN_VALUES, r=R_SAMPLE):
    """The input design at theta, with the sampled noise's spectral density
    R dt (the continuous equivalent, eq. 7.11)."""
    F, G = matrices(theta)
    return mlid.InputDesign(F, G, np.eye(4), np.diag(r * DT), UNKNOWNS)


def model(theta=DESIGN_VALUES, r=R_SAMPLE):
    """The identification model at theta: input held over each sample (the
    designed input is a staircase)."""
    F, G = matrices(theta)
    return mlid.LinearModel(F, G, np.eye(4), r=r, free=UNKNOWNS, names=NAMES,
                            input_hold="zoh")


def servo_design(theta, tau, r=R_SAMPLE):
    """§8.3: a first-order servo of time constant tau between the command
    and the elevator, as a fifth (unmeasured) state; the unknowns stay the
    aircraft's (M_delta, Z_delta now couple the servo state)."""
    F, G = matrices(theta)
    Fs = np.zeros((5, 5))
    Fs[:4, :4], Fs[:4, 4], Fs[4, 4] = F, G[:, 0], -1.0 / tau
    Gs = np.zeros((5, 1))
    Gs[4, 0] = 1.0 / tau
    Hs = np.hstack([np.eye(4), np.zeros((4, 1))])
    return mlid.InputDesign(Fs, Gs, Hs, np.diag(r * DT),
                            ["f(3,3)", "f(3,4)", "f(4,4)", "f(3,5)", "f(4,5)"])
