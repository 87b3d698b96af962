"""Which input to fly (``InputDesign.rank_inputs``): candidate inputs at a
common energy or peak, ranked by the information they give the unknowns.
The numbers are the core's (fortran/design/mlid_input_ranking.f90, the one
the deck's ``&design candidates`` runs); this module only holds them, by
candidate, with a table view."""

import numpy as np

from .._bridge import lines
from ..estimate.named import NamedArray
from ..estimate.views import TableView


class InputRanking(TableView):
    """Candidate inputs of a design, each scaled to the same energy
    (the integral of u'u over [0, T]) or peak, in rank order (best first).

    Attributes
    ----------
    names : list of str
        The candidates, best first.
    signals : list of str
        Each candidate's settings in words (band, base pulse, clock).
    compare : str
        'energy' or 'peak'; ``level`` the common value.
    rank_by : str
        'det' (D-optimal) or 'trace'.
    unknowns : list of str
        The unknowns, in the design's order.
    t_edges : ndarray (cells + 1,)
        The cells' edges, 0 to T.
    u : ndarray (candidates, cells, nu)
        Each candidate as scaled, held over the cells.
    M : ndarray (candidates, n, n)
        Each one's information matrix (unweighted, eq. 7.12).
    det, trace : ndarray (candidates,)
        det M and tr M.
    sigma : ndarray (candidates, n)
        Cramér-Rao sigma of each unknown.
    energy, peak : ndarray (candidates,)
        Each scaled input's energy and largest absolute value.
    state_peak, state_rms : ndarray (candidates, nx)
        Peak and rms over [0, T] of each state of the model, from x(0) = 0.
    output_peak, output_rms : ndarray (candidates, ny)
        The same of each output H x.
    """

    def __init__(self, r, unknowns, T, compare, level, rank_by, nu):
        order = np.asarray(r["order"], dtype=int) - 1
        names, signals = lines(r["names"]), r["signals"].decode().split("\n")
        self.names = [names[k] for k in order]
        self.signals = [signals[k].strip() for k in order]
        self.unknowns = list(unknowns)
        self.compare, self.level, self.rank_by = compare, float(level), rank_by
        m, nc = len(self.unknowns), len(names)
        u = np.asarray(r["u"]).reshape(nu, -1, nc, order="F")      # the core's: cell by cell
        self.u = np.transpose(u, (2, 1, 0))[order]
        self.t_edges = np.linspace(0.0, T, self.u.shape[1] + 1)
        self.M = np.asarray(r["mm"]).reshape(m, m, nc, order="F").transpose(2, 0, 1)[order]
        for key in ("det", "trace", "energy", "peak"):
            setattr(self, key, np.asarray(r[key], dtype=float)[order])
        for key, name in (("sigma", "sigma"), ("x_peak", "state_peak"), ("x_rms", "state_rms"),
                          ("y_peak", "output_peak"), ("y_rms", "output_rms")):
            setattr(self, name, np.asarray(r[key], dtype=float).reshape(-1, nc).T[order])

    def __len__(self):
        return len(self.names)

    def sigma_of(self, candidate):
        """The Cramér-Rao sigma of one candidate, by unknown.

        Parameters
        ----------
        candidate : str
            One of ``names``.

        Returns
        -------
        NamedArray
        """
        return NamedArray(self.sigma[self.names.index(candidate)], self.unknowns)

    def _table(self):
        columns = {"rank": list(range(1, len(self) + 1)), "det M": list(self.det),
                   "tr M": list(self.trace)}
        columns.update({f"sigma {u}": list(self.sigma[:, j]) for j, u in enumerate(self.unknowns)})
        columns["signal"] = self.signals
        return "candidate", self.names, columns

    def _heading(self):
        by = "det M (D-optimal)" if self.rank_by == "det" else "tr M"
        return f"{len(self)} inputs at equal {self.compare} {self.level:.6g}, ranked by {by}"
