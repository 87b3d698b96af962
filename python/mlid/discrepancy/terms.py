"""Nonlinear-term candidates for the models stated as equations
(EquationModel, SixDofModel).

A candidate is one term, a power, |x|*x, a product or a breakpoint
max(x - b, 0), with a new coefficient appended to one equation of the
model's own text.  The core differentiates that text exactly, so the
extended model is as exact as the base one: no regressor input made from
estimates, and the term follows the model's states wherever a fit or a
simulation takes them.  Whether a term is worth fitting is decided by its
score (Lagrange-multiplier) statistic at the base fit, ``Term.score``:
one evaluation of the extended model, no fit.

Where the terms go:

- EquationModel: each state equation and output that depends on an
  estimated parameter (free or tied; directly or through definitions); a
  kinematic equation, with no parameter, gets none.  The terms are over the
  model's states x and inputs u: x^2, |x|*x, x*y for each pair of states,
  x*u; breakpoints in a state that an output measures alone.  A model
  without states (a regression) takes the inputs each output reads in the
  role of x, with breakpoints at their own quantiles.
- SixDofModel: each aerodynamic coefficient definition (CX, CZ, CD, CL, CY,
  Cl, Cm, Cn) that depends on an estimated parameter and is not written
  from the others (CX and CZ from CD and CL: the terms go in those), over
  the air data (alpha, beta, phat, qhat, rhat) in the role of x and the
  control inputs in the role of u (not the kinematic quantities, nor what
  feeds rho and the thrust); breakpoints in alpha and beta.

A quantity that does not vary over the record (qhat with the pitch rate a
zero input, alpha from constant u and w) is left out: its square is a
constant and its products are scaled copies of the other variable, terms
the model's linear parameters already span.
"""

import re

import numpy as np

from ..design.simulate import simulate
from ..errors import DivergenceError, InputError
from ..estimate.evaluate import evaluate
from ..model.models import EquationModel, FlightPathModel, SixDofModel
from . import score_test

#: The quantiles of the measured variable where breakpoints are put.
QUANTILES = (0.25, 0.5, 0.75)
#: The six-degree-of-freedom model's air data and aerodynamic coefficients
#: (fortran/models/mlid_sixdof.f90 defines the first, the user the second).
AIR_DATA = ("alpha", "beta", "phat", "qhat", "rhat")
COEFFICIENTS = ("CX", "CZ", "CD", "CL", "CY", "Cl", "Cm", "Cn")
#: Breakpoints of the six-degree-of-freedom kind: stall and sideslip.
BREAKPOINT_AIR_DATA = ("alpha", "beta")
#: Quantities that are not control inputs when the six-degree-of-freedom
#: model takes them as inputs: the kinematic ones (decoupled forms), the air
#: density and the thrust with what its definitions read.
KINEMATIC = ("u", "v", "w", "p", "q", "r", "phi", "theta", "psi", "h")
PROPULSION = ("rho", "T", "sigT", "lT")
#: The core's longest name (fortran/models/mlid_equations.f90, NAMELEN) less one.
NAME_MAX = 31
#: A term whose information, with the free parameters partialled out, is
#: below this share of its own is one they already span: score 0.
CONFOUNDED = 1e-8
#: The keyword arguments of Model._init_common, in its order.
_COMMON = ("x0", "bias", "q", "r", "S", "free", "names", "ties", "input_hold", "substeps",
           "delay", "udelay", "stab")
