"""What a Monte Carlo of fits gives (mlid.monte_carlo): the dict it always
was, with its numbers by parameter name, DataFrame views of the summary and
of the runs, and a readable repr and Jupyter view."""

import numpy as np

from ..checks import pandas_for
from ..estimate.named import NamedArray
from ..estimate.views import TableView

#: The summary's entries with one value per free parameter (the others are
#: numbers of the whole covariance or information).
PER_PARAMETER = ("mean", "sample_sigma", "mean_cr_sigma")


class MonteCarloResult(TableView, dict):
    """The runs of a Monte Carlo and their summary: a dict with the keys
    ``mlid.monte_carlo`` documents (``estimates``, ``sigma``,
    ``information``, ``iterations``, ``status``, ``names``, ``truth``,
    ``summary``), so ``mc["summary"]["mean"]`` keeps working; also

    - ``mc.truth``, ``mc.mean``, ``mc.sample_sigma``, ``mc.mean_cr_sigma``:
      NamedArrays by parameter (``mc.mean['M_q']``);
    - ``to_frame()``: a row per parameter, its true value and the summary's
      mean, sample sigma and mean Cramer-Rao sigma over the runs that
      converged;
    - ``runs_frame()``: a row per run, its estimates, status and iterations.

    Parameters
    ----------
    fields : dict
        The keys above.
    """

    @property
    def names(self):
        """The free parameters' names."""
        return list(self["names"])

    @property
    def truth(self):
        """The true value of each free parameter."""
        return NamedArray(np.asarray(self["truth"], dtype=float), self.names)

    @property
    def converged(self):
        """How many runs converged (status 0): the summary is over them."""
        return int(np.sum(np.asarray(self["status"]) == 0))

    def __getattr__(self, name):
        if name in PER_PARAMETER:
            return NamedArray(np.asarray(self["summary"][name], dtype=float), self.names)
        raise AttributeError(name)

    def _table(self):
        columns = {"truth": list(self["truth"])}
        columns.update({k: list(self["summary"][k]) for k in PER_PARAMETER})
        return "name", self.names, columns

    def _heading(self):
        s = self["summary"]
        runs = len(self["status"])
        return (f"{self.converged} of {runs} runs converged (the summary is over them); "
                f"sample covariance trace {s['sample_cov_trace']:.6g}, det "
                f"{s['sample_cov_det']:.6g}; mean information trace "
                f"{s['mean_info_trace']:.6g}, det {s['mean_info_det']:.6g}")

    def runs_frame(self):
        """The runs as a DataFrame: a row per run (numbered from 0, run k's
        noise seed is seed + k), each parameter's estimate, then ``status``
        (0 converged, else the core's code) and ``iterations``.

        Returns
        -------
        pandas.DataFrame

        Raises
        ------
        InputError
            If pandas is not installed.
        """
        pd = pandas_for("MonteCarloResult.runs_frame")
        frame = pd.DataFrame(np.asarray(self["estimates"]), columns=self.names)
        frame.index.name = "run"
        frame["status"] = np.asarray(self["status"])
        frame["iterations"] = np.asarray(self["iterations"])
        return frame
