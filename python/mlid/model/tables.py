"""Table-lookup coefficients of the models written as equations
(fortran/models/mlid_tables.f90): a coefficient or derivative over one to
three flight-condition variables, given by its breakpoints, its values the
model's parameters, interpolated (multi)linearly and held beyond the ends.

A table is a definition of an ``EquationModel`` or ``SixDofModel``:
``definitions={'CLt': Table('alpha', [0, 0.1, 0.2, 0.3], [0.2, 0.6, 1.0, 1.2]),
'CL': 'CLt + CLq*qhat'}``.  Its values are parameters named
``'CLt[i]'``, ``'CLt[i,j]'``, ``'CLt[i,j,k]'`` (1-based, the value at the
i-th breakpoint of the first variable, ...), free, fixed, tied, bounded
and with a prior like any other.
"""

import numpy as np

from ..errors import InputError


class Table:
    """A table over flight-condition variables.

    Parameters
    ----------
    variables : str or sequence of str
        One to three names the model knows where the table is defined:
        states, inputs, parameters, earlier definitions (``'alpha'``,
        ``'Mach'``, a configuration flag).
    breakpoints : sequence
        Each variable's breakpoints, increasing, at least two; for one
        variable the list itself or a list of it.
    values : array_like, optional
        Start values, shape (n1[, n2[, n3]]), values[i, j] at breakpoints
        (b1[i], b2[j]); default zero.

    Raises
    ------
    InputError
        Values of the wrong shape, a breakpoint that is not a number, more
        than three variables (the core checks the rest: increasing
        breakpoints, known variables).

    Examples
    --------
    >>> t = Table("alpha", [0.0, 0.1, 0.2], [0.1, 0.5, 0.8])
    >>> t.line("CLt")
    't CLt(alpha) = 0.0 0.1 0.2'
    >>> t.value_names("CLt")
    ['CLt[1]', 'CLt[2]', 'CLt[3]']
    """

    def __init__(self, variables, breakpoints, values=None):
        self.variables = (variables,) if isinstance(variables, str) else tuple(variables)
        if not 1 <= len(self.variables) <= 3:
            raise InputError(f"a table has one to three variables, got {len(self.variables)}")
        if len(self.variables) == 1 and np.ndim(breakpoints) == 1:
            breakpoints = [breakpoints]
        try:
            self.breakpoints = tuple(np.asarray(b, dtype=float).ravel() for b in breakpoints)
        except (TypeError, ValueError) as err:
            raise InputError(f"table breakpoints: {err}") from None
        if len(self.breakpoints) != len(self.variables):
            raise InputError(f"a table over {len(self.variables)} variables needs as many "
                             f"lists of breakpoints, got {len(self.breakpoints)}")
        self.shape = tuple(b.size for b in self.breakpoints)
        self.given = values is not None          # else a model may start it (with_tables)
        values = np.zeros(self.shape) if values is None else np.asarray(values, dtype=float)
        if values.shape != self.shape:
            raise InputError(f"table values must have the shape {self.shape} of its "
                             f"breakpoints, got {values.shape}")
        self.values = values

    def line(self, name):
        """The table's line of the model's text (the core's ``t`` item)."""
        bps = "; ".join(" ".join(repr(float(v)) for v in b) for b in self.breakpoints)
        return f"t {name}({', '.join(self.variables)}) = {bps}"

    @property
    def flat_values(self):
        """The values in the order of p: the first index fastest."""
        return self.values.ravel(order="F")

    def value_names(self, name):
        """The values' parameter names, in the order of p."""
        idx = np.indices(self.shape).reshape(len(self.shape), -1, order="F").T + 1
        return [f"{name}[{','.join(str(i) for i in ijk)}]" for ijk in idx]
