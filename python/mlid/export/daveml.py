"""A model, or a fit of it, as DAVE-ML 2.0 (ANSI/AIAA S-119): one
``<DAVEfunc>`` holding the model's right-hand side as a static function.

What each part of the model becomes (in the standard's element order):

- an input channel, a state, and t when the model reads it: a
  ``variableDef`` with no calculation (an input of the function); a state is
  marked ``<isState/>``;
- a parameter: a ``variableDef`` with its ``initialValue`` (the estimate,
  for a fit) and, when it was free or tied, its Cramer-Rao sigma as an
  additive normal ``uncertainty`` of one sigma; a definition that is a
  number: the same, as a constant;
- a definition: a ``variableDef`` whose ``calculation`` is the expression
  in MathML-2 content markup (the two-argument arctangent as DAVE-ML's
  ``csymbol`` extension);
- a table: its ``breakpointDef`` per variable, a ``griddedTableDef``
  (values with the last variable varying fastest, as the standard lists
  them; the fit's sigma of each value, free or tied, as an additive normal
  uncertainty table, 0 for a value held, NaN for one no sample reaches,
  named in the table's description) and a ``function`` from the variables to the table's name,
  linear, held beyond the end breakpoints (``extrapolate="neither"``), as
  mlid's tables are;
- each state equation: ``d_NAME``, ``<isStateDeriv/>`` and ``<isOutput/>``;
  an input channel and t are marked ``<isInput/>``;
  each output equation: ``y_NAME``, ``<isOutput/>``.

Optional ``checkData``: static shots at given states and inputs, their
outputs computed by mlid's core (the model's f and h evaluated there,
``mlid.model.point``), with a tolerance, so that a DAVE-ML tool can
verify its reading of the file.

The model's units are kept (mlid's models are in SI and radians); a
name's units are taken from ``UNITS`` (the flight variables and the
six-degree-of-freedom constants, in the standard's recommended
abbreviations), from ``units`` given to the export, or ``nd``
(dimensionless) for the coefficients CX ... Cn and a six-degree-of-freedom
model's parameters (its derivatives).  Anything else is written with units ``"unknown"`` and
said so in its description rather than guessed.
"""

import ast
import datetime
import math
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ..errors import InputError
from ..files import atomic_write_text
from ..model.point import derivatives_at, outputs_at
from . import expressions as ex
from .source import Source, Table

NAMESPACE = "http://daveml.org/2010/DAVEML"
MATHML = "http://www.w3.org/1998/Math/MathML"
DOCTYPE = ('<!DOCTYPE DAVEfunc PUBLIC "-//AIAA//DTD for Flight Dynamic Models - Functions '
           '2.0//EN" "http://daveml.org/DTDs/2p0/DAVEfunc.dtd">')
#: DAVE-ML's extension of MathML-2 for the two-argument arctangent.
ATAN2 = ('<csymbol definitionURL="http://daveml.org/function_spaces.html#atan2" '
         'encoding="text">atan2</csymbol>')
#: The models' functions as MathML-2 content elements (atan2 and log10 apart).
FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "arcsin", "acos": "arccos",
             "atan": "arctan", "sqrt": "root", "abs": "abs", "exp": "exp", "log": "ln",
             "tanh": "tanh", "min": "min", "max": "max"}
#: Units of the names mlid's models share (SI, rad).
UNITS = {"V": "m_s", "u": "m_s", "v": "m_s", "w": "m_s", "p": "rad_s", "q": "rad_s",
         "r": "rad_s", "alpha": "rad", "beta": "rad", "phi": "rad", "theta": "rad",
         "psi": "rad", "h": "m", "rho": "kg_m3", "t": "s", "de": "rad", "da": "rad",
         "dr": "rad", "Mach": "nd", "phat": "nd", "qhat": "nd", "rhat": "nd", "qbar": "Pa",
         "m": "kg", "Ix": "kgm2", "Iy": "kgm2", "Iz": "kgm2", "Ixz": "kgm2", "S": "m2",
         "cbar": "m", "b": "m", "g": "m_s2", "ax": "m_s2", "ay": "m_s2", "az": "m_s2",
         "pdot": "rad_s2", "qdot": "rad_s2", "rdot": "rad_s2", "Lmom": "Nm", "Mmom": "Nm",
         "Nmom": "Nm"}
#: The six-degree-of-freedom model's coefficients (dimensionless).
COEFFICIENTS = ("CX", "CY", "CZ", "CD", "CL", "Cl", "Cm", "Cn")
TOLERANCE = 1e-9          # relative, of a check output