#: One line of the model's text: kind, name and the expression after ' = '.
_LINE = re.compile(r"^([xylup])\s+([^\s=]+)\s*(?:=\s*(.*))?$")
#: A number (so that the e of 1.5e-3 is not read as a name) or a name.
_TOKEN = re.compile(r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|([A-Za-z_]\w*)")


class Term:
    """One candidate term in one equation of a model.

    Attributes
    ----------
    equation : str
        Where the term goes: 'the q equation', 'the ay output', 'the Cl
        definition'.
    label : str
        The term as an engineer writes it: 'alpha^2', '|beta|*beta',
        'alpha*de', 'max(alpha - 0.12, 0)'.
    expression : str
        The term in the model's language (abs(beta)*beta for |beta|*beta).
    param : str
        The name of its coefficient in the extended model (and in a fit's
        ``names``): 'Cl_absbeta_beta', 'qdot_alpha2'.
    """

    def __init__(self, model, line, equation, label, expression, param):
        self._model, self._line = model, line
        self.equation, self.label, self.expression, self.param = (equation, label, expression,
                                                                   param)

    def extend(self):
        """The model with this term appended to its equation.

        The coefficient is a new parameter after the existing p (every
        existing element keeps its name and index), start value 0, free;
        x0, biases, noise, delays, ties, labels and the free set are kept.

        Returns
        -------
        model : EquationModel or SixDofModel
            The same kind, one parameter more.
        param : str
            The coefficient's name, as a fit's ``names`` gives it.
        """
        model, params = extended(self._model, [self])
        return model, params[0]

    def score(self, data, **options):
        """The score (Lagrange-multiplier) statistic of the term at the
        base model's parameters: g_c^2 / (M_cc - M_ct M_tt^-1 M_tc), the
        gradient g and information M of the extended model at coefficient
        0 (one ``mlid.evaluate``), c the term, t the free parameters,
        which it partials out.  At the base fit (g_t = 0) it is
        asymptotically chi-square with one degree of freedom when the
        term is absent.

        Parameters
        ----------
        data : FlightData or list of FlightData
            The record the base model was fitted to.
        **options
            Estimator options, as for ``mlid.evaluate``.

        Returns
        -------
        float
            The statistic; 0 when the free parameters already span the
            term (its partialled information below CONFOUNDED of its own).

        Raises
        ------
        MlidError
            As ``mlid.evaluate`` raises.
        """
        model, param = self.extend()
        ev = evaluate(model, data, **options)
        names = model.free_names()
        c = names.index(param)
        score, share, _ = score_test.statistics(ev["gradient"], ev["information"],
                                                [k for k in range(len(names)) if k != c], [c])
        return float(score[0]) if share[0] > CONFOUNDED else 0.0

    def __repr__(self):
        return f"Term({self.label!r} in {self.equation}, coefficient {self.param})"


def extended(model, terms):
    """The model with each term appended to its equation, each with its own
    coefficient: new parameters after the existing p (every existing element
    keeps its name and index), start value 0, free; x0, biases, noise,
    delays, ties, labels and the free set are kept.

    Parameters
    ----------
    model : EquationModel or SixDofModel
        The model the terms were made for.
    terms : sequence of Term
        From ``candidates(model, ...)``.

    Returns
    -------
    model : EquationModel or SixDofModel
        The same kind, len(terms) parameters more.
    params : list of str
        The coefficients' names, as a fit's ``names`` gives them.
    """
    lines = _text_lines(model)
    for t in terms:
        lines[t._line] += f" + {t.param}*{t.expression}"
    # after the last parameter (p(np+1) is the first new one), else after the inputs
    kinds = [line[:1] for line in lines]
    last = "p" if "p" in kinds else "u"
    at = max((k + 1 for k, c in enumerate(kinds) if c == last), default=0)
    lines[at:at] = [f"p {t.param}" for t in terms]
    common = model._common()
    common["free"] = list(model.free) + [f"p({model.np + 1 + k})" for k in range(len(terms))]
    m = object.__new__(type(model))        # the constructor path of the class's text
    m._from_text("\n".join(lines), np.r_[model.p, np.zeros(len(terms))],
                 tuple(common[k] for k in _COMMON))
    return m, [t.param for t in terms]


def candidates(model, data):
    """The nonlinear-term candidates of an equations or six-degree-of-
    freedom model (the module's docstring says which), for the record.

    Parameters
    ----------
    model : EquationModel or SixDofModel
        The base model, at its fitted parameters (the scores are taken
        there).
    data : FlightData or list of FlightData
        The record: the breakpoints are at quantiles of its measured
        variables, and variables constant over it are left out.

    Returns
    -------
    list of Term
        By equation in the order of the model's text, then by kind:
        squares, |x|*x, products of pairs, products with inputs,
        breakpoints.

    Raises
    ------
    InputError
        Another model kind (one line naming it); a record the model cannot
        be simulated on.
    """
    if not isinstance(model, EquationModel) or isinstance(model, FlightPathModel):
        raise InputError(f"nonlinear-term candidates: a {type(model).__name__} is not a kind "
                         "they are written in (EquationModel or SixDofModel; the linear and "
                         "longitudinal kinds have theirs in mlid.diagnose)")
    lines = [_parse(line) for line in _text_lines(model)]
    uses = _uses(lines)
    own = dict(zip(model.element_names(), model.element_labels()))   # as the text names them
    estimated = {own[e] for e in [*model.free, *model.ties]}
    names = [name for _, name, _ in lines]
    inputs = [n for kind, n, _ in lines if kind == "u"]
    records = data if isinstance(data, (list, tuple)) else [data]
    if isinstance(model, SixDofModel):
        # CX and CZ written from CD and CL (wind to body axes) get none: those do
        where = [k for k, (kind, name, expression) in enumerate(lines)
                 if kind == "l" and name in COEFFICIENTS and uses[k] & estimated
                 and not _names_in(expression) & set(COEFFICIENTS)]
        feeds = set(PROPULSION).union(*(uses[k] for k, (kind, name, _) in enumerate(lines)
                                        if kind == "l" and name in PROPULSION))
        xs = [a for a in AIR_DATA if a in names]
        us = [n for n in inputs if n not in KINEMATIC and n not in feeds]
        breaks = [a for a in BREAKPOINT_AIR_DATA if a in xs]
    else:
        where = [k for k, (kind, _, _) in enumerate(lines)
                 if kind in "xy" and uses[k] & estimated]
        xs = [n for kind, n, _ in lines if kind == "x"]
        # without states (a regression) the inputs are the measured variables
        xs, us = (xs, inputs) if xs else (inputs, [])
        breaks = xs
    varying = _varying(model, records, xs + us)
    xs, us = [x for x in xs if x in varying], [u for u in us if u in varying]
    measured = _measured(model, lines, records, [b for b in breaks if b in xs])
    taken = {n.lower() for n in names} | {"t", "pi"}
    out = []
    for k in where:
        kind, name, _ = lines[k]
        if isinstance(model, SixDofModel):
            equation, prefix = f"the {name} definition", name
        elif kind == "x":
            equation, prefix = f"the {name} equation", f"{name}dot"
        else:
            equation, prefix = f"the {name} output", name
        # a regression's inputs serve every output: each takes those it reads
        xk = xs if model.nx else [x for x in xs if x in uses[k]]
        for label, expression, suffix in _terms(xk, us, {x: measured[x] for x in xk
                                                         if x in measured}):
            param = _fresh(f"{prefix}_{suffix}", taken, model.np + 1)
            out.append(Term(model, k, equation, label, expression, param))
    return out


def _terms(xs, us, measured):
    """(label, expression, name suffix) of every term over the variables xs
    (states or air data), the inputs us, and the breakpoints
    {variable: its measured values}."""
    out = [(f"{x}^2", f"{x}^2", f"{x}2") for x in xs]
    out += [(f"|{x}|*{x}", f"abs({x})*{x}", f"abs{x}_{x}") for x in xs]
    out += [(f"{x}*{y}", f"{x}*{y}", f"{x}_{y}") for i, x in enumerate(xs) for y in xs[i + 1:]]
    out += [(f"{x}*{u}", f"{x}*{u}", f"{x}_{u}") for x in xs for u in us]
    for x, values in measured.items():
        seen = set()
        for q in QUANTILES:
            b = float(f"{np.quantile(values, q):.3g}")   # readable; any b in range serves
            if b in seen:
                continue
            seen.add(b)
            pct = round(100 * q)
            above = f"max({x} - {b:g}, 0)" if b >= 0 else f"max({x} + {-b:g}, 0)"
            out += [(above, above, f"{x}_above{pct}"),
                    (f"max({b:g} - {x}, 0)", f"max({b:g} - {x}, 0)", f"{x}_below{pct}")]
    return out


def _text_lines(model):
    """The lines of the model's text (a deck's ends with a newline)."""
    return [line.strip() for line in model.text.split("\n") if line.strip()]


def _parse(line):
    """(kind, name, expression or None) of one line of a model's text."""
    m = _LINE.match(line)
    if not m:
        raise InputError(f"nonlinear-term candidates: cannot read the model's line {line!r}")
    return m.group(1), m.group(2), m.group(3)


def _names_in(expression):
    return {m.group(1) for m in _TOKEN.finditer(expression or "") if m.group(1)}


def _uses(lines):
    """The names each line reads, directly or through the definitions
    before it (the text defines a name before its use)."""
    defined, out = {}, []
    for kind, name, expression in lines:
        direct = _names_in(expression)
        used = direct.union(*(defined[n] for n in direct if n in defined))
        if kind == "l":
            defined[name] = used
        out.append(used)
    return out


def _varying(model, records, variables):
    """The variables that vary over the records, by a simulation of the
    model with them as its outputs (air data and states are the model's,
    not measured).  A model that cannot be simulated (unstable without its
    stabilising gain) keeps them all."""
    if not variables:
        return set()
    lines = [line for line in _text_lines(model) if not line.startswith("y ")]
    lines += [f"y probe_{k} = {v}" for k, v in enumerate(variables)]
    probe = object.__new__(type(model))
    probe._from_text("\n".join(lines), model.p,
                     (model.x0, None, None, None, None, [], None, None, model.input_hold,
                      model.substeps, None, model.udelay, None))
    try:
        values = np.vstack([simulate(probe, d.t, d.u)[0].y for d in records])
    except DivergenceError:
        return set(variables)
    spread = np.ptp(values, axis=0)
    return {v for v, s, a in zip(variables, spread, np.abs(values).max(axis=0))
            if s > 1e-9 * (1 + a)}


def _measured(model, lines, records, variables):
    """{variable: its measured values} for each variable an output measures
    alone (its expression is the name; less the output's bias) or that is
    an input."""
    outputs = [expression.strip() for kind, _, expression in lines if kind == "y"]
    inputs = [name for kind, name, _ in lines if kind == "u"]
    out = {}
    for v in variables:
        if v in outputs:
            i = outputs.index(v)
            out[v] = np.concatenate([d.y[:, i] for d in records]) - model.bias[i]
        elif v in inputs:                       # a regression's input: measured itself
            out[v] = np.concatenate([d.u[:, inputs.index(v)] for d in records])
    return out


def state_biases(model):
    """A constant in each state equation of an EquationModel that depends on
    an estimated parameter (a thrust or moment offset: issue 47's
    state-equation bias), as terms whose expression is 1; the kinematic
    equations get none.

    Parameters
    ----------
    model : EquationModel
        Not a six-DOF or flight-path model (their state equations are the
        core's, not the text's).

    Returns
    -------
    list of Term
        Labelled 'bias', coefficient '<state>dot_bias', by state.

    Raises
    ------
    InputError
        Another model kind (one line naming it).
    """
    if not isinstance(model, EquationModel) or isinstance(model, (SixDofModel, FlightPathModel)):
        raise InputError(f"state-equation biases: a {type(model).__name__} has no state "
                         "equations in its text (EquationModel has)")
    lines = [_parse(line) for line in _text_lines(model)]
    uses = _uses(lines)
    own = dict(zip(model.element_names(), model.element_labels()))
    estimated = {own[e] for e in [*model.free, *model.ties]}
    taken = {name.lower() for _, name, _ in lines} | {"t", "pi"}
    return [Term(model, k, f"the {name} equation", "bias", "1",
                 _fresh(f"{name}dot_bias", taken, model.np + 1))
            for k, (kind, name, _) in enumerate(lines) if kind == "x" and uses[k] & estimated]


def _fresh(name, taken, index):
    """name, made unique (case-insensitively, as the core reads names) and
    short enough for the core; taken is updated."""
    if len(name) > NAME_MAX:
        name = f"term{index}"
    base, k = name, 1
    while name.lower() in taken:
        k += 1
        name = f"{base[:NAME_MAX - len(str(k)) - 1]}_{k}"
    taken.add(name.lower())
    return name
