"""Model objects: what the equations are and which parameters are free.

Every model carries its full parameter vector

    theta = [p, x0, bias, q, r, S]

(model parameters, initial states, output biases, process- and
measurement-noise variances, their cross-covariance) and a list of free
parameter names; the Fortran core sees only flat arrays.  Parameters are
named by element, 1-based as in a deck: ``'f(1,2)'``, ``'x0(3)'``,
``'r(2)'``, ``'cm(4)'``.  The order of the blocks, their element names and
default labels come from the core (fortran/models/mlid_layout.f90); the matrices
F, G, ... are views into theta.
"""

import copy

import numpy as np

from .._bridge import (api as _api, call_handle as _call_handle, lines as _lines,
                       put as _put, results as _results, run as _run)
from ..checks import real_array
from ..errors import InputError, check_status, guarded_class
from .tables import Table

INPUT_HOLDS = ("linear", "zoh")

#: The constructor arguments every model kind shares, for its docstring.
_COMMON_PARAMETERS = """x0 : array_like (nx,), optional
        Initial state (default zero).
    bias : array_like (ny,), optional
        Output biases, added to the outputs (default zero).
    free : sequence of str
        The free parameters by element name, 1-based: 'f(1,2)', 'x0(3)',
        'bias(1)', 'q(1)', 'r(2)', 's(1,2)' and the kind's own.
    names : dict, optional
        Readable labels by element name, {'f(3,3)': 'M_q'}; reports and
        results use them.
    input_hold : {'linear', 'zoh'}
        Inputs linear between samples (RK4's mid-step stages take their
        mean) or held from one sample to the next.
    substeps : int
        RK4 steps per sample interval.
    q : array_like (nw,), optional
        Process-noise variances (default zero), the noise held over each
        sample interval.
    r : array_like (ny,), optional
        Measurement-noise variances (default zero); filter error needs them
        > 0, simulation draws the noise from them.
    S : array_like (nw, ny), optional
        Cross-covariance E{w v'} of the process noise of an interval and the
        measurement noise at its start (default zero).
    ties : dict, optional
        Affine ties, {tied: right-hand side}: a parameter equal to a free one,
        {'f(1,5)': 'f(1,3)'}, or a constant plus a sum of scaled parameters,
        {'g(1,1)': '-0.01 + 0.0096*g(2,1) - f(2,2)'} (fortran/models/mlid_ties.f90
        reads them, as it reads a deck's ``tie``).  The tied values are set
        from the sources when the model is made and at every iteration.
    delay : array_like (ny,), optional
        Each output's time delay in s (default zero): the model output at
        t - delay, interpolated between the samples that bracket it; a lead
        (delay < 0, less than a sample) extrapolated from the sample before
        (fortran/numerics/mlid_delay.f90).  A parameter 'delay(i)' like any other;
        output error only.
    udelay : array_like (nu,), optional
        Each input's time delay in s (default zero), by the same rule: the
        aircraft sees the recorded input at t - udelay.  A parameter
        'udelay(j)'; output error only; free only with the kinds that give
        their input Jacobians (linear, equations, sixdof, flight path).
    stab : array_like (nx, ny), optional
        The gain K of the stabilized output error (textbook eq. 9.37; default
        zero: plain output error): after each sample's outputs the state
        moves by K (z - yhat) toward the measurements, which keeps an
        unstable model's integration from diverging.  Free ('stab(i,j)') only
        as the Kalman filter's steady-state gain of filter error with
        ``filter_params='gain'`` (report eqs 4.19-4.21).
    p0 : array_like (nx,), optional
        The diagonal of the Kalman filter's initial state covariance P(1|0)
        (default zero: the initial state x0 known); the time-varying filter
        of filter error starts each manoeuvre from it.  A parameter 'p0(i)'."""
#: What every model constructor raises.
_COMMON_RAISES = """InputError
        Wrong sizes or shapes, an element that does not exist, a parameter
        listed twice, both free and tied, or tied to a tied one, an unknown
        input_hold."""


def _documented(cls):
    """Fill the shared constructor arguments into the class docstring (none
    under python -OO, PYTHONOPTIMIZE=2)."""
    if cls.__doc__ is None:
        return cls
    cls.__doc__ = cls.__doc__.replace("{common}", _COMMON_PARAMETERS).replace(
        "{raises}", _COMMON_RAISES)
    return cls


#: Layouts kept by _Layout.of, and parsed ties kept by each layout (bounds
#: on what a long campaign's worker holds).
LAYOUTS_KEPT = 256
TIES_KEPT = 1024


