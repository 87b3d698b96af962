"""What a result shown as a table has in common: a pandas DataFrame
(``to_frame``, pandas imported only then), a fixed-width text for the
terminal (``repr``) and an HTML table for Jupyter (``_repr_html_``), all
three from the one table the result gives (``_table``)."""

import html
import math

import numpy as np

from ..checks import pandas_for
from .table import HTML_DIGITS


def _cell(value):
    """A value as table text: numbers to HTML_DIGITS significant digits."""
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return f"{value:.{HTML_DIGITS}g}" if math.isfinite(value) else str(float(value))
    return str(value)


def _numeric(value):
    return isinstance(value, (int, float, np.integer, np.floating)) and \
        not isinstance(value, (bool, np.bool_))


class TableView:
    """A result with a table: a row per name (parameter, output), a column
    per quantity.  A subclass gives ``_table()``: (index name, row labels,
    {column: values, one per row}) and ``_heading()``, one line saying what
    the table is."""

    def _table(self):
        raise NotImplementedError

    def _heading(self):
        return ""

    def to_frame(self):
        """The table as a DataFrame, a row per name.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        InputError
            If pandas is not installed.
        """
        pd = pandas_for(f"{type(self).__name__}.to_frame")
        index, labels, columns = self._table()
        return pd.DataFrame({k: list(v) for k, v in columns.items()},
                            index=pd.Index(list(labels), name=index))

    def _rows(self):
        index, labels, columns = self._table()
        heads = [index, *columns]
        rows = [[label, *(v[i] for v in columns.values())] for i, label in enumerate(labels)]
        return heads, rows

    def table_text(self):
        """The table as fixed-width text (names left, numbers right).

        Returns
        -------
        str
        """
        heads, rows = self._rows()
        cells = [[_cell(v) for v in row] for row in rows]
        widths = [max([len(h)] + [len(r[k]) for r in cells]) for k, h in enumerate(heads)]
        right = [bool(rows) and all(_numeric(r[k]) for r in rows) for k in range(len(heads))]

        def line(items):
            return "  ".join(f"{s:>{w}}" if r else f"{s:<{w}}"
                             for s, w, r in zip(items, widths, right)).rstrip()
        return "\n".join([line(heads)] + [line(c) for c in cells])

    def __repr__(self):
        return f"{type(self).__name__}: {self._heading()}\n{self.table_text()}"

    def __str__(self):
        return self.__repr__()

    def _repr_html_(self):
        """Jupyter's view: the heading and the table."""
        e = html.escape
        heads, rows = self._rows()
        head = "".join(f"<th>{e(str(h))}</th>" for h in heads)
        body = "".join(
            "<tr>" + "".join(f'<td style="text-align:right">{e(_cell(v))}</td>' if _numeric(v)
                             else f"<td>{e(_cell(v))}</td>" for v in row) + "</tr>"
            for row in rows)
        kind = type(self).__name__.lower()
        return (f'<div class="mlid-{kind}"><p><b>{e(type(self).__name__)}</b>: '
                f"{e(self._heading())}</p><table class=\"mlid-table\"><thead><tr>{head}</tr>"
                f"</thead><tbody>{body}</tbody></table></div>")
