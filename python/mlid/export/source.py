"""What an export reads of a model or a fit: the model's text (the core's
equations, one item a line: inputs, parameters, definitions, tables,
states, outputs), its parameters' values and, from a fit, their sigma."""

import numpy as np

from ..errors import InputError


class Table:
    """One table of a model: its variables, breakpoints, values, each
    value's parameter label ('CLt[2,1]', in p's order) and (from a fit)
    sigma (NaN: not estimated, or reached by no sample)."""

    def __init__(self, name, variables, breakpoints, values, sigma, labels):
        self.name, self.variables, self.breakpoints = name, variables, breakpoints
        self.values, self.sigma, self.labels = values, sigma, labels


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
        {parameter: sigma} of a fit's free and tied model parameters (its
        ``covariance_of``; NaN for a free table value no sample reaches);
        empty for a model.
    """

    def __init__(self, model_or_result):
        model = getattr(model_or_result, "model", model_or_result)
        if not hasattr(model, "text"):
            raise InputError(f"export: a model written as equations (SixDofModel, "
                             f"EquationModel, LongitudinalModel.with_tables) or its fit's "
                             f"result is needed, got {type(model).__name__}")
        self.model = model
        self.fitted = model is not model_or_result
        self.sigma = _sigma(model_or_result) if self.fitted else {}
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
        return name, Table(name, variables, breakpoints, values, sigma, labels)

    @property
    def tables(self):
        """The model's tables, in the text's order."""
        return [d for _, d in self.definitions if isinstance(d, Table)]


def _sigma(result):
    """{label: sigma} of the model parameters (p) a fit estimated, free or
    tied (FitResult.covariance_of; a global table fit's own FitResult)."""
    result = getattr(result, "result", result)
    model = result.model
    labels = model.element_labels()[:model.np]
    tied = {labels[k] for k in model.tie_terms() if k < model.np}
    free = set(result.names)
    shown = [n for n in labels if n in free or n in tied]
    cov = np.asarray(result.covariance_of(shown), dtype=float) if shown else np.zeros((0, 0))
    return {n: float(np.sqrt(v)) if np.isfinite(v) else float("nan")
            for n, v in zip(shown, np.diag(cov))}
