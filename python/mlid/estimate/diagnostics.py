"""A fit's diagnostics as objects: the whiteness test of its residuals, what
its information says about identifiability, and its output sensitivities.
Each is what it was before (a list of dicts, of printed lines) with a
DataFrame view (``to_frame``), its arrays by name, and a readable repr and
Jupyter view (views.TableView)."""

import numpy as np

from .named import NamedArray
from .views import TableView

#: The columns of a whiteness test, per output (a row's keys after ``output``).
WHITENESS_KEYS = ("Q", "critical", "white", "outside")


class Whiteness(TableView, list):
    """The Ljung-Box test of a fit's residuals: a list of dicts, one per
    output (``output``, ``Q``, ``critical``, ``white``, ``outside``), as
    ``FitResult.whiteness`` gave; also reached by output name
    (``w['q']['Q']``), as arrays (``w.Q``, ``w.white``, each a NamedArray
    by output) and as a DataFrame (``to_frame``).

    Parameters
    ----------
    rows : iterable of dict
        Per output, with the keys above.
    lags : int
        The largest lag of the test.
    """

    def __init__(self, rows, lags):
        super().__init__(rows)
        self.lags = int(lags)

    @property
    def outputs(self):
        """The outputs' names, in order."""
        return [row["output"] for row in self]

    def __getitem__(self, key):
        if isinstance(key, str):
            for row in self:
                if row["output"] == key:
                    return row
            raise KeyError(f"no output named {key!r}; the outputs are {', '.join(self.outputs)}")
        return list.__getitem__(self, key)

    def __getattr__(self, name):
        if name in WHITENESS_KEYS:
            return NamedArray(np.array([row[name] for row in self]), self.outputs)
        raise AttributeError(name)

    def _table(self):
        return "output", self.outputs, {k: [row[k] for row in self] for k in WHITENESS_KEYS}

    def _heading(self):
        white = sum(bool(row["white"]) for row in self)
        return (f"Ljung-Box over lags 1..{self.lags}, {white} of {len(self)} outputs white "
                "(Q below the 5% critical value; outside: autocorrelations outside "
                "+-1.96/sqrt(N))")


class Identifiability(TableView, list):
    """What the information says about identifiability (report §4.5,
    §5.3.5): the report's lines (a list of str, as
    ``FitResult.identifiability`` gave), and their numbers: ``eigenvalues``
    of the normalised information (ascending) and their ``spread``, the
    ``weakest`` direction (a NamedArray by parameter, its largest component
    positive), the ``correlation`` matrix (NamedArray on both axes).
    ``to_frame``: per parameter its share of the weakest direction and the
    parameter it is most correlated with.

    Parameters
    ----------
    lines : list of str
        The report's lines (empty for a failed fit).
    names : list of str
        The free parameters.
    eigenvalues : ndarray (nf,)
    eigenvectors : ndarray (nf, nf)
        Of the normalised information, ascending, a column each.
    correlation : ndarray (nf, nf)
    """

    def __init__(self, lines, names, eigenvalues, eigenvectors, correlation):
        super().__init__(lines)
        self.names = list(names)
        self.eigenvalues = np.asarray(eigenvalues, dtype=float)
        v = np.asarray(eigenvectors, dtype=float)
        w = v[:, 0] if v.size else np.zeros(0)
        if w.size:                # an eigenvector's sign is arbitrary: largest +, as the report
            w = w * np.sign(w[np.argmax(np.abs(w))] or 1.0)
        self.weakest = NamedArray(w, self.names)
        self.correlation = NamedArray(correlation, self.names)

    @property
    def spread(self):
        """Largest over smallest eigenvalue of the normalised information
        (infinite when the smallest is not positive)."""
        e = self.eigenvalues
        if e.size == 0:
            return float("nan")
        return float(e[-1] / e[0]) if e[0] > 0 else float("inf")

    def _partners(self):
        """Per parameter the other one it is most correlated with, and that
        correlation."""
        c = np.array(self.correlation, dtype=float)
        np.fill_diagonal(c, 0.0)
        if c.shape[0] < 2:
            return [""] * c.shape[0], [float("nan")] * c.shape[0]
        k = np.argmax(np.abs(c), axis=1)
        return [self.names[j] for j in k], [float(c[i, j]) for i, j in enumerate(k)]

    def _table(self):
        partner, corr = self._partners()
        return "name", self.names, {"weakest_direction": list(self.weakest),
                                    "most_correlated_with": partner, "correlation": corr}

    def _heading(self):
        if not self.names:
            return "no estimates"
        return f"normalised information eigenvalue spread {self.spread:.4g}"

    def __str__(self):
        return "\n".join(self)


class Sensitivity(TableView, list):
    """Output sensitivity norms at the estimate: how many residual sigmas
    each parameter moves each output over the record.  A list of the printed
    lines (as ``FitResult.sensitivity_table`` gave), ``norms`` (ny, nf),
    a parameter's norms by its name (``s['M_q']``: a NamedArray by output)
    and ``to_frame`` (a row per parameter, a column per output).

    Parameters
    ----------
    norms : ndarray (ny, nf)
    names : list of str
        The free parameters.
    outputs : list of str
        The outputs.
    """

    def __init__(self, norms, names, outputs):
        self.norms = np.asarray(norms, dtype=float)
        self.names, self.outputs = list(names), list(outputs)
        short = [n[:10] for n in self.outputs]
        lines = [" output sensitivity norms (residual sigmas over the record)",
                 f" {'parameter':<16}" + "".join(f"{n:>11}" for n in short)]
        for k, name in enumerate(self.names):
            lines.append(f" {name[:16]:<16}" + "".join(f"{v:11.3E}" for v in self.norms[:, k]))
        super().__init__(lines)

    def __getitem__(self, key):
        if isinstance(key, str):
            if key not in self.names:
                raise KeyError(f"no parameter named {key!r}; the names are "
                               f"{', '.join(self.names)}")
            return NamedArray(self.norms[:, self.names.index(key)].copy(), self.outputs)
        return list.__getitem__(self, key)

    def _table(self):
        return "name", self.names, {out: list(self.norms[i]) for i, out in
                                    enumerate(self.outputs)}

    def _heading(self):
        return "output sensitivity norms (residual sigmas over the record)"

    def __str__(self):
        return "\n".join(self)