class _Layout:
    """The core's layout of theta for one model kind and its sizes."""

    _cache = {}

    def __init__(self, kind, sizes, iconst, rconst):
        self._args = dict(mkind=kind, nx=sizes[0], nu=sizes[1], ny=sizes[2], nw=sizes[3],
                          iconst=np.array(iconst), rconst=np.array(rconst))
        out = self._call(_api.mlid_layout)
        self.blocks = {k: (o, r, c) for k, r, c, o in zip(
            _lines(out["keys"]), out["rows"].tolist(), out["cols"].tolist(),
            out["offsets"].tolist())}
        self.names, self.labels = _lines(out["names"]), _lines(out["labels"])
        self.regressors = _lines(out["regressors"])     # the longitudinal model's, in p order
        self.nth = len(self.names)
        self.place = {name: k for k, name in enumerate(self.names)}
        self.np = self.blocks["x0"][0]
        self._maps, self._ties, self._elements = {}, {}, {}

    def _call(self, routine, **given):
        """routine of the core on this layout's model (the model part of the
        thread's problem) with the values given by name: what it gives, by
        name."""
        h = _call_handle()
        check_status(*_api.mlid_set_model(h.value, **self._args))
        if given:
            _put(h, **given)
        check_status(*routine(h.value))
        return _results(h)

    def element(self, name):
        """The element name of parameter name as the core writes it
        (mlid_elements: 'F( 1,2 )' -> 'f(1,2)'; an equations model's own
        names too), or raise InputError saying why it is none; kept, as the
        layout is."""
        key = str(name)
        if key not in self._elements:
            if "\n" in key:
                raise InputError(f"parameter {name!r} does not exist: a name is one line")
            out = self._call(_api.mlid_elements, names=key + "\n")
            written, problem = (_lines(out[k])[0] if _lines(out[k]) else "" for k in
                                ("written", "problem"))
            if not written:
                raise InputError(f"parameter {name!r} {problem}")
            if len(self._elements) >= TIES_KEPT:
                self._elements.clear()
            self._elements[key] = written
        return self._elements[key]

    def manoeuvre_map(self, n):
        """The core's map of theta on n manoeuvres (mlid_manoeuvre_map): the
        0-based entry of one manoeuvre's theta, the manoeuvre it is own to
        (0 shared) and what its label gets after the name ('#2', or ''), per
        entry; kept (read-only), as the layout is."""
        if n not in self._maps:
            out = self._call(_api.mlid_manoeuvre_map, nseg=n)
            entry, seg = out["map"] - 1, out["seg"]
            entry.setflags(write=False)
            seg.setflags(write=False)
            suffix = tuple(out["suffix"].decode().split("\n")[:seg.size])
            self._maps[n] = entry, seg, suffix
        return self._maps[n]

    def tie(self, text):
        """A tie 'a = c + s*b + ...' parsed by the core (mlid_tie_parse): the
        tied entry (0-based), the offset and ((source, scale), ...); kept,
        as the layout is (a fit parses its model's ties each time; cleared
        when full)."""
        tie = self._ties.get(text)
        if tie is None:             # (a local: another thread may clear the store meanwhile)
            out = self._call(_api.mlid_tie_parse, text=text)
            tie = (out["to"] - 1, out["offset"],
                   tuple((j - 1, s) for j, s in zip(out["from"].tolist(),
                                                    out["scale"].tolist())))
            if len(self._ties) >= TIES_KEPT:
                self._ties.clear()
            self._ties[text] = tie
        return tie

    @classmethod
    def of(cls, kind, sizes, iconst, rconst):
        """The layout of these sizes and constants, kept (the oldest of
        LAYOUTS_KEPT dropped: a campaign's cases each have their own)."""
        key = (kind, tuple(sizes), tuple(iconst), tuple(rconst))
        layout = cls._cache.get(key)
        if layout is None:
            layout = cls(kind, sizes, iconst, rconst)
            if len(cls._cache) >= LAYOUTS_KEPT:
                cls._cache.pop(next(iter(cls._cache), None), None)
            cls._cache[key] = layout
        return layout

    def shape(self, key):
        _, r, c = self.blocks[key]
        return (r, c) if c >= 0 else (r,)

    def slice(self, key):
        o, r, c = self.blocks[key]
        return slice(o, o + r * (c if c >= 0 else 1))


def _own_sizes(kind, iconst, rconst):
    """Sizes of a model whose sizes are its own, from the core."""
    nx, nu, ny, nw, _, status, msg = _api.mlid_model_sizes(mkind=kind, iconst=iconst,
                                                           rconst=rconst)
    check_status(status, msg)
    return nx, nu, ny, nw


class _Block:
    """A block of theta, as an array view, by its key in the core's layout."""

    def __init__(self, key):
        self.key = key

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, model, owner=None):
        return self if model is None else model._block(self.key)

    def __set__(self, model, value):
        model._put(self.key, value, self.name)


#: The core's model kinds by name, and their codes (mlid_model_factory).
MODEL_KINDS = {name: k for k, name in enumerate(_lines(_api.mlid_name_list("model_kinds")), 1)}


