"""Closed forms of the report's input-design examples (§7.4): the reference
the numerical design (mlid.InputDesign) is checked against.

    first_order(T, r)           §7.4.1  x' = -x + theta u, y = x + v
    levadi(a, c, T)             §7.4.2  x' = -x + b u, y = x + v, v coloured,
                                        E{v(t) v(s)} = c exp(-a |t - s|)
    second_order(a1, a2, r, T)  §7.4.3  x1' = a1 x1 + x2 + b1 u,
                                        x2' = a2 x1 + b2 u, y = x1 + v, b1 unknown

Each gives the largest eigenvalue mu of the design operator (max M = mu E,
eq. 7.40, with E = int u^2 dt), its frequencies and the optimal input.  The
derivations are in cases/design_theory/README.md; where they differ from the
report's printed equations, it says so.
"""

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from ..errors import InputError


@dataclass
class ClosedForm:
    """A closed-form optimal input: mu, the frequencies, and
    ``shape(t)``, the input up to its scale (u(0) >= 0)."""
    T: float
    mu: float
    omega: tuple
    shape: object

    def input(self, t, energy=1.0):
        """The optimal input at times t (in [0, T]), scaled to the energy.

        Parameters
        ----------
        t : array_like
        energy : float
            int_0^T u^2 dt.

        Returns
        -------
        ndarray
        """
        x, w = np.polynomial.legendre.leggauss(200)      # exact for these smooth shapes
        e = 0.5 * self.T * np.sum(w * self.shape(0.5 * self.T * (x + 1.0)) ** 2)
        return self.shape(np.asarray(t, dtype=float)) * np.sqrt(energy / e)


def _first_root(f, step, upper):
    """The smallest w in (0, upper] where f changes sign, scanned in steps."""
    grid = np.arange(step, upper + step, step)
    v = f(grid)
    k = np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))
    if len(k) == 0:
        raise InputError("no root of the eigenvalue equation in the range searched")
    return brentq(f, grid[k[0]], grid[k[0] + 1], xtol=1e-15, rtol=1e-15)


def _check(**values):
    for name, v in values.items():
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"{name} must be > 0, got {v}")


def first_order(T, r=1.0):
    """§7.4.1: tan(w T) = -w (eq. 7.54), mu = 1/(r (1 + w^2)), u ~ sin w t +
    w cos w t (eq. 7.55).

    Parameters
    ----------
    T : float
        Length [s].
    r : float
        Spectral density of the measurement noise.

    Returns
    -------
    ClosedForm
    """
    _check(T=T, r=r)
    w = _first_root(lambda w: np.sin(w * T) + w * np.cos(w * T), 1e-3 / T, 2 * np.pi / T)
    return ClosedForm(T, 1.0 / (r * (1.0 + w * w)), (w,),
                      lambda t: np.sin(w * t) + w * np.cos(w * t))


def levadi_mu(a, c, w):
    """Eq. 7.68: mu = (1 + (a^2 - 1)/(1 + w^2))/(2 a c) for the input
    frequency w.

    Parameters
    ----------
    a, c : float
        The noise's autocorrelation c exp(-a |tau|).
    w : float or ndarray

    Returns
    -------
    float or ndarray
    """
    return (1.0 + (a * a - 1.0) / (1.0 + np.asarray(w) ** 2)) / (2.0 * a * c)


def levadi(a, c, T, printed=False):
    """§7.4.2, wide-band noise (a > 1): the input u = A sin(w t + phi),
    phi = atan w (eq. 7.67), w the smallest positive root of the eigenvalue
    equation, mu by eq. 7.68.  We derive tan(w T + phi) = -w/a; the report
    prints +w/a (eq. 7.65): ``printed=True`` solves that one instead.  For
    a < 1 (narrow band) mu grows with w toward its supremum 1/(2ac), which
    no input attains (eq. 7.68).

    Parameters
    ----------
    a, c : float
        The noise's autocorrelation c exp(-a |tau|), a > 1.
    T : float
        Length [s].
    printed : bool
        Solve the report's printed eq. 7.65.

    Returns
    -------
    ClosedForm

    Raises
    ------
    InputError
        a <= 1 (no finite optimal frequency), c or T not > 0.
    """
    _check(a=a, c=c, T=T)
    if a <= 1.0:
        raise InputError(f"a = {a}: for a <= 1 the optimal frequency is infinite (eq. 7.68)")
    s = 1.0 if printed else -1.0

    def eq(w):             # a sin(wT + phi) -+ w cos(wT + phi) = 0, tan = +-w/a
        p = w * T + np.arctan(w)
        return a * np.sin(p) - s * w * np.cos(p)

    w = _first_root(eq, 1e-3 / T, 4 * np.pi / T)
    return ClosedForm(T, float(levadi_mu(a, c, w)), (w,),
                      lambda t: np.sin(w * t + np.arctan(w)))


