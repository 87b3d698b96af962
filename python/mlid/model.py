"""Model objects: what the equations are and which parameters are free.

Every model carries its full parameter vector

    theta = [p, x0, bias, q, r, S]

(model parameters, initial states, output biases, process- and
measurement-noise variances, their cross-covariance) and a list of free
parameter names; the Fortran core sees only flat arrays.  Parameters are
named by element, 1-based as in a deck: ``'f(1,2)'``, ``'x0(3)'``,
``'r(2)'``, ``'cm(4)'``.
"""

import re

import numpy as np

from .errors import InputError

_ELEMENT = re.compile(r"^\s*([a-z0-9_]+)\s*\(\s*(\d+)\s*(?:,\s*(\d+)\s*)?\)\s*$", re.I)

INPUT_HOLDS = ("linear", "zoh")


class Model:
    """What every model shares: the generic blocks of theta and the free,
    tied and labelled parameters.  Subclasses define kind, iconst, rconst,
    _model_blocks() and _from_parts()."""

    kind = 0

    def _init_common(self, nx, nu, ny, nw, x0, bias, q, r, S, free, names, ties, input_hold,
                     substeps):
        x0 = np.zeros(nx) if x0 is None else np.asarray(x0, dtype=float).ravel()
        bias = np.zeros(ny) if bias is None else np.asarray(bias, dtype=float).ravel()
        q = np.zeros(nw) if q is None else np.asarray(q, dtype=float).ravel()
        r = np.zeros(ny) if r is None else np.asarray(r, dtype=float).ravel()
        S = np.zeros((nw, ny)) if S is None else np.asarray(S, dtype=float).reshape(nw, ny)
        for key, a, n in (("x0", x0, nx), ("bias", bias, ny), ("q", q, nw), ("r", r, ny)):
            if a.size != n:
                raise InputError(f"{key} must have {n} values, got {a.size}")
        if input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be one of {INPUT_HOLDS}, got {input_hold!r}")
        self.nx, self.nu, self.ny, self.nw = nx, nu, ny, nw
        self.x0, self.bias, self.q, self.r, self.S = x0, bias, q, r, S
        self.input_hold = input_hold
        self.substeps = int(substeps)
        self.names = dict(names or {})
        self.free = [self.canonical_name(n) for n in free]
        dup = {n for n in self.free if self.free.count(n) > 1}
        if dup:
            raise InputError(f"free parameter listed twice: {sorted(dup)[0]}")
        self.names = {self.canonical_name(k): v for k, v in self.names.items()}
        self.ties = {self.canonical_name(a): self.canonical_name(b)
                     for a, b in (ties or {}).items()}
        for a, b in self.ties.items():
            if a in self.free:
                raise InputError(f"parameter {a!r} is both free and tied")
            if b in self.ties:
                raise InputError(f"{a!r} is tied to {b!r}, which is itself tied")

    def _common(self):
        """Keyword arguments that carry the generic parts to a copy."""
        return dict(x0=self.x0, bias=self.bias, q=self.q, r=self.r, S=self.S, free=self.free,
                    names=self.names, ties=self.ties, input_hold=self.input_hold,
                    substeps=self.substeps)

    # -- parameter vector ------------------------------------------------
    def _blocks(self):
        return self._model_blocks() + [("x0", self.x0), ("bias", self.bias), ("q", self.q),
                                       ("r", self.r), ("s", self.S)]

    @property
    def np(self):
        """Number of model parameters p (theta before x0 and the noise blocks)."""
        return sum(a.size for _, a in self._model_blocks())

    @property
    def theta(self):
        """All parameters, in the core's order; matrices column-major."""
        return np.concatenate([a.ravel(order="F") for _, a in self._blocks()])

    def element_names(self):
        """The element name of every entry of theta, in order."""
        out = []
        for key, a in self._blocks():
            if a.ndim == 2:
                out += [f"{key}({i + 1},{j + 1})" for j in range(a.shape[1])
                        for i in range(a.shape[0])]
            else:
                out += [f"{key}({i + 1})" for i in range(a.size)]
        return out

    def canonical_name(self, name):
        """The element name of a parameter, checked against the dimensions."""
        m = _ELEMENT.match(str(name))
        blocks = dict(self._blocks())
        if not m or m.group(1).lower() not in blocks:
            raise InputError(f"parameter {name!r} does not exist: use "
                             + ", ".join(f"{k}(i,j)" if a.ndim == 2 else f"{k}(i)"
                                         for k, a in self._blocks()))
        key, i = m.group(1).lower(), int(m.group(2))
        a = blocks[key]
        if a.ndim == 2:
            if m.group(3) is None:
                raise InputError(f"parameter {name!r} needs two indices: {key}(i,j)")
            j = int(m.group(3))
            if not (1 <= i <= a.shape[0] and 1 <= j <= a.shape[1]):
                raise InputError(f"parameter {name!r} does not exist: {key.upper()} is "
                                 f"{a.shape[0]}x{a.shape[1]}")
            return f"{key}({i},{j})"
        if m.group(3) is not None or not 1 <= i <= a.size:
            raise InputError(f"parameter {name!r} does not exist: {key} has {a.size} entries")
        return f"{key}({i})"

    @property
    def free_mask(self):
        names = self.element_names()
        mask = np.zeros(len(names), dtype=np.int32)
        for n in self.free:
            mask[names.index(n)] = 1
        return mask

    @property
    def tie_index(self):
        """For the core: 1-based index of the parameter each entry is tied to, else 0."""
        names = self.element_names()
        tie = np.zeros(len(names), dtype=np.int32)
        for a, b in self.ties.items():
            tie[names.index(a)] = names.index(b) + 1
        return tie

    def free_names(self):
        """Readable labels of the free parameters, in theta order."""
        return [self.names.get(n, n) for n, f in zip(self.element_names(), self.free_mask) if f]

    def value(self, name):
        """The value of one parameter, by element name or label."""
        labels = {v: k for k, v in self.names.items()}
        key = self.canonical_name(labels.get(name, name))
        return float(self.theta[self.element_names().index(key)])

    def with_theta(self, theta):
        """A copy with the parameter vector replaced."""
        theta = np.asarray(theta, dtype=float)
        parts, k = {}, 0
        for key, a in self._blocks():
            parts[key] = theta[k:k + a.size].reshape(a.shape, order="F")
            k += a.size
        common = self._common()
        common.update(x0=parts.pop("x0"), bias=parts.pop("bias"), q=parts.pop("q"),
                      r=parts.pop("r"), S=parts.pop("s"))
        return self._from_parts(parts, common)

    def with_free(self, free, names=None):
        """A copy with another free set (and labels, if given)."""
        m = self.with_theta(self.theta)
        m.free = [m.canonical_name(n) for n in free]
        if names is not None:
            m.names = {m.canonical_name(k): v for k, v in names.items()}
        return m

    def __repr__(self):
        return (f"{type(self).__name__}(nx={self.nx}, nu={self.nu}, ny={self.ny}, nw={self.nw}, "
                f"free={self.free_names()})")


