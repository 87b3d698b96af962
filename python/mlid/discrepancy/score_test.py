"""The score (Lagrange-multiplier) test of parameters a model might be
missing, from one evaluation of the model extended by them at their null
value: no fit.  For each extra parameter c, with the model's free
parameters t partialled out,

    score = (g_c - M_ct M_tt^-1 g_t)^2 / (M_cc - M_ct M_tt^-1 M_tc),

asymptotically chi-square(1) when c is absent (g_t ~ 0 at the base fit).
Several extras from one evaluation give each one's own statistic: at the
null the model is the base one, and each extra's entries of the gradient
and information are those it would have alone.
"""

import numpy as np


def statistics(gradient, information, base, extra):
    """The score statistic of each extra parameter and the share of its
    information left once the base parameters are partialled out.

    Parameters
    ----------
    gradient : ndarray (nf,)
    information : ndarray (nf, nf)
        Of the extended model at the extras' null values.
    base, extra : sequence of int
        Indices of the model's own free parameters and of the extras.

    Returns
    -------
    score : ndarray (len(extra),)
        The statistics; 0 where nothing is left.
    left : ndarray (len(extra),)
        Each extra's information left over its own (1: orthogonal to the
        base, 0: spanned by it).
    signed : ndarray (len(extra),)
        The partialled gradient g_c - M_ct M_tt^-1 g_t (its sign says
        which way the cost falls).
    """
    g, M = np.asarray(gradient), np.asarray(information)
    b, e = list(base), list(extra)
    rhs = np.column_stack([M[np.ix_(b, e)], g[b]])
    if b:
        try:
            x = np.linalg.solve(M[np.ix_(b, b)], rhs)
        except np.linalg.LinAlgError:
            x = np.linalg.lstsq(M[np.ix_(b, b)], rhs, rcond=None)[0]
    else:
        x = np.zeros_like(rhs)
    mee = M[e, e]
    rest = mee - np.einsum("be,be->e", M[np.ix_(b, e)], x[:, :-1])
    signed = g[e] - M[np.ix_(e, b)] @ x[:, -1]
    share = np.where(mee > 0, rest / np.where(mee > 0, mee, 1.0), 0.0)
    score = np.where(rest > 0, signed**2 / np.where(rest > 0, rest, 1.0), 0.0)
    return score, share, signed


def corrected(gradient, information, meat, base, extra):
    """The score statistic of each extra parameter with the partialled
    gradient's variance taken from the meat B (the information's sandwich
    middle under coloured residuals: the core's mlid_colored bracket,
    sum_i sum_j a(i)' w(|i-j|) Rvv(i-j) a(j), plus M - Ms) instead of the
    information M:

        score_c = (g_c - M_ct M_tt^-1 g_t)^2 / (l' B l),  l = (-M_tt^-1 M_tc, 1),

    asymptotically chi-square(1) when c is absent whatever the residuals'
    colour (the generalised score test); equal to ``statistics``' score
    when B = M (white residuals).

    Parameters
    ----------
    gradient : ndarray (nf,)
    information, meat : ndarray (nf, nf)
    base, extra : sequence of int

    Returns
    -------
    ndarray (len(extra),)
        The statistics; 0 where the variance is not positive.
    """
    g, M, B = np.asarray(gradient), np.asarray(information), np.asarray(meat)
    b, e = list(base), list(extra)
    x = np.zeros((len(b), len(e)))
    y = np.zeros(len(b))
    if b:
        rhs = np.column_stack([M[np.ix_(b, e)], g[b]])
        try:
            sol = np.linalg.solve(M[np.ix_(b, b)], rhs)
        except np.linalg.LinAlgError:
            sol = np.linalg.lstsq(M[np.ix_(b, b)], rhs, rcond=None)[0]
        x, y = sol[:, :-1], sol[:, -1]
    signed = g[e] - M[np.ix_(e, b)] @ y
    # l' B l = B_cc - 2 x_c' B_tc + x_c' B_tt x_c, for each extra c
    var = (B[e, e] - 2.0 * np.einsum("be,be->e", B[np.ix_(b, e)], x)
           + np.einsum("be,bk,ke->e", x, B[np.ix_(b, b)], x))
    return np.where(var > 0, signed**2 / np.where(var > 0, var, 1.0), 0.0)
