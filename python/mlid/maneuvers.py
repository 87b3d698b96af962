"""Several manoeuvres fitted together: the parameter vector the core sees
and the joined record.

The model's parameters are shared by every manoeuvre except the initial
state and the output biases, which each manoeuvre has of its own: the core's
x0 and bias blocks are repeated once per manoeuvre (fortran/mlid_models.f90,
layout_t).  A manoeuvre's own entries are named like the model's with the
manoeuvre number after '#', e.g. 'x0(1)#2' or 'V0#2'.
"""

import numpy as np

from .data import FlightData
from .errors import InputError


class Params:
    """The core's parameter vector for a model on n manoeuvres."""

    def __init__(self, model, n=1, initial_states=None, biases=None):
        self.model, self.n = model, n
        names = model.element_names()
        theta, mask, tie = model.theta, model.free_mask, model.tie_index
        np_, nx, ny = model.np, model.nx, model.ny
        self.shared_head = slice(0, np_)
        self.rest = slice(np_ + nx + ny, len(theta))
        x0s = self._per_manoeuvre(initial_states, model.x0, nx, "initial_states")
        biases = self._per_manoeuvre(biases, model.bias, ny, "biases")
        if n > 1:
            own = set(range(np_, np_ + nx + ny))
            if any(t and (k in own or t - 1 in own) for k, t in enumerate(tie)):
                raise InputError("ties to or from initial states and biases are not available "
                                 "with several manoeuvres")
        self.theta = np.concatenate([theta[:np_], *x0s, *biases, theta[self.rest]])
        x0_mask, bias_mask = mask[np_:np_ + nx], mask[np_ + nx:np_ + nx + ny]
        self.mask = np.concatenate([mask[:np_], np.tile(x0_mask, n), np.tile(bias_mask, n),
                                    mask[self.rest]]).astype(np.int32)
        # ties keep to the shared blocks; entries after the repeated blocks move
        shift = (n - 1) * (nx + ny)
        moved = np.where(tie > np_ + nx + ny, tie + shift, tie)
        self.tie = np.concatenate([moved[:np_], np.zeros(n * (nx + ny), dtype=np.int32),
                                   moved[self.rest]]).astype(np.int32)
        label = [model.names.get(e, e) for e in names]
        own_el, own_lab = names[np_:np_ + nx + ny], label[np_:np_ + nx + ny]

        def repeat(items):
            if n == 1:
                return items
            return [f"{a}#{k + 1}" for k in range(n) for a in items]

        self.elements = (names[:np_] + repeat(own_el[:nx]) + repeat(own_el[nx:])
                         + names[self.rest])
        self.labels = (label[:np_] + repeat(own_lab[:nx]) + repeat(own_lab[nx:])
                       + label[self.rest])

    def _per_manoeuvre(self, given, default, size, what):
        if given is None:
            return [np.asarray(default, dtype=float)] * self.n
        if len(given) != self.n:
            raise InputError(f"{what}: one per manoeuvre ({self.n}), got {len(given)}")
        out = [np.asarray(g, dtype=float).ravel() for g in given]
        if any(o.size != size for o in out):
            raise InputError(f"{what}: each needs {size} values")
        return out

    def free_names(self):
        return [lab for lab, f in zip(self.labels, self.mask) if f]

    def index(self, name):
        """Position in theta of a free parameter given by element name or label."""
        for seq in (self.labels, self.elements):
            if name in seq:
                k = seq.index(name)
                break
        else:
            try:
                k = self.elements.index(self.model.canonical_name(name))
            except (InputError, ValueError):
                raise InputError(f"{name!r} is not a free parameter") from None
        if not self.mask[k]:
            raise InputError(f"{name!r} is not a free parameter")
        return k

    def model_of(self, theta, k=0):
        """The model with the shared parameters of theta and manoeuvre k's own."""
        m = self.model
        np_, nx, ny = m.np, m.nx, m.ny
        x0 = theta[np_ + k * nx:np_ + (k + 1) * nx]
        bias = theta[np_ + self.n * nx + k * ny:np_ + self.n * nx + (k + 1) * ny]
        return m.with_theta(np.concatenate([theta[:np_], x0, bias,
                                            theta[np_ + self.n * (nx + ny):]]))


def join(records):
    """One record of several, one after the other: each keeps its sampling,
    its times moved to follow the one before.  Returns the record and the
    first sample (1-based) of each manoeuvre."""
    if len(records) == 0:
        raise InputError("no manoeuvres given")
    first = records[0]
    starts, ts, t_end = [], [], None
    for k, r in enumerate(records):
        if r.u.shape[1] != first.u.shape[1] or r.y.shape[1] != first.y.shape[1]:
            raise InputError(f"manoeuvre {k + 1} has {r.u.shape[1]} inputs and {r.y.shape[1]} "
                             f"outputs, manoeuvre 1 {first.u.shape[1]} and {first.y.shape[1]}")
        if len(r.t) < 2:
            raise InputError(f"manoeuvre {k + 1} has fewer than 2 samples")
        t = np.asarray(r.t, dtype=float)
        offset = 0.0 if t_end is None else t_end + (t[1] - t[0]) - t[0]
        starts.append(1 + sum(len(x) for x in ts))
        ts.append(t + offset)
        t_end = ts[-1][-1]
    joined = FlightData(np.concatenate(ts), np.vstack([r.u for r in records]),
                        np.vstack([r.y for r in records]), first.input_names,
                        first.output_names)
    return joined, np.array(starts, dtype=np.int32)