class LinearModel(Model):
    """Linear state space with process and measurement noise

        xdot = F x + G (u + K x) + Gamma w,   y = H x + D (u + K x) + bias + v,

    w (nw values) held over each sample interval with variances q (diagonal
    Q), v with variances r (diagonal R), cross-covariance S = E{w v'} (nw x ny).

    K (nu x nx, zero unless given) feeds states back to the inputs: a
    stability augmentation system moving the surfaces on top of the
    recorded command.

    Model parameters: ``'f(i,j)'``, ``'g(i,j)'``, ``'h(i,j)'``, ``'d(i,j)'``,
    ``'gamma(i,j)'``, ``'k(j,s)'``; ``names`` gives readable labels (``{'f(3,3)': 'M_q'}``);
    ``ties`` holds parameters equal to a free one (``{'f(1,5)': 'f(1,3)'}``).
    """

    kind = 1
    iconst = np.zeros(0, dtype=np.int32)
    rconst = np.zeros(0)

    def __init__(self, F, G, H, D=None, x0=None, bias=None, free=(), names=None,
                 input_hold="linear", substeps=1, Gamma=None, q=None, r=None, S=None,
                 ties=None, K=None):
        F = np.atleast_2d(np.asarray(F, dtype=float))
        nx = F.shape[0]
        if F.shape != (nx, nx):
            raise InputError(f"F must be square, got shape {F.shape}")
        G = np.asarray(G, dtype=float)
        if G.ndim == 1:
            G = G.reshape(nx, -1)
        H = np.atleast_2d(np.asarray(H, dtype=float))
        if G.shape[0] != nx:
            raise InputError(f"G must have {nx} rows (one per state), got shape {G.shape}")
        if H.shape[1] != nx:
            raise InputError(f"H must have {nx} columns (one per state), got shape {H.shape}")
        nu, ny = G.shape[1], H.shape[0]
        D = np.zeros((ny, nu)) if D is None else np.asarray(D, dtype=float).reshape(ny, nu)
        Gamma = np.zeros((nx, 0)) if Gamma is None else np.asarray(Gamma, dtype=float)
        if Gamma.ndim == 1:
            Gamma = Gamma.reshape(nx, -1)
        if Gamma.shape[0] != nx:
            raise InputError(f"Gamma must have {nx} rows (one per state), got shape {Gamma.shape}")
        K = np.zeros((nu, nx)) if K is None else np.asarray(K, dtype=float)
        if K.size != nu * nx:
            raise InputError(f"K must be {nu}x{nx} (inputs x states), got shape {K.shape}")
        K = K.reshape(nu, nx)
        self.F, self.G, self.H, self.D, self.Gamma, self.K = F, G, H, D, Gamma, K
        self._init_common(nx, nu, ny, Gamma.shape[1], x0, bias, q, r, S, free, names, ties,
                          input_hold, substeps)

    def _model_blocks(self):
        return [("f", self.F), ("g", self.G), ("h", self.H), ("d", self.D),
                ("gamma", self.Gamma), ("k", self.K)]

    def _from_parts(self, parts, common):
        return LinearModel(parts["f"], parts["g"], parts["h"], parts["d"],
                           Gamma=parts["gamma"], K=parts["k"], **common)


