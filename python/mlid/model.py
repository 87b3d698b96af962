"""Model objects: what the equations are and which parameters are free.

Every model carries its full parameter vector ``theta = [p, x0, bias]``
(model parameters, initial states, output biases) and a list of free
parameter names; the Fortran core sees only flat arrays.
"""

import re

import numpy as np

from .errors import InputError

_ELEMENT = re.compile(r"^\s*([a-z0-9_]+)\s*\(\s*(\d+)\s*(?:,\s*(\d+)\s*)?\)\s*$", re.I)

INPUT_HOLDS = ("linear", "zoh")


class LinearModel:
    """Linear state space with process and measurement noise

        xdot = F x + G u + Gamma w,   y = H x + D u + bias + v,

    w (nw values) held over each sample interval with variances q (diagonal
    Q), v with variances r (diagonal R), cross-covariance S = E{w v'} (nw x ny).

    Parameters are named by element, 1-based as in a deck: ``'f(1,2)'``,
    ``'g(3,1)'``, ``'h(i,j)'``, ``'d(i,j)'``, ``'gamma(i,j)'``, ``'x0(i)'``,
    ``'bias(i)'``, ``'q(i)'``, ``'r(i)'``, ``'s(i,j)'``.  ``free`` lists the
    names to estimate; ``names`` gives them readable labels (``{'f(3,3)':
    'M_q'}``) used in reports; ``ties`` holds parameters equal to a free one
    (``{'f(1,5)': 'f(1,3)'}``).
    """

    kind = 1
    iconst = np.zeros(0, dtype=np.int32)
    rconst = np.zeros(0)

    def __init__(self, F, G, H, D=None, x0=None, bias=None, free=(), names=None,
                 input_hold="linear", substeps=1, Gamma=None, q=None, r=None, S=None,
                 ties=None):
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
        x0 = np.zeros(nx) if x0 is None else np.asarray(x0, dtype=float).ravel()
        bias = np.zeros(ny) if bias is None else np.asarray(bias, dtype=float).ravel()
        if x0.size != nx:
            raise InputError(f"x0 must have {nx} values (one per state), got {x0.size}")
        if bias.size != ny:
            raise InputError(f"bias must have {ny} values (one per output), got {bias.size}")
        Gamma = np.zeros((nx, 0)) if Gamma is None else np.asarray(Gamma, dtype=float)
        if Gamma.ndim == 1:
            Gamma = Gamma.reshape(nx, -1)
        if Gamma.shape[0] != nx:
            raise InputError(f"Gamma must have {nx} rows (one per state), got shape {Gamma.shape}")
        nw = Gamma.shape[1]
        q = np.zeros(nw) if q is None else np.asarray(q, dtype=float).ravel()
        r = np.zeros(ny) if r is None else np.asarray(r, dtype=float).ravel()
        S = np.zeros((nw, ny)) if S is None else np.asarray(S, dtype=float).reshape(nw, ny)
        if q.size != nw:
            raise InputError(f"q must have {nw} values (one per noise input), got {q.size}")
        if r.size != ny:
            raise InputError(f"r must have {ny} values (one per output), got {r.size}")
        if input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be one of {INPUT_HOLDS}, got {input_hold!r}")
        self.nx, self.nu, self.ny, self.nw = nx, nu, ny, nw
        self.F, self.G, self.H, self.D, self.x0, self.bias = F, G, H, D, x0, bias
        self.Gamma, self.q, self.r, self.S = Gamma, q, r, S
        self.input_hold = input_hold
        self.substeps = int(substeps)
        self.names = dict(names or {})
        self.free = [self.canonical_name(n) for n in free]
        dup = {n for n in self.free if self.free.count(n) > 1}
        if dup:
            raise InputError(f"free parameter listed twice: {sorted(dup)[0]}")
        for key in self.names:
            self.canonical_name(key)
        self.ties = {self.canonical_name(a): self.canonical_name(b)
                     for a, b in (ties or {}).items()}
        for a, b in self.ties.items():
            if a in self.free:
                raise InputError(f"parameter {a!r} is both free and tied")
            if b in self.ties:
                raise InputError(f"{a!r} is tied to {b!r}, which is itself tied")

    # -- parameter vector ------------------------------------------------
    def _blocks(self):
        return [("f", self.F), ("g", self.G), ("h", self.H), ("d", self.D),
                ("gamma", self.Gamma), ("x0", self.x0), ("bias", self.bias), ("q", self.q),
                ("r", self.r), ("s", self.S)]

    @property
    def theta(self):
        """All parameters [F, G, H, D, Gamma, x0, bias, q, r, S], matrices column-major."""
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
            raise InputError(f"parameter {name!r} does not exist: use f, g, h, d, gamma, s (i,j) "
                             "or x0, bias, q, r (i)")
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

    def with_theta(self, theta):
        """A copy with the parameter vector replaced."""
        theta = np.asarray(theta, dtype=float)
        parts, k = {}, 0
        for key, a in self._blocks():
            parts[key] = theta[k:k + a.size].reshape(a.shape, order="F")
            k += a.size
        return LinearModel(parts["f"], parts["g"], parts["h"], parts["d"], parts["x0"],
                           parts["bias"], free=self.free, names=self.names,
                           input_hold=self.input_hold, substeps=self.substeps,
                           Gamma=parts["gamma"], q=parts["q"], r=parts["r"], S=parts["s"],
                           ties=self.ties)

    def with_free(self, free, names=None):
        """A copy with another free set (and labels, if given)."""
        m = self.with_theta(self.theta)
        m.free = [m.canonical_name(n) for n in free]
        if names is not None:
            m.names = dict(names)
        return m

    def __repr__(self):
        return (f"LinearModel(nx={self.nx}, nu={self.nu}, ny={self.ny}, nw={self.nw}, "
                f"free={self.free_names()})")
