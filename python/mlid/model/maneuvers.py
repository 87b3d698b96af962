"""Several manoeuvres fitted together: the parameter vector the core sees
and the joined record.

The model's parameters are shared by every manoeuvre except the initial
state and the output biases, which each manoeuvre has of its own: the core's
x0 and bias blocks are repeated once per manoeuvre (fortran/models/mlid_layout.f90,
manoeuvre_map).  A manoeuvre's own entries are named like the model's with the
manoeuvre number after '#', e.g. 'x0(1)#2' or 'V0#2'.
"""

import functools

import numpy as np

from ..checks import real_array
from ..data.flight_data import FlightData
from ..errors import InputError
from .models import free_entries


class Params:
    """The core's parameter vector for a model on n manoeuvres (the map of
    shared and own entries comes from the core, mlid_layout)."""

    def __init__(self, model, n=1, initial_states=None, biases=None):
        self.model, self.n = model, n
        # 0-based entries of one manoeuvre, whose manoeuvre, the label's '#k'
        self.map, self.seg, self._suffix = model._layout.manoeuvre_map(n)
        own = self.seg > 0
        theta, mask, terms = model.theta, model.free_places, model.tie_terms()
        if n > 1 and terms:
            own_old = np.zeros(theta.size, dtype=bool)
            own_old[self.map[own]] = True
            tied = [k for k in terms] + [j for _, src in terms.values() for j, _ in src]
            if any(own_old[k] for k in tied):
                raise InputError("ties to or from initial states and biases are not available "
                                 "with several manoeuvres")
        self.theta = theta[self.map]
        for key, given in (("x0", initial_states), ("bias", biases)):
            self._put_own(key, given, "initial_states" if key == "x0" else "biases")
        # the places in the order of free: the shared entries keep theirs, each
        # manoeuvre's own copies follow (as the core's manoeuvre_places)
        self.mask = mask[self.map].astype(np.int32)
        own_free = (self.mask > 0) & own
        self.mask[own_free] += self.seg[own_free] * mask.max(initial=0)
        self.free = free_entries(self.mask)            # the free entries, in the order of free
        # a tie points at the new places of its shared entries
        shared = np.where(own, -1, self.map)
        self.ties = model.tie_args(shared if n > 1 else None, terms)
        self._names = dict(model.names)                 # the labels as they are now

    def _tagged(self, name_of, free_only=False):
        """name_of(element name) for each entry here (the free ones only), an
        own entry's with its manoeuvre number after '#' (several manoeuvres)."""
        elements, suffix = self.model._layout.names, self._suffix
        tagged = [name_of(elements[i]) + suffix[j] for j, i in enumerate(self.map.tolist())]
        return [tagged[j] for j in self.free] if free_only else tagged

    def _label(self, element):
        return self._names.get(element, element)

    @functools.cached_property
    def labels(self):
        """Each entry's label ('C_Lalpha', 'x0(1)#2')."""
        return self._tagged(self._label)

    @functools.cached_property
    def elements(self):
        """Each entry's element name ('f(1,2)', 'x0(1)#2')."""
        return self._tagged(str)

    def _put_own(self, key, given, what):
        """Each manoeuvre's own x0 or bias block: the model's, or given per manoeuvre."""
        if given is None:
            return
        if isinstance(given, (str, bytes)) or not hasattr(given, "__len__"):
            raise InputError(f"{what} must be a list, one per manoeuvre ({self.n})")
        if len(given) != self.n:
            raise InputError(f"{what}: one per manoeuvre ({self.n}), got {len(given)}")
        block = self.model._layout.slice(key)
        size = block.stop - block.start
        for k, g in enumerate(given, 1):
            g = real_array(f"{what}[{k - 1}]", g).ravel()
            if g.size != size:
                raise InputError(f"{what}: each needs {size} values")
            at = (self.seg == k) & (self.map >= block.start) & (self.map < block.stop)
            self.theta[at] = g

    def free_names(self):
        return self._tagged(self._label, free_only=True)

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

    def model_of(self, theta, k=0, base=None):
        """The model (or base, a copy of it) with the shared parameters of
        theta and manoeuvre k's own."""
        base = self.model if base is None else base
        one = np.empty(base.theta.size)
        at = (self.seg == 0) | (self.seg == k + 1)
        one[self.map[at]] = np.asarray(theta)[at]
        return base.with_theta(one)


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
                        first.output_names, input_units=first.input_units,
                        output_units=first.output_units, input_display=first.input_display,
                        output_display=first.output_display)
    return joined, np.array(starts, dtype=np.int32)