@guarded_class
class Model:
    """What every model shares: theta in the core's layout, the generic
    blocks and the free, tied and labelled parameters.  Subclasses set kind,
    iconst, rconst and their own blocks."""

    kind = 0                # none: each kind's class says (MODEL_KINDS)
    iconst = np.zeros(0, dtype=np.int32)
    rconst = np.zeros(0)
    x0, bias, q, r, S = _Block("x0"), _Block("bias"), _Block("q"), _Block("r"), _Block("s")
    delay = _Block("delay")
    udelay = _Block("udelay")
    stab = _Block("stab")
    p0 = _Block("p0")

    def _init_layout(self, nx, nu, ny, nw):
        self.nx, self.nu, self.ny, self.nw = nx, nu, ny, nw
        self._layout = _Layout.of(self.kind, (nx, nu, ny, nw), self.iconst, self.rconst)
        self._theta = np.zeros(self._layout.nth)

    def _block(self, key):
        return self._theta[self._layout.slice(key)].reshape(self._layout.shape(key), order="F")

    def _put(self, key, value, what=None):
        shape = self._layout.shape(key)
        a = real_array(what or key, value, finite=False)
        if a.size != int(np.prod(shape)):
            raise InputError(f"{what or key} must have {int(np.prod(shape))} values"
                             + (f" ({shape[0]}x{shape[1]})" if len(shape) == 2 else "")
                             + f", got {a.size}")
        self._theta[self._layout.slice(key)] = a.reshape(shape).ravel(order="F")

    def _init_common(self, x0, bias, q, r, S, free, names, ties, input_hold, substeps,
                     delay=None, udelay=None, stab=None, p0=None):
        for key, value in (("x0", x0), ("bias", bias), ("q", q), ("r", r), ("S", S),
                           ("delay", delay), ("udelay", udelay), ("stab", stab), ("p0", p0)):
            if value is not None:
                setattr(self, key, value)
        if input_hold not in INPUT_HOLDS:
            raise InputError(f"input_hold must be one of {INPUT_HOLDS}, got {input_hold!r}")
        self.input_hold = input_hold
        self.substeps = int(substeps)
        self.names = {e: lab for e, lab in zip(self._layout.names, self._layout.labels)
                      if e != lab}
        self.names.update({self.canonical_name(k): v for k, v in (names or {}).items()})
        self.free = [self.canonical_name(n) for n in free]
        dup = {n for n in self.free if self.free.count(n) > 1}
        if dup:
            raise InputError(f"free parameter listed twice: {sorted(dup)[0]}")
        self.ties = {}
        for a, b in (ties or {}).items():
            a = self.canonical_name(a)
            if a in self.ties:
                raise InputError(f"parameter {a!r} is tied twice")
            self.ties[a] = str(b).strip()
        terms = self.tie_terms()
        names = self._layout.names
        for k, (offset, sources) in terms.items():
            a = names[k]
            if a in self.free:
                raise InputError(f"parameter {a!r} is both free and tied")
            for j, _ in sources:
                if names[j] in self.ties:
                    raise InputError(f"{a!r} is tied to {names[j]!r}, which is itself tied "
                                     "(a chain or a cycle of ties): tie to the free parameter")
        self._theta[:] = self.tied(self._theta, terms)

    def _common(self):
        """Keyword arguments that carry the generic parts to a copy."""
        return dict(x0=self.x0, bias=self.bias, q=self.q, r=self.r, S=self.S, free=self.free,
                    names=self.names, ties=self.ties, input_hold=self.input_hold,
                    substeps=self.substeps, delay=self.delay,
                    udelay=self.udelay, stab=self.stab, p0=self.p0)

    # -- parameter vector ------------------------------------------------
    @property
    def np(self):
        """Number of model parameters p (theta before x0 and the noise blocks)."""
        return self._layout.np

    @property
    def theta(self):
        """All parameters, in the core's order; matrices column-major."""
        return self._theta.copy()

    def element_names(self):
        """The element name of every entry of theta, in order.

        Returns
        -------
        list of str
            'f(1,1)', ..., 'x0(1)', ..., 'r(ny)', ... as the core lays theta out.
        """
        return list(self._layout.names)

    def element_labels(self):
        """The core's own label of every entry of theta, in order (the
        default labels, before any ``names``): 'C_Lalpha', an equations
        model's parameters by their own names, else the element name.

        Returns
        -------
        list of str
        """
        return list(self._layout.labels)

    def param_units(self, input_units, output_units):
        """The unit of every entry of theta, in order, from the units of the
        record's channels (the core's units, as ``FlightData.input_units``
        and ``output_units`` hold them).

        Parameters
        ----------
        input_units, output_units : sequence of str
            One unit per input and per output ('' unknown).

        Returns
        -------
        list of str
            '-' for a dimensionless parameter, '' where the unit is unknown
            (fortran/models/mlid_param_units.f90 says which).

        Raises
        ------
        InputError
            Not one unit per input and per output.
        """
        if len(input_units) != self.nu or len(output_units) != self.ny:
            raise InputError(f"param_units: {self.nu} input and {self.ny} output units needed, "
                             f"got {len(input_units)} and {len(output_units)}")
        out = self._layout._call(_api.mlid_parameter_units, theta=self._theta,
                                 input_units="\n".join(input_units) + "\n",
                                 output_units="\n".join(output_units) + "\n")
        lines = out["units"].decode(errors="replace").split("\n")
        return [s.strip() for s in lines[:self._theta.size]]

    def canonical_name(self, name):
        """The element name of a parameter, checked against the dimensions
        (the core's grammar, mlid_layout's element_index).

        Parameters
        ----------
        name : str
            An element name, any case and spacing: 'F( 1,2 )'; a model
            written as equations also takes a parameter's own name, exact or
            in any case when that is unique ('Mq').

        Returns
        -------
        str
            The element name as the model writes it: 'f(1,2)'.

        Raises
        ------
        InputError
            No such block, the wrong number of indices, or indices outside
            the block.
        """
        return self._layout.element(name)

    @property
    def free_mask(self):
        """1 for each free entry of theta, else 0, in theta order."""
        return (self.free_places > 0).astype(np.int32)

    @property
    def free_places(self):
        """Each free entry's place in the order of free (1, 2, ...), 0 for a
        fixed one (int32, as the core takes it; free_entries reads it)."""
        place = self._layout.place
        places = np.zeros(len(self._layout.names), dtype=np.int32)
        places[[place[n] for n in self.free]] = np.arange(1, len(self.free) + 1)
        return places

    def free_indices(self):
        """The theta entries of the free parameters, in the order of free.

        Returns
        -------
        numpy.ndarray of int
            0-based entries of theta in the order of a fit's estimate, so
            that ``truth.theta[truth.free_indices()]`` lines up with it.
        """
        return free_entries(self.free_places)

    def tie_terms(self):
        """The ties parsed by the core (fortran/models/mlid_ties.f90).

        Returns
        -------
        dict
            {tied entry (0-based): (offset, [(source entry, scale), ...])}.

        Raises
        ------
        InputError
            A tie that names no parameter or is not affine ('a = c + s*b + ...').
        """
        out = {}
        for a, rhs in self.ties.items():
            to, offset, sources = self._layout.tie(f"{a} = {rhs}")
            out[to] = (offset, list(sources))
        return out

    def tied(self, theta, terms=None):
        """theta with every tied entry set from its ties.

        Parameters
        ----------
        theta : array_like
            A parameter vector of this model.
        terms : dict, optional
            ``tie_terms()``, when the caller has them already.

        Returns
        -------
        numpy.ndarray
        """
        theta = np.array(theta, dtype=float)
        for k, (offset, sources) in (self.tie_terms() if terms is None else terms).items():
            theta[k] = offset + sum(s * theta[j] for j, s in sources)
        return theta

    def tie_args(self, entries=None, terms=None):
        """The ties as the core takes them: tie_to, tie_from (1-based),
        tie_scale per term and tie_offset per entry of theta.

        Parameters
        ----------
        entries : array_like of int, optional
            A map of this model's entries onto a longer vector (several
            manoeuvres): entry k of the long vector is entry entries[k] here;
            a tied entry and its sources must map once (shared entries).
        terms : dict, optional
            ``tie_terms()``, when the caller has them already.

        Returns
        -------
        dict
        """
        terms = self.tie_terms() if terms is None else terms
        where = np.arange(self._theta.size) if entries is None else np.asarray(entries)
        new_of = dict(zip(where.tolist(), range(len(where)))) if terms else {}
        to, frm, scale = [], [], []
        offset = np.zeros(len(where))
        for k, (c, sources) in terms.items():
            offset[new_of[k]] = c
            for j, s in sources:
                to.append(new_of[k] + 1)
                frm.append(new_of[j] + 1)
                scale.append(s)
        # f2py wants at least one element: no tie is ntie = 0 over arrays of one
        return {"ntie": len(to), "tie_to": np.array(to or [0], dtype=np.int32),
                "tie_from": np.array(frm or [0], dtype=np.int32),
                "tie_scale": np.array(scale or [0.0], dtype=float), "tie_offset": offset}

    def free_names(self):
        """Readable labels of the free parameters, in the order of free.

        Returns
        -------
        list of str
            Each free parameter's label, or its element name when it has none.
        """
        return [self.names.get(n, n) for n in self.free]

    def value(self, name):
        """The value of one parameter, by element name or label.

        Parameters
        ----------
        name : str
            'f(3,3)' or its label 'M_q'.

        Returns
        -------
        float

        Raises
        ------
        InputError
            If no parameter has that name or label.
        """
        labels = {v: k for k, v in self.names.items()}
        key = self.canonical_name(labels.get(name, name))
        return float(self._theta[self._layout.names.index(key)])

    def with_theta(self, theta):
        """A copy with the parameter vector replaced.

        Parameters
        ----------
        theta : array_like
            Every parameter in the core's order (``theta``'s size).

        Returns
        -------
        Model
            The same kind, free set, ties and labels.

        Raises
        ------
        InputError
            If theta has the wrong size.
        """
        theta = np.asarray(theta, dtype=float).ravel()
        if theta.size != self._layout.nth:
            raise InputError(f"theta must have {self._layout.nth} values, got {theta.size}")
        m = copy.copy(self)
        m._theta = theta.copy()
        m.names, m.free, m.ties = dict(self.names), list(self.free), dict(self.ties)
        m.iconst, m.rconst = self.iconst.copy(), self.rconst.copy()
        if "constants" in vars(self):
            m.constants = dict(self.constants)
        return m

    def with_free(self, free, names=None):
        """A copy with another free set (and labels, if given).

        Parameters
        ----------
        free : sequence of str
            The new free parameters, by element name.
        names : dict, optional
            Labels by element name, replacing the model's.

        Returns
        -------
        Model

        Raises
        ------
        InputError
            If a name is not an element of the model.
        """
        m = self.with_theta(self._theta)
        m.free = [m.canonical_name(n) for n in free]
        if names is not None:
            m.names = {m.canonical_name(k): v for k, v in names.items()}
        return m

    def __repr__(self):
        return (f"{type(self).__name__}(nx={self.nx}, nu={self.nu}, ny={self.ny}, nw={self.nw}, "
                f"free={self.free_names()})")


