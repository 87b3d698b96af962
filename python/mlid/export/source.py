"""What an export reads of a model or a fit: the model's text (the core's
equations, one item a line: inputs, parameters, definitions, tables,
states, outputs), its parameters' values and, from a fit, their sigma."""

import numpy as np

from ..errors import InputError


class Table:
    """One table of a model: its variables, breakpoints, values and (from
    a fit) each value's sigma (NaN: not free, no sigma)."""

    def __init__(self, name, variables, breakpoints, values, sigma):
        self.name, self.variables, self.breakpoints = name, variables, breakpoints
        self.values, self.sigma = values, sigma


class Source:
    """A model's parts by name, in the text's order.

    Attributes
    ----------
    model : EquationModel
    inputs, params, states : list of str
    definitions : list of (name, expression or Table)
    equations, outputs : dict
        {state: its derivative's expression}, {output: its expression}.
    sigma : dict
        {free parameter: sigma} of a fit (empty for a model).
    """

    def __init__(self, model_or_result):
        model = getattr(model_or_result, "model", model_or_result)
        if not hasattr(model, "text"):
            raise InputError(f"export: a model written as equations (SixDofModel, "
                             f"EquationModel, LongitudinalModel.with_tables) or its fit's "
                             f"result is needed, got {type(model).__name__}")
        self.model = model
        self.fitted = model is not model_or_result
        names = getattr(model_or_result, "names", None) if self.fitted else None
        sigma = getattr(model_or_result, "sigma", None) if self.fitted else None
        self.sigma = ({} if names is None or sigma is None
                      else {n: float(s) for n, s in zip(names, np.ravel(sigma))})
        self.inputs, self.params, self.states = [], [], []
        self.definitions, self.outputs, self.equations = [], {}, {}
        for line in model.text.split("\n"):
            kind, _, rest = line.partition(" ")
            if kind == "u":
                self.inputs.append(rest.strip())
            elif kind == "p":
                self.params.append(rest.strip())
            elif kind == "l":
                name, _, expr = rest.partition(" = ")
                self.definitions.append((name.strip(), expr.strip()))
            elif kind == "t":
                self.definitions.append(self._table(rest))
            elif kind == "x":
                name, _, expr = rest.partition(" = ")
                self.states.append(name.strip())
                self.equations[name.strip()] = expr.strip()
            elif kind == "y":
                name, _, expr = rest.partition(" = ")
                self.outputs[name.strip()] = expr.strip()

    def value(self, name):
        """A parameter's value in the model (the estimate, for a fit)."""
        return float(self.model.value(name))

    def _table(self, rest):
        head, _, bps = rest.partition(" = ")
        name, _, variables = head.partition("(")
        name = name.strip()
        variables = tuple(v.strip() for v in variables.rstrip(") ").split(","))
        breakpoints = tuple(np.array([float(x) for x in b.split()]) for b in bps.split(";"))
        shape = tuple(b.size for b in breakpoints)
        idx = np.indices(shape).reshape(len(shape), -1, order="F").T
        labels = [f"{name}[{','.join(str(i + 1) for i in ijk)}]" for ijk in idx]
        values = np.array([self.value(n) for n in labels]).reshape(shape, order="F")
        sigma = np.array([self.sigma.get(n, np.nan) for n in labels]).reshape(shape, order="F")
        return name, Table(name, variables, breakpoints, values, sigma)

    @property
    def tables(self):
        """The model's tables, in the text's order."""
        return [d for _, d in self.definitions if isinstance(d, Table)]