def daveml(model_or_result, path, checks=None, units=None, name="mlid", author="mlid",
           org="mlid", date=None):
    """Write a model (or a fit of it) as a DAVE-ML 2.0 file.

    Parameters
    ----------
    model_or_result : EquationModel, SixDofModel or FitResult
        A model written as equations (``SixDofModel``, ``EquationModel``,
        ``LongitudinalModel.with_tables``), or its fit: the estimates and
        each free value's sigma.
    path : str or Path
        The file, written whole or not at all.
    checks : sequence of dict, optional
        Static check cases: each {state or input: value} for every state
        and input (and t if the model reads it); written as ``checkData``
        with the outputs mlid computes there.
    units : dict, optional
        {name: units} for names ``UNITS`` does not know.
    name, author, org : str
        The file header's model name and author.
    date : str, optional
        The creation date, YYYY-MM-DD (default today).

    Returns
    -------
    str
        The text written.

    Raises
    ------
    InputError
        A model not written as equations, an expression with no MathML
        form, a check case missing a value, a file that cannot be written.
    """
    text = daveml_text(model_or_result, checks, units, name, author, org, date)
    atomic_write_text(path, text)
    return text


def daveml_text(model_or_result, checks=None, units=None, name="mlid", author="mlid",
                org="mlid", date=None):
    """The DAVE-ML text ``daveml`` writes."""
    src = Source(model_or_result)
    w = _Writer(src, units or {})
    date = date or datetime.date.today().isoformat()
    try:
        datetime.date.fromisoformat(date)
    except (TypeError, ValueError):
        raise InputError(f"DAVE-ML export: date {date!r} is not YYYY-MM-DD") from None
    body = (w.variables() + w.breakpoints() + w.gridded_tables() + w.functions()
            + (w.check_data(checks) if checks else []))
    what = "a fit's estimates, free values with their sigma" if src.fitted else \
        "a model's values"
    head = ['<?xml version="1.0" encoding="UTF-8"?>', DOCTYPE,
            f'<DAVEfunc xmlns="{NAMESPACE}">',
            f"  <fileHeader name={quoteattr(name)}>",
            f"    <author name={quoteattr(author)} org={quoteattr(org)}/>",
            f'    <creationDate date="{date}"/>',
            f"    <description>{escape(name)}: {what}, exported by mlid (the model's "
            f"right-hand side: d_NAME is a state's derivative, y_NAME an output; SI units, "
            f"rad)</description>",
            "  </fileHeader>"]
    return "\n".join(head + ["  " + line for line in body] + ["</DAVEfunc>", ""])