@_documented
@guarded_class
class LinearModel(Model):
    """Linear state space with process and measurement noise

        xdot = F x + G (u + K x) + bx + Gamma w,   y = H x + D (u + K x) + bias + v,

    w (nw values) held over each sample interval with variances q (diagonal
    Q), v with variances r (diagonal R), cross-covariance S = E{w v'} (nw x ny).

    K (nu x nx, zero unless given) feeds states back to the inputs: a
    stability augmentation system moving the surfaces on top of the
    recorded command.  bx (nx, zero unless given): constant state-equation
    biases (trim offsets, such as the textbook's Z_0 and M_0), no fake input
    of ones needed.

    Model parameters: ``'f(i,j)'``, ``'g(i,j)'``, ``'h(i,j)'``, ``'d(i,j)'``,
    ``'gamma(i,j)'``, ``'k(j,s)'``, ``'bx(i)'``; ``names`` gives readable labels (``{'f(3,3)': 'M_q'}``);
    ``ties`` holds parameters tied to free ones: equal (``{'f(1,5)': 'f(1,3)'}``)
    or affine (``{'g(1,1)': '0.0096*g(2,1)'}``).

    Parameters
    ----------
    F : array_like (nx, nx)
    G : array_like (nx, nu)
    H : array_like (ny, nx)
    D : array_like (ny, nu), optional
        Default zero.
    Gamma : array_like (nx, nw), optional
        How the process noise enters (default: none, nw = 0).
    K : array_like (nu, nx), optional
        State feedback to the inputs (default zero).
    bx : array_like (nx,), optional
        State-equation biases (default zero).
    {common}

    Raises
    ------
    {raises}

    Examples
    --------
    The short period, x = (alpha, q), with three derivatives to estimate,
    each under its own label:

    >>> import mlid
    >>> model = mlid.LinearModel([[-0.7, 1.0], [-0.6, -1.6]], [[0.0], [-1.7]],
    ...                          [[1.0, 0.0], [0.0, 1.0]],
    ...                          free=["f(2,1)", "f(2,2)", "g(2,1)"],
    ...                          names={"f(2,1)": "M_alpha", "f(2,2)": "M_q",
    ...                                 "g(2,1)": "M_de"})
    >>> model
    LinearModel(nx=2, nu=1, ny=2, nw=0, free=['M_alpha', 'M_q', 'M_de'])
    >>> float(model.F[1, 1])
    -1.6
    """

    kind = MODEL_KINDS["linear"]
    F, G, H, D = _Block("f"), _Block("g"), _Block("h"), _Block("d")
    Gamma, K, bx = _Block("gamma"), _Block("k"), _Block("bx")

    def __init__(self, F, G, H, D=None, x0=None, bias=None, free=(), names=None,
                 input_hold="linear", substeps=1, Gamma=None, q=None, r=None, S=None,
                 ties=None, K=None, bx=None, delay=None, udelay=None, stab=None, p0=None):
        F, G, H = np.atleast_2d(real_array("F", F)), real_array("G", G), np.atleast_2d(real_array("H", H))
        nx = F.shape[0]
        if F.shape != (nx, nx):
            raise InputError(f"F must be square, got shape {F.shape}")
        if G.ndim == 1:
            G = G.reshape(nx, -1)
        if G.shape[0] != nx:
            raise InputError(f"G must have {nx} rows (one per state), got shape {G.shape}")
        if H.shape[1] != nx:
            raise InputError(f"H must have {nx} columns (one per state), got shape {H.shape}")
        Gamma = np.zeros((nx, 0)) if Gamma is None else np.asarray(Gamma, dtype=float)
        if Gamma.ndim == 1:
            Gamma = Gamma.reshape(nx, -1)
        if Gamma.shape[0] != nx:
            raise InputError(f"Gamma must have {nx} rows (one per state), got shape {Gamma.shape}")
        self._init_layout(nx, G.shape[1], H.shape[0], Gamma.shape[1])
        self.F, self.G, self.H, self.Gamma = F, G, H, Gamma
        if D is not None:
            self.D = D
        if K is not None:
            self.K = K
        if bx is not None:
            self.bx = bx
        self._init_common(x0, bias, q, r, S, free, names, ties, input_hold, substeps, delay,
                          udelay, stab, p0)


#: Regressors of the longitudinal model (fortran/models/mlid_aero_long.f90), in
#: the order of their codes, and its constants in the core's order.
REGRESSORS = tuple(_lines(_api.mlid_name_list("regressors")))
CONSTANTS = tuple(_api.mlid_name_list("constants").decode().strip().split(", "))


def _longitudinal_iconst(regressors):
    """The longitudinal model's iconst for its regressors by name, from the
    core (mlid_longitudinal_iconst), which refuses an unknown one."""
    h = _call_handle()
    _put(h, **{k.lower(): "".join(f"{r}\n" for r in regs) for k, regs in regressors.items()})
    return _run(h, _api.mlid_longitudinal_iconst)["iconst"].astype(np.int32)


