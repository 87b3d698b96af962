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
    """Linear state space  xdot = F x + G u,  y = H x + D u + bias.

    Parameters are named by element, 1-based as in a deck: ``'f(1,2)'``,
    ``'g(3,1)'``, ``'h(i,j)'``, ``'d(i,j)'``, ``'x0(i)'``, ``'bias(i)'``.
    ``free`` lists the names to estimate; ``names`` gives them readable
    labels (``{'f(3,3)': 'M_q'}``) used in reports.
    """

    kind = 1
    iconst = np.zeros(0, dtype=np.int32)
    rconst = np.zeros(0)

    def __init__(self, F, G, H, D=None, x0=None, bias=None, free=(), names=None,
                 input_hold="linear", substeps=1):
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
        if input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be one of {INPUT_HOLDS}, got {input_hold!r}")
        self.nx, self.nu, self.ny = nx, nu, ny
        self.F, self.G, self.H, self.D, self.x0, self.bias = F, G, H, D, x0, bias
        self.input_hold = input_hold
        self.substeps = int(substeps)
        self.names = dict(names or {})
        self.free = [self.canonical_name(n) for n in free]
        dup = {n for n in self.free if self.free.count(n) > 1}
        if dup:
            raise InputError(f"free parameter listed twice: {sorted(dup)[0]}")
        for key in self.names:
            self.canonical_name(key)

    # -- parameter vector ------------------------------------------------
    def _blocks(self):
        return [("f", self.F), ("g", self.G), ("h", self.H), ("d", self.D),
                ("x0", self.x0), ("bias", self.bias)]

    @property
    def theta(self):
        """All parameters [vec F, vec G, vec H, vec D, x0, bias], column-major."""
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
            raise InputError(f"parameter {name!r} does not exist: use f(i,j), g(i,j), h(i,j), "
                             "d(i,j), x0(i) or bias(i)")
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
                           input_hold=self.input_hold, substeps=self.substeps)

    def __repr__(self):
        return (f"LinearModel(nx={self.nx}, nu={self.nu}, ny={self.ny}, "
                f"free={self.free_names()})")