#: Regressors of the longitudinal model (fortran/mlid_aero_long.f90), by name,
#: with the suffix of the coefficient names they give (C_D0, C_Lalpha, C_mq, ...).
REGRESSORS = {"1": "0", "V/V0": "V", "alpha": "alpha", "alpha^2": "alpha2", "qhat": "q",
              "de": "de"}
#: Its constants, in the core's order.
CONSTANTS = ("g", "S/m", "S cbar/Iy", "lT/Iy", "V0", "m", "sigma_T", "rho", "cbar/2")


class LongitudinalModel(Model):
    """Nonlinear longitudinal aircraft model (states V, alpha, theta, q;
    inputs delta_e, thrust; outputs V, alpha, theta, q, qdot, a_x, a_z) whose
    C_D, C_L, C_m are linear in their coefficients over named regressors
    (``REGRESSORS``); the equations are in fortran/mlid_aero_long.f90.

    regressors: {'CD': ['1', 'V/V0', 'alpha'], 'CL': [...], 'Cm': [...]}
    coefficients: {'CD': [values], ...} (start values, same order)
    constants: {name: value} for every name in ``CONSTANTS``
    Model parameters are ``'cd(k)'``, ``'cl(k)'``, ``'cm(k)'``, labelled
    C_D0, C_DV, C_Dalpha, ... unless ``names`` says otherwise.
    """

    kind = 2

    def __init__(self, regressors, coefficients, constants, x0=None, bias=None, free=(),
                 names=None, input_hold="linear", substeps=1, r=None, ties=None, q=None, S=None):
        self.regressors = {k: list(regressors.get(k, [])) for k in ("CD", "CL", "Cm")}
        unknown = set(regressors) - set(self.regressors)
        if unknown:
            raise InputError(f"unknown coefficient {sorted(unknown)[0]!r}: use CD, CL, Cm")
        for key, regs in self.regressors.items():
            for reg in regs:
                if reg not in REGRESSORS:
                    raise InputError(f"regressor {reg!r} does not exist (in {key}): use "
                                     + ", ".join(REGRESSORS))
        self.coefficients = {}
        for key, regs in self.regressors.items():
            vals = np.asarray(coefficients.get(key, np.zeros(len(regs))), dtype=float).ravel()
            if vals.size != len(regs):
                raise InputError(f"{key} has {len(regs)} regressors but {vals.size} values")
            self.coefficients[key] = vals
        missing = [c for c in CONSTANTS if c not in constants]
        if missing:
            raise InputError(f"missing constant {missing[0]!r} (need {', '.join(CONSTANTS)})")
        self.constants = {c: float(constants[c]) for c in CONSTANTS}
        labels = {}
        for key, block in (("CD", "cd"), ("CL", "cl"), ("Cm", "cm")):
            for k, reg in enumerate(self.regressors[key]):
                labels[f"{block}({k + 1})"] = f"C_{key[1]}{REGRESSORS[reg]}"
        labels.update(names or {})
        # process noise (q, 4 variances) adds to each state equation: turbulence
        self._init_common(4, 2, 7, 4, x0, bias, q, r, S, free, labels, ties, input_hold,
                          substeps)

    @property
    def iconst(self):
        codes = list(REGRESSORS)
        regs = [self.regressors[k] for k in ("CD", "CL", "Cm")]
        return np.array([len(r) for r in regs] + [codes.index(x) + 1 for r in regs for x in r],
                        dtype=np.int32)

    @property
    def rconst(self):
        return np.array([self.constants[c] for c in CONSTANTS])

    def _model_blocks(self):
        return [("cd", self.coefficients["CD"]), ("cl", self.coefficients["CL"]),
                ("cm", self.coefficients["Cm"])]

    def _from_parts(self, parts, common):
        return LongitudinalModel(self.regressors, {"CD": parts["cd"], "CL": parts["cl"],
                                                   "Cm": parts["cm"]}, self.constants, **common)