@_documented
@guarded_class
class LongitudinalModel(Model):
    """Nonlinear longitudinal aircraft model (states V, alpha, theta, q;
    inputs delta_e, thrust; outputs V, alpha, theta, q, qdot, a_x, a_z) whose
    C_D, C_L, C_m are linear in their coefficients over named regressors
    (``REGRESSORS``); the equations are in fortran/models/mlid_aero_long.f90.

    regressors: {'CD': ['1', 'V/V0', 'alpha'], 'CL': [...], 'Cm': [...]}
    coefficients: {'CD': [values], ...} (start values, same order)
    constants: {name: value} for every name in ``CONSTANTS``
    Model parameters are ``'cd(k)'``, ``'cl(k)'``, ``'cm(k)'``, labelled
    C_D0, C_DV, C_Dalpha, ... unless ``names`` says otherwise.  Process
    noise (4 variances q) adds to each state equation.

    Parameters
    ----------
    regressors : dict
        {'CD': [...], 'CL': [...], 'Cm': [...]}: each coefficient's
        regressors by name, from ``REGRESSORS``; a key left out has none.
    coefficients : dict
        Start values in the same order, {'CD': [...], ...} (default zero).
    constants : dict
        A value for every name of ``CONSTANTS`` (SI units).
    {common}

    Raises
    ------
    {raises}
        Also an unknown coefficient, regressor or missing constant.
    """

    kind = MODEL_KINDS["longitudinal"]
    _COEFFICIENTS = {"CD": "cd", "CL": "cl", "Cm": "cm"}

    def __init__(self, regressors, coefficients, constants, x0=None, bias=None, free=(),
                 names=None, input_hold="linear", substeps=1, r=None, ties=None, q=None, S=None,
                 delay=None, udelay=None, stab=None, p0=None):
        self.regressors = {k: list(regressors.get(k, [])) for k in self._COEFFICIENTS}
        unknown = set(regressors) - set(self.regressors)
        if unknown:
            raise InputError(f"unknown coefficient {sorted(unknown)[0]!r}: use CD, CL, Cm")
        self.iconst = _longitudinal_iconst(self.regressors)
        missing = [c for c in CONSTANTS if c not in constants]
        if missing:
            raise InputError(f"missing constant {missing[0]!r} (need {', '.join(CONSTANTS)})")
        self.constants = {c: float(constants[c]) for c in CONSTANTS}
        self.rconst = np.array([self.constants[c] for c in CONSTANTS])
        self._init_layout(*_own_sizes(self.kind, self.iconst, self.rconst))
        for key, block in self._COEFFICIENTS.items():
            vals = np.asarray(coefficients.get(key, np.zeros(len(self.regressors[key]))),
                              dtype=float).ravel()
            if vals.size != len(self.regressors[key]):
                raise InputError(f"{key} has {len(self.regressors[key])} regressors but "
                                 f"{vals.size} values")
            self._put(block, vals, key)
        # process noise (q, 4 variances) adds to each state equation: turbulence
        self._init_common(x0, bias, q, r, S, free, names, ties, input_hold, substeps, delay,
                          udelay, stab, p0)

    @property
    def coefficients(self):
        """The coefficients' current values, {'CD': array, 'CL': ..., 'Cm': ...}."""
        return {key: self._block(block) for key, block in self._COEFFICIENTS.items()}

    def with_tables(self, tables, free=None):
        """This model written as equations (fortran/models/mlid_long_text.f90)
        with some of its coefficients tables: the same states, inputs
        (named de, F), outputs and equations, no process noise.

        Parameters
        ----------
        tables : dict
            {label: Table}: the coefficient of that label (C_D0, C_Lalpha,
            C_mq, ...) a table over states, inputs or qhat; its values are
            parameters 'C_Lalpha[i]', ... after the other coefficients
            (which keep their labels as names and their values).
        free : sequence of str, optional
            The new model's free parameters (default: this model's free
            coefficients that are not tables, and every table value).

        Returns
        -------
        EquationModel
            With this model's x0, output biases, r, delay, udelay, stab and
            p0.  A table's values start at the Table's values or, when it
            was made without any, at the coefficient's value here (as a
            deck's table values without a params entry do).

        Raises
        ------
        InputError
            A label that is no coefficient, a table the core refuses, process
            noise (q or S not zero: an equations model has none).
        """
        if np.any(self._block("q")) or np.any(self._block("s")):
            raise InputError("with_tables: the model is written as equations, which have no "
                             "process noise: q and S must be zero")
        labels = self.element_labels()[:self.np]
        lines = "".join(t.line(n)[2:] + "\n" for n, t in tables.items())
        out = self._layout._call(_api.mlid_longitudinal_text, tables=lines)
        p = [v for n, v in zip(labels, self._theta[:self.np]) if n not in tables]
        coef = dict(zip(labels, self._theta[:self.np]))
        p += [v for n in labels if n in tables for v in
              (tables[n].flat_values if tables[n].given else
               np.full(tables[n].flat_values.size, coef[n]))]
        if free is None:
            free = [labels[k] for k in self.free_indices() if k < self.np
                    and labels[k] not in tables]
            free += [v for n in labels if n in tables for v in tables[n].value_names(n)]
        m = object.__new__(EquationModel)
        m._from_text(out["text"].decode().rstrip("\n"), p,
                     (self._block("x0"), self._block("bias"), None, self._block("r"), None,
                      free, None, None, self.input_hold, self.substeps, self._block("delay"),
                      self._block("udelay"), self._block("stab"), self._block("p0")))
        return m