class _Writer:
    """The elements of one model, in the order DAVEfunc takes them."""

    def __init__(self, src, units):
        self.src, self.units = src, dict(units)
        self.sixdof = all(n in dict(src.definitions) for n in ("rhat", "qbar", "Ixz"))
        self.names = set()

    def unit(self, name):
        if name in self.units:
            return self.units[name]
        if name in UNITS:
            return UNITS[name]
        if name in COEFFICIENTS or (self.sixdof and name in self.src.params):
            return "nd"
        return "unknown"

    def _var(self, var_id, inner, initial=None):
        if var_id in self.names:
            raise InputError(f"DAVE-ML export: the name {var_id!r} is given twice")
        self.names.add(var_id)
        unit = self.unit(var_id)
        note = [f"<description>{escape(var_id)}: units as the model's (not "
                f"stated)</description>"] if unit == "unknown" else []
        value = "" if initial is None else f' initialValue="{ex.number(initial)}"'
        head = f'<variableDef name="{var_id}" varID="{var_id}" units="{unit}"{value}'
        if not note + inner:
            return [head + "/>"]
        return [head + ">"] + ["  " + line for line in note + inner] + ["</variableDef>"]

    def _uncertainty(self, bounds):
        return ['<uncertainty effect="additive">', '  <normalPDF numSigmas="1">',
                *("    " + line for line in ["<bounds>", *("  " + b for b in bounds),
                                             "</bounds>"]),
                "  </normalPDF>", "</uncertainty>"]

    # variables -----------------------------------------------------------
    def variables(self):
        src, out = self.src, []
        read = set()
        for _, d in src.definitions:
            read |= set(d.variables) if isinstance(d, Table) else \
                ex.names(ex.parse(d, "a definition"))
        for e in [*src.equations.values(), *src.outputs.values()]:
            read |= ex.names(ex.parse(e, "an equation"))
        for n in src.inputs:
            out += self._var(n, ["<isInput/>"])
        for n in src.states:
            out += self._var(n, ["<isState/>"])
        if "t" in read and "t" not in src.params:
            out += self._var("t", ["<isInput/>"])
        for n in src.params:
            s = src.sigma.get(n)
            inner = [] if s is None else self._uncertainty([ex.number(s)]) if math.isfinite(s) \
                else [f"<description>{n}: not identified by the fit (no sigma)</description>"]
            out += self._var(n, inner, initial=src.value(n))
        for n, d in src.definitions:
            if isinstance(d, Table):
                out += self._var(n, [])                   # a function's output
            elif _is_number(d):
                out += self._var(n, [], initial=float(d))
            else:
                out += self._var(n, self._calculation(d, f"definition {n}"))
        for n, e in src.equations.items():
            self.units.setdefault(f"d_{n}", _per_second(self.unit(n)))
            out += self._var(f"d_{n}", self._calculation(e, f"state equation {n}")
                             + ["<isStateDeriv/>", "<isOutput/>"])
        for n, e in src.outputs.items():
            self.units.setdefault(f"y_{n}", self.unit(n))
            out += self._var(f"y_{n}", self._calculation(e, f"output {n}") + ["<isOutput/>"])
        return out

    def _calculation(self, expr, where):
        return ["<calculation>", f'  <math xmlns="{MATHML}">',
                *("    " + line for line in _mathml(ex.parse(expr, where), where)),
                "  </math>", "</calculation>"]

    # tables --------------------------------------------------------------
    def breakpoints(self):
        out = []
        for t in self.src.tables:
            for v, b in zip(t.variables, t.breakpoints):
                out += [f'<breakpointDef bpID="{_bp_id(t, v)}" units="{self.unit(v)}">',
                        f"  <bpVals>{', '.join(ex.number(x) for x in b)}</bpVals>",
                        "</breakpointDef>"]
        return out

    def gridded_tables(self):
        out = []
        for t in self.src.tables:
            refs = [f'    <bpRef bpID="{_bp_id(t, v)}"/>' for v in t.variables]
            # sigma: the fit's (free or tied), 0 for a value held, NaN for one
            # the fit estimated but no sample reaches (said in the description)
            names = t.labels
            estimated = np.array([n in self.src.sigma for n in names]).reshape(t.values.shape,
                                                                               order="F")
            sigma = np.where(estimated, t.sigma, 0.0)
            unc = self._uncertainty(_data_table(sigma)) if estimated.any() else []
            lost = [n for n in names if n in self.src.sigma and not
                    math.isfinite(self.src.sigma[n])]
            note = [f"  <description>not identified (reached by no sample; sigma NaN, the "
                    f"value its start): {', '.join(lost)}</description>"] if lost else []
            out += ([f'<griddedTableDef name="{t.name}" gtID="{t.name}_table" '
                     f'units="{self.unit(t.name)}">', *note, "  <breakpointRefs>", *refs,
                     "  </breakpointRefs>"] + ["  " + line for line in unc]
                    + ["  " + line for line in _data_table(t.values)] + ["</griddedTableDef>"])
        return out

    def functions(self):
        out = []
        for t in self.src.tables:
            ind = [f'  <independentVarRef varID="{v}" min="{ex.number(b[0])}" '
                   f'max="{ex.number(b[-1])}" extrapolate="neither"/>'
                   for v, b in zip(t.variables, t.breakpoints)]
            out += [f'<function name="{t.name}">', *ind,
                    f'  <dependentVarRef varID="{t.name}"/>',
                    "  <functionDefn>", f'    <griddedTableRef gtID="{t.name}_table"/>',
                    "  </functionDefn>", "</function>"]
        return out

    # check cases ---------------------------------------------------------
    def check_data(self, checks):
        src = self.src
        needed = [*src.inputs, *src.states] + (["t"] if "t" in self.names else [])
        outputs = [f"d_{n}" for n in src.equations] + [f"y_{n}" for n in src.outputs]
        out = ["<checkData>"]
        for k, shot in enumerate(checks):
            missing = [n for n in needed if n not in shot]
            extra = sorted(set(shot) - set(needed))
            if missing or extra:
                raise InputError(f"DAVE-ML export: check case {k + 1}: "
                                 + (f"no value for {', '.join(missing)}" if missing else
                                    f"{', '.join(extra)} is not a state or input"))
            values = _evaluate(src, outputs, shot)
            sig_in = [self._signal(n, shot[n]) for n in needed]
            sig_out = [self._signal(n, values[n], tol=TOLERANCE * max(1.0, abs(values[n])))
                       for n in outputs]
            out += [f'  <staticShot name="check {k + 1}">', "    <checkInputs>",
                    *("      " + line for s in sig_in for line in s), "    </checkInputs>",
                    "    <checkOutputs>", *("      " + line for s in sig_out for line in s),
                    "    </checkOutputs>", "  </staticShot>"]
        return out + ["</checkData>"]

    def _signal(self, name, value, tol=None):
        if not math.isfinite(value):
            raise InputError(f"DAVE-ML export: {name} is not finite at a check case")
        return (["<signal>", f"  <signalName>{name}</signalName>",
                 f"  <signalUnits>{self.unit(name)}</signalUnits>",
                 f"  <signalValue>{ex.number(value)}</signalValue>"]
                + ([f"  <tol>{ex.number(tol)}</tol>"] if tol is not None else [])
                + ["</signal>"])