def second_order_conditions(a1, a2, r, T, w1):
    """The boundary conditions of §7.4.3 on the costate lambda_2 = sum of
    c1 sin w1 t, c2 cos w1 t, c3 sin w2 t, c4 cos w2 t (eq. 7.75), w2 =
    -a2/w1: lambda_2(T) = 0, lambda_2'(T) = 0 (lambda(T) = 0), and the
    sensitivities' start s1(0) = 0, s2(0) = 0 (our eq. 7.77; rows as
    the README derives them).

    Returns
    -------
    ndarray (4, 4), or (len(w1), 4, 4) for an array w1
        The matrix whose determinant vanishes at an eigenvalue.
    inv_mu_r : float
        1/(mu r) = (w1 - w2)^2 + a1^2 (eq. 7.76).
    """
    w2 = -a2 / w1
    imr = (w1 - w2) ** 2 + a1 ** 2
    cols = []
    for w in (w1, w2):
        cols.append([np.sin(w * T), w * np.cos(w * T), -a1 * w, -w ** 3 + (imr - a2) * w])
        cols.append([np.cos(w * T), -w * np.sin(w * T), w * w + a2, -a1 * w * w])
    return np.moveaxis(np.array(cols, dtype=float), (0, 1), (-1, -2)), imr


def second_order(a1, a2, r, T, scan=20000):
    """§7.4.3: the optimal input for b1 of x1' = a1 x1 + x2 + b1 u,
    x2' = a2 x1 + b2 u, y = x1 + v (E{v v} = r delta), a2 < 0: two
    frequencies w1 < sqrt(-a2) < w2, w1 w2 = -a2, the root of the eigenvalue
    equation (our eq. 7.77) with w1 closest below the natural frequency
    (largest mu), 1/(mu r) = (w1 - w2)^2 + a1^2; the input eq. 7.78.

    Parameters
    ----------
    a1, a2 : float
        The model (a2 < 0: a stable oscillatory or real pair).
    r : float
        Spectral density of the measurement noise.
    T : float
        Length [s].
    scan : int
        Grid points of the root scan in (0, sqrt(-a2)).

    Returns
    -------
    ClosedForm
        ``omega`` = (w1, w2).

    Raises
    ------
    InputError
        a2 >= 0, r or T not > 0, no root found.
    """
    _check(r=r, T=T)
    if not a2 < 0:
        raise InputError(f"a2 must be < 0 (natural frequency sqrt(-a2)), got {a2}")
    wn = np.sqrt(-a2)

    def det(w1):
        return np.linalg.det(second_order_conditions(a1, a2, r, T, w1)[0])

    # from the natural frequency down: the first sign change is the largest mu
    grid = wn * (1.0 - np.linspace(1e-9, 1.0 - 1e-6, scan))
    v = np.linalg.det(second_order_conditions(a1, a2, r, T, grid)[0])
    k = np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))
    if len(k) == 0:
        raise InputError("no root of the eigenvalue equation (7.77) found")
    w1 = brentq(det, grid[k[0] + 1], grid[k[0]], xtol=1e-15, rtol=1e-15)
    w2 = -a2 / w1
    mat, imr = second_order_conditions(a1, a2, r, T, w1)
    c = np.linalg.svd(mat)[2][-1]                 # the null vector: c1..c4

    def shape(t):                                 # u = lambda_1/mu ~ -lambda_2' (eq. 7.78)
        u = -(c[0] * w1 * np.cos(w1 * t) - c[1] * w1 * np.sin(w1 * t)
              + c[2] * w2 * np.cos(w2 * t) - c[3] * w2 * np.sin(w2 * t))
        return u * np.sign(-(c[0] * w1 + c[2] * w2))
    return ClosedForm(T, 1.0 / (imr * r), (w1, w2), shape)