@_documented
@guarded_class
class UserModel(Model):
    """The user's own Fortran model (fortran/models/mlid_user_model.f90, compiled into
    the core): p holds its np parameters, named ``'p(k)'``; iconst and rconst
    its constants.  Its sizes come from the core.

    Parameters
    ----------
    p : array_like (np,)
        The model parameters' start values.
    iconst : array_like of int, optional
        Integer constants the user model reads.
    rconst : array_like of float, optional
        Real constants the user model reads.
    {common}

    Raises
    ------
    {raises}
        Also p of the wrong size, or constants the user model refuses.
    """

    kind = MODEL_KINDS["user"]
    p = _Block("p")

    def __init__(self, p, iconst=(), rconst=(), x0=None, bias=None, free=(), names=None,
                 input_hold="linear", substeps=1, q=None, r=None, S=None, ties=None, delay=None,
                 udelay=None, stab=None, p0=None):
        self.iconst = np.asarray(iconst, dtype=np.int32).ravel()
        self.rconst = np.asarray(rconst, dtype=float).ravel()
        self._init_layout(*_own_sizes(self.kind, self.iconst, self.rconst))
        p = np.asarray(p, dtype=float).ravel()
        if p.size != self.np:
            raise InputError(f"the user model has {self.np} parameters p, got {p.size} values")
        self.p = p
        self._init_common(x0, bias, q, r, S, free, names, ties, input_hold, substeps, delay,
                          udelay, stab, p0)


@_documented
@guarded_class
class X22Model(Model):
    """X-22 VTOL longitudinal model of report Appendix A
    (fortran/models/mlid_x22.f90): states u, w [ft/s], theta [rad], q [rad/s];
    input delta_es; outputs u, w, theta, q, qdot, n_x, n_z [g]; gusts v1, v2
    [ft/s], v3 [rad/s] (variances q) entering through dA/d(u, w, q) and
    carried by qdot, n_x and n_z.  p: the 23 coefficients of X22_LABELS,
    named ``'p(k)'`` and labelled by X22_LABELS.

    Parameters
    ----------
    p : array_like (23,)
        The coefficients' start values, in the order of X22_LABELS.
    {common}

    Raises
    ------
    {raises}
        Also p of the wrong size.
    """

    kind = MODEL_KINDS["x22"]
    p = _Block("p")

    def __init__(self, p, x0=None, bias=None, free=(), names=None, input_hold="linear",
                 substeps=1, q=None, r=None, S=None, ties=None, delay=None, udelay=None, stab=None, p0=None):
        self._init_layout(*_own_sizes(self.kind, self.iconst, self.rconst))
        p = np.asarray(p, dtype=float).ravel()
        if p.size != self.np:
            raise InputError(f"the X-22 model has {self.np} coefficients, got {p.size}")
        self.p = p
        self._init_common(x0, bias, q, r, S, free, names, ties, input_hold, substeps, delay,
                          udelay, stab, p0)


#: The X-22's 23 coefficients (report Appendix A), from the core: each
#: derivative's polynomial in u by rising power, labelled e.g. M_o, M_o.u, M_o.u2.
_X22 = _Layout.of(X22Model.kind, _own_sizes(X22Model.kind, X22Model.iconst, X22Model.rconst),
                  X22Model.iconst, X22Model.rconst)
X22_LABELS = tuple(_X22.labels[_X22.slice("p")])
X22_DERIVATIVES = tuple((d, sum(1 for lab in X22_LABELS if lab.split(".")[0] == d))
                        for d in dict.fromkeys(lab.split(".")[0] for lab in X22_LABELS))