class UserModel(Model):
    """The user's own Fortran model (fortran/mlid_user_model.f90, compiled into
    the core): p holds its np parameters, named ``'p(k)'``; iconst and rconst
    its constants.  Its sizes come from the core."""

    kind = 3

    def __init__(self, p, iconst=(), rconst=(), x0=None, bias=None, free=(), names=None,
                 input_hold="linear", substeps=1, q=None, r=None, S=None, ties=None):
        from . import _core
        self.iconst = np.asarray(iconst, dtype=np.int32).ravel()
        self.rconst = np.asarray(rconst, dtype=float).ravel()
        nx, nu, ny, nw, npar, status, msg = _core.mlid_api.mlid_model_sizes(
            mkind=self.kind, iconst=self.iconst, rconst=self.rconst)
        if status:
            raise InputError(msg.decode(errors="replace").strip())
        self.p = np.asarray(p, dtype=float).ravel()
        if self.p.size != npar:
            raise InputError(f"the user model has {npar} parameters p, got {self.p.size} values")
        self._init_common(nx, nu, ny, nw, x0, bias, q, r, S, free, names, ties, input_hold,
                          substeps)

    def _model_blocks(self):
        return [("p", self.p)]

    def _from_parts(self, parts, common):
        return UserModel(parts["p"], self.iconst, self.rconst, **common)


#: The X-22's 23 coefficients (report Appendix A): each derivative's polynomial
#: in u by rising power, labelled e.g. M_o, M_o.u, M_o.u2.
X22_DERIVATIVES = (("M_o", 3), ("M_w", 2), ("M_q", 2), ("M_de", 2), ("X_o", 3), ("X_w", 2),
                   ("X_de", 2), ("Z_o", 3), ("Z_w", 2), ("Z_de", 2))
X22_LABELS = tuple(f"{d}{('', '.u', '.u2')[k]}" for d, n in X22_DERIVATIVES for k in range(n))


class X22Model(Model):
    """X-22 VTOL longitudinal model of report Appendix A
    (fortran/mlid_x22.f90): states u, w [ft/s], theta [rad], q [rad/s];
    input delta_es; outputs u, w, theta, q, qdot, n_x, n_z [g]; gusts v1, v2
    [ft/s], v3 [rad/s] (variances q) entering through dA/d(u, w, q) and
    carried by qdot, n_x and n_z.  p: the 23 coefficients of X22_LABELS,
    named ``'p(k)'`` and labelled by X22_LABELS."""

    kind = 4

    def __init__(self, p, x0=None, bias=None, free=(), names=None, input_hold="linear",
                 substeps=1, q=None, r=None, S=None, ties=None):
        self.p = np.asarray(p, dtype=float).ravel()
        if self.p.size != len(X22_LABELS):
            raise InputError(f"the X-22 model has {len(X22_LABELS)} coefficients, got "
                             f"{self.p.size}")
        labels = {f"p({k + 1})": n for k, n in enumerate(X22_LABELS)}
        labels.update(names or {})
        self._init_common(4, 1, 7, 3, x0, bias, q, r, S, free, labels, ties, input_hold,
                          substeps)

    iconst = np.zeros(0, dtype=np.int32)
    rconst = np.zeros(0)

    def _model_blocks(self):
        return [("p", self.p)]

    def _from_parts(self, parts, common):
        return X22Model(parts["p"], **common)


def from_core(mkind, sizes, iconst, rconst, theta, isfree, itie, labels, input_hold, substeps):
    """The model a case spec of the core describes (kind, sizes (nx, nu, ny,
    nw), constants, the whole theta with free flags, ties and the free
    parameters' labels); the core has read and checked it."""
    nx, nu, ny, nw = sizes
    z = np.zeros
    if mkind == LinearModel.kind:
        proto = LinearModel(z((nx, nx)), z((nx, nu)), z((ny, nx)), Gamma=z((nx, nw)))
    elif mkind == LongitudinalModel.kind:
        codes, n = list(REGRESSORS), iconst[:3]
        regs = [codes[c - 1] for c in iconst[3:]]
        split = {"CD": regs[:n[0]], "CL": regs[n[0]:n[0] + n[1]], "Cm": regs[n[0] + n[1]:]}
        proto = LongitudinalModel(split, {}, dict(zip(CONSTANTS, rconst)))
    elif mkind == UserModel.kind:
        proto = UserModel(z(len(theta) - (nx + 2 * ny + nw + nw * ny)), iconst, rconst)
    else:
        proto = X22Model(z(len(X22_LABELS)))
    model = proto.with_theta(theta)
    names = model.element_names()
    free = [names[k] for k in np.flatnonzero(isfree)]
    model.free = free
    model.names.update(zip(free, labels))
    model.ties = {names[k]: names[itie[k] - 1] for k in np.flatnonzero(itie)}
    model.input_hold, model.substeps = input_hold, int(substeps)
    return model