def _evaluate(src, names, shot):
    """The exported quantities (d_NAME, y_NAME) at one check case, computed
    by the core (the model's f and h there, without output biases, as the
    file's y_NAME)."""
    x = [shot[n] for n in src.states]
    u = [shot[n] for n in src.inputs]
    t = shot.get("t", 0.0)
    values = dict(zip([f"d_{n}" for n in src.states], derivatives_at(src.model, x, u, t)))
    values.update(zip([f"y_{n}" for n in src.outputs], outputs_at(src.model, x, u, t)))
    return {n: float(values[n]) for n in names}


def _bp_id(t, variable):
    return f"{t.name}_{variable}_bp"


def _data_table(values):
    """A <dataTable>, the last variable fastest (row-major), a row per line."""
    rows = np.asarray(values, dtype=float).reshape(-1, np.shape(values)[-1])
    lines = [", ".join(ex.number(v) for v in row) for row in rows]
    return ["<dataTable>", *("  " + line + ("," if i < len(lines) - 1 else "")
                             for i, line in enumerate(lines)), "</dataTable>"]


def _is_number(expr):
    try:
        float(expr)
    except ValueError:
        return False
    return True


def _per_second(unit):
    """The units of a quantity's rate (m_s -> m_s2, rad -> rad_s)."""
    if unit.endswith("_s"):
        return unit + "2"
    return unit + "_s" if unit in ("rad", "m", "kg", "Pa") else "unknown"


def _mathml(tree, where):
    """MathML-2 content markup of an expression's tree, one list of lines."""
    if isinstance(tree, ast.Constant) and isinstance(tree.value, (int, float)):
        return [f"<cn>{ex.number(tree.value)}</cn>"]
    if isinstance(tree, ast.Name):
        return ["<pi/>"] if tree.id == "pi" else [f"<ci>{tree.id}</ci>"]
    if isinstance(tree, ast.UnaryOp) and isinstance(tree.op, (ast.USub, ast.UAdd)):
        inner = _mathml(tree.operand, where)
        return inner if isinstance(tree.op, ast.UAdd) else _apply("<minus/>", [inner])
    ops = {ast.Add: "<plus/>", ast.Sub: "<minus/>", ast.Mult: "<times/>",
           ast.Div: "<divide/>", ast.Pow: "<power/>"}
    if isinstance(tree, ast.BinOp) and type(tree.op) in ops:
        if isinstance(tree.op, (ast.Add, ast.Mult)):
            parts = [*ex._flat(tree.left, type(tree.op)), *ex._flat(tree.right, type(tree.op))]
        else:
            parts = [tree.left, tree.right]
        return _apply(ops[type(tree.op)], [_mathml(p, where) for p in parts])
    if isinstance(tree, ast.Call) and isinstance(tree.func, ast.Name) and not tree.keywords:
        fn, args = tree.func.id, [_mathml(a, where) for a in tree.args]
        if fn == "atan2" and len(args) == 2:
            return _apply(ATAN2, args)
        if fn == "log10" and len(args) == 1:
            return _apply("<log/>", [["<logbase>", "  <cn>10</cn>", "</logbase>"], args[0]])
        if fn in FUNCTIONS and (len(args) == 1 or fn in ("min", "max")):
            return _apply(f"<{FUNCTIONS[fn]}/>", args)
    raise InputError(f"DAVE-ML export: {where}: MathML has no form for {ast.unparse(tree)!r}")


def _apply(op, parts):
    return ["<apply>", f"  {op}", *("  " + line for part in parts for line in part),
            "</apply>"]