@_documented
@guarded_class
class EquationModel(Model):
    """A model stated as equations in text, differentiated exactly by the
    core (fortran/models/mlid_equations.f90): no Fortran and no rebuild.  The
    expressions use the language of derived channels (+ - * / ^, sin cos tan
    asin acos atan atan2 sqrt abs exp log log10 min max tanh, pi) over the
    states, inputs, parameters, t and the definitions.  p holds the
    parameters, named by their own names or ``'p(k)'``; there is no process
    noise (nw = 0: q and S are empty) and there may be no states
    (regression).

    Parameters
    ----------
    outputs : dict
        {name: expression} of each output, in output order.
    states : dict, optional
        {name: expression of its time derivative}, in state order.
    inputs : sequence of str, optional
        The inputs' names, in the order of the data's input channels.
    params : dict, optional
        {name: start value} of each model parameter, in the order of p.
    definitions : dict, optional
        {name: expression} of constants and intermediate quantities, each
        usable by the ones after it and by the equations; an expression may
        be a ``Table`` (mlid.model.tables): its values are parameters after
        those of params, named 'NAME[i]', 'NAME[i,j]', ..., in the order of
        the definitions.
    {common}

    Raises
    ------
    {raises}
        Also an expression the core cannot read (the message names the
        equation and the character), a name given twice.
    """

    kind = MODEL_KINDS["equations"]
    p = _Block("p")

    def __init__(self, outputs, states=None, inputs=(), params=None, definitions=None, x0=None,
                 bias=None, free=(), names=None, input_hold="linear", substeps=1, q=None, r=None,
                 S=None, ties=None, delay=None, udelay=None, stab=None, p0=None):
        self._build(outputs, states or {}, inputs, params, definitions, "", "",
                    (x0, bias, q, r, S, free, names, ties, input_hold, substeps, delay,
                     udelay, stab, p0))

    def _build(self, outputs, states, inputs, params, definitions, pre, post, common):
        """The model's text from its parts (pre and post: lines a generator
        puts around the definitions), then the layout and parameters."""
        params, definitions = dict(params or {}), dict(definitions or {})
        if isinstance(inputs, (str, bytes)):
            raise InputError(f"inputs must be a list of names, got the string {inputs!r}")
        for n in [*inputs, *params, *definitions, *states, *outputs]:
            if not isinstance(n, str) or not n or any(c.isspace() for c in n):
                raise InputError(f"equations model: {n!r} is not a name")
        lines = ([f"u {n}" for n in inputs] + [f"p {n}" for n in params] + [pre]
                 + [e.line(n) if isinstance(e, Table) else f"l {n} = {_one_line(e)}"
                    for n, e in definitions.items()] + [post]
                 + [f"x {n} = {_one_line(e)}" for n, e in states.items()]
                 + [f"y {n} = {_one_line(e)}" for n, e in outputs.items()])
        p = list(params.values()) + [v for e in definitions.values() if isinstance(e, Table)
                                     for v in e.flat_values]
        self._from_text("\n".join(line.rstrip("\n") for line in lines if line), p, common)

    def _from_text(self, text, p, common):
        """The model from its text, the parameters' start values and the
        common settings."""
        self.iconst = np.frombuffer(text.encode(), dtype=np.uint8).astype(np.int32)
        self._init_layout(*_own_sizes(self.kind, self.iconst, self.rconst))
        self.p = np.asarray(p, dtype=float)
        self._init_common(*common)

    @property
    def text(self):
        """The model's text as the core reads it (one item a line)."""
        return bytes(self.iconst.astype(np.uint8)).decode()

    @property
    def table_names(self):
        """The tables' names, in the text's order (lines 't NAME(...) = ...')."""
        return [line[2:].split("(", 1)[0].strip() for line in self.text.split("\n")
                if line.startswith("t ")]

    def _tables(self, smoothness=None):
        """The core's account of the tables (mlid_model_tables): each p
        entry's text and the smoothness weight over theta's p."""
        names = self.table_names
        smoothness = dict(smoothness or {})
        unknown = sorted(set(smoothness) - set(names))
        if unknown:
            raise InputError(f"smoothness: no table named {', '.join(unknown)} (tables: "
                             f"{', '.join(names) or 'none'})")
        lam = np.array([float(smoothness.get(n, 0.0)) for n in names] or [0.0])[:len(names)]
        out = self._layout._call(_api.mlid_model_tables, smoothness=lam)
        cells = out["cells"].decode("utf-8", "surrogateescape").split("\n")[:self.np]
        return cells, np.asarray(out["weight"]).reshape(self.np, self.np, order="F")

    @property
    def table_cells(self):
        """{label: text} of each table value: its name and where it is
        weighted, 'CLt[3] (alpha = 0.2; weighted where 0.1 < alpha < 0.3)'."""
        texts = self._tables()[0]
        labels = self.element_labels()
        return {labels[k]: t for k, t in enumerate(texts) if t}

    def smoothness_weight(self, smoothness):
        """The a priori weight of the tables' smoothness over the free
        parameters, for ``fit(..., prior_weight=...)``.

        The prior's cost is 1/2 sum_tables lambda sum d^2, d each second
        difference between neighbouring values along each variable (the
        change of slope times the mean spacing: v[i-1] - 2 v[i] + v[i+1] on
        even breakpoints) of theta minus the a priori values (by default the
        start: start from a table linear in each variable, zero or constant,
        and d is the table's own).  lambda = 1/sigma^2, sigma the a priori
        spread of one second difference, in the coefficient's units.

        Parameters
        ----------
        smoothness : dict
            {table name: lambda}, lambda a finite number >= 0; 0, like a
            table not named, is no prior on that table.

        Returns
        -------
        numpy.ndarray (nf, nf)
            Over the free parameters, in the order of free; add a diagonal
            of other a priori weights to it.

        Raises
        ------
        InputError
            A name that is no table of the model, or a lambda that is
            negative or not finite (the core's message names the table).
        """
        w = np.zeros((self._theta.size, self._theta.size))
        w[:self.np, :self.np] = self._tables(smoothness)[1]
        idx = self.free_indices()
        return w[np.ix_(idx, idx)]

    def unreached_cells(self, information):
        """The free table values no sample reaches: zero information.

        Parameters
        ----------
        information : FitResult or array_like (nf, nf)
            A fit's result (its ``information``), or an information matrix
            over the free parameters in the order of free.

        Returns
        -------
        list of str
            '... is reached by no sample: not identifiable' for each free
            table value whose row of the information is zero (its
            weight is zero at every sample), in the order of free.
        """
        texts = self._tables()[0]
        return [f"{texts[j]} is reached by no sample: not identifiable"
                for j in self._unreached(information)]

    def unreached_names(self, information):
        """The labels of the free table values no sample reaches (those
        ``unreached_cells`` describes).

        Parameters
        ----------
        information : FitResult or array_like (nf, nf)
            As ``unreached_cells``.

        Returns
        -------
        list of str
            Their labels ('CLt[6]'), in the order of free.
        """
        labels = self.element_labels()
        return [labels[j] for j in self._unreached(information)]

    def _unreached(self, information):
        """The entries (of theta) of the free table values whose row of the
        information is zero."""
        info = np.asarray(getattr(information, "information", information), dtype=float)
        texts = self._tables()[0]
        return [j for k, j in enumerate(self.free_indices()) if j < self.np and texts[j]
                and not np.any(info[k] != 0.0)]


#: The six-degree-of-freedom model's constants, in the core's order (mlid_sixdof).
SIXDOF_CONSTANTS = tuple(n.strip() for n in
                         _api.mlid_sixdof_constants().decode().strip().split(","))


@_documented
@guarded_class
class SixDofModel(EquationModel):
    """The six-degree-of-freedom rigid aircraft in body axes
    (fortran/models/mlid_sixdof.f90), written out as an equations model: states any
    of u, v, w, p, q, r, phi, theta, psi, h; the aerodynamic coefficients
    are definitions over the air data it provides (V, alpha, beta, phat,
    qhat, rhat), the inputs and the parameters.  It adds qbar, the specific
    forces at the centre of gravity ax, ay, az, the moments and pdot, qdot,
    rdot, usable in the outputs.  A kinematic quantity (u ... theta) that is
    not a state must be an input: the decoupled forms.

    Parameters
    ----------
    constants : dict
        m [kg], Ix, Iy, Iz, Ixz [kg m^2], S [m^2], cbar, b [m], g [m/s^2].
    states : sequence of str
        The states, in order.
    outputs : dict
        {name: expression} of each output ('alpha', 'ay', 'pdot', ...).
    inputs : sequence of str, optional
        The inputs' names, in the order of the data's input channels.
    params : dict, optional
        {name: start value} of each model parameter.
    definitions : dict, optional
        The coefficients CX, CZ (or CD, CL), CY, Cl, Cm, Cn as the states
        need them, rho, and optionally thrust T, its inclination sigT and
        moment arm lT, with any intermediate quantities, in order.
    {common}

    Raises
    ------
    {raises}
        Also a constant missing or not positive, an inertia matrix that is
        not positive definite, an unknown state, a kinematic quantity neither
        state nor input, a coefficient a state needs left undefined.
    """

    def __init__(self, constants, states, outputs, inputs=(), params=None, definitions=None,
                 x0=None, bias=None, free=(), names=None, input_hold="linear", substeps=1, q=None,
                 r=None, S=None, ties=None, delay=None, udelay=None, stab=None, p0=None):
        _check_constants(constants, SIXDOF_CONSTANTS)
        definitions = dict(definitions or {})
        pre, post, xs, status, msg = _api.mlid_sixdof_text(
            [float(constants[k]) for k in SIXDOF_CONSTANTS], "".join(f"{n}\n" for n in states),
            "".join(f"{n}\n" for n in inputs), "".join(f"{n}\n" for n in definitions))
        check_status(status, msg)
        equations = dict(line[2:].split(" = ", 1) for line in xs.decode().strip().split("\n")
                         if line.strip())
        self._build(outputs, equations, inputs, params, definitions, pre.decode().strip(),
                    post.decode().strip(), (x0, bias, q, r, S, free, names, ties, input_hold,
                                            substeps, delay, udelay, stab, p0))


#: The flight-path model's constants, corrections, outputs and inputs, in
#: the core's order (mlid_flightpath).
FLIGHTPATH_CONSTANTS, FLIGHTPATH_CORRECTIONS, FLIGHTPATH_OUTPUTS, FLIGHTPATH_INPUTS = (
    tuple(n.strip() for n in b.decode().strip().split(","))
    for b in _api.mlid_flightpath_lists())


@_documented
@guarded_class
class FlightPathModel(EquationModel):
    """Flight-path reconstruction (data compatibility, textbook ch. 10):
    the kinematic equations driven by the measured accelerations and rates
    (fortran/models/mlid_flightpath.f90), written out as an equations model.
    States u, v, w, phi, theta, psi, h; inputs ax, ay, az [m/s^2], p, q, r
    [rad/s], pdot, qdot, rdot [rad/s^2] (FLIGHTPATH_INPUTS, in that order);
    outputs any of V, alpha, beta, phi, theta, psi, h.  The sensor
    corrections present are parameters: accelerometer and gyro biases and
    scale factors (a = (a_m - b_ax)/f_ax), air-data scale factors and biases
    (alpha_m = f_al alpha + b_al, alpha and beta the vanes' flank angles at
    the boom) and a constant wind w_n, w_e, w_d (earth axes); attitude and
    height biases are ``bias(i)``, sensor time delays ``delay(i)``.

    Parameters
    ----------
    constants : dict
        xA, yA, zA: the accelerometer, xN, yN, zN: the air-data boom [m,
        body axes from the centre of gravity]; g [m/s^2].
    corrections : dict
        {name: start value} of each correction the model has (from
        FLIGHTPATH_CORRECTIONS); the rest are absent (neutral).
    outputs : sequence of str, optional
        The outputs, in the order of the data's output channels (default
        all seven).
    {common}

    Raises
    ------
    {raises}
        Also a constant missing, an unknown correction or output, a name
        given twice.
    """

    def __init__(self, constants, corrections=None, outputs=FLIGHTPATH_OUTPUTS, x0=None,
                 bias=None, free=(), names=None, input_hold="linear", substeps=1, q=None, r=None,
                 S=None, ties=None, delay=None, udelay=None, stab=None, p0=None):
        _check_constants(constants, FLIGHTPATH_CONSTANTS)
        if isinstance(outputs, (str, bytes)):
            raise InputError(f"outputs must be a list of names, got the string {outputs!r}")
        corrections = dict(corrections or {})
        text, status, msg = _api.mlid_flightpath_model_text(
            [float(constants[k]) for k in FLIGHTPATH_CONSTANTS],
            "".join(f"{n}\n" for n in corrections), "".join(f"{n}\n" for n in outputs))
        check_status(status, msg)
        self._from_text(text.decode().rstrip(), list(corrections.values()),
                        (x0, bias, q, r, S, free, names, ties, input_hold, substeps, delay,
                         udelay, stab, p0))


def _check_constants(constants, names):
    """constants, a dict, gives exactly the names."""
    missing = [k for k in names if k not in constants]
    if missing or len(constants) != len(names):
        raise InputError(f"constants must give {', '.join(names)}; missing {missing or 'none'}, "
                         f"unknown {sorted(set(constants) - set(names)) or 'none'}")


def _one_line(expression):
    """An expression on one line (the model's text is one item a line)."""
    return " ".join(str(expression).split())


_KINDS = {c.kind: c for c in (LinearModel, LongitudinalModel, UserModel, X22Model, EquationModel)}


def _tie_text(names, offset, sources):
    """A tie's right-hand side as text: 'f(1,3)', or '0.5 + 2.0*g(1,1)'."""
    if offset == 0 and len(sources) == 1 and sources[0][1] == 1:
        return names[sources[0][0]]
    text = repr(offset) if offset else ""
    for j, s in sources:                  # 'c - s*b', never '+ -s*b' (the core reads signs once)
        sign = "-" if s < 0 else "+"
        text += f" {sign} {abs(s)!r}*{names[j]}" if text else f"{s!r}*{names[j]}"
    return text


def free_entries(mask):
    """The free entries of a parameter vector in the order of free.

    Parameters
    ----------
    mask : array_like of int
        mask[k] > 0 is entry k's place among the free parameters, as the
        core takes it (free_indices, fortran/models/mlid_params.f90); equal
        places keep the vector's order (a manoeuvre's own copies of one entry
        share a place); 0 is a fixed entry.

    Returns
    -------
    numpy.ndarray of int
        The 0-based free entries, in the order of free.

    Examples
    --------
    >>> free_entries([0, 3, 0, 1, 2]).tolist()
    [3, 4, 1]
    """
    mask = np.asarray(mask)
    idx = np.flatnonzero(mask > 0)
    return idx[np.argsort(mask[idx], kind="stable")]


def from_core(mkind, sizes, iconst, rconst, theta, isfree, ties, labels, input_hold, substeps):
    """The model a case spec of the core describes (kind, sizes (nx, nu, ny,
    nw), constants, the whole theta with free flags, ties and the free
    parameters' labels); the core has read and checked it."""
    m = object.__new__(_KINDS[mkind])
    m.iconst = np.asarray(iconst, dtype=np.int32)
    m.rconst = np.asarray(rconst, dtype=float)
    m._init_layout(*sizes)
    if mkind == LongitudinalModel.kind:           # each coefficient's regressors, from the core
        lay = m._layout
        m.regressors = {key: lay.regressors[lay.slice(block)]
                        for key, block in LongitudinalModel._COEFFICIENTS.items()}
        m.constants = dict(zip(CONSTANTS, m.rconst))
    m._theta[:] = theta
    names = m.element_names()
    free = [names[k] for k in free_entries(isfree)]
    to, frm, scale, offset = ties
    grouped = {}
    for k, j, s in zip(to, frm, scale):
        grouped.setdefault(int(k) - 1, []).append((int(j) - 1, float(s)))
    ties = {names[k]: _tie_text(names, float(offset[k]), src) for k, src in grouped.items()}
    m._init_common(None, None, None, None, None, free, dict(zip(free, labels)), ties,
                   input_hold, substeps)
    return m
