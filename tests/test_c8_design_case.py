"""The C-8 input-design case (cases/c8_input_design) tells what its README says."""

import sys

import numpy as np
import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "c8_input_design"))
import c8_design  # noqa: E402


@pytest.fixture(scope="module")
def plots(tmp_path_factory):
    return tmp_path_factory.mktemp("plots")


@pytest.fixture(scope="module")
def out(plots):
    return c8_design.run(plots=plots)


def test_c8_design_case(out, plots):
    tmp_path = plots
    fo = out["first order"]
    assert abs(fo["mu operator"] - fo["mu closed form"]) < 1e-7
    assert abs(fo["optimal/doublet at T = 1"] - 4.2) < 0.05        # CASES.md §1
    table = {name: s for name, _, s in out["table"]}
    opt = table["optimal"]["trace"]
    # at equal energy nothing beats the optimal input's weighted trace (eq. 7.40)
    assert all(s["trace"] < opt for name, s in table.items() if "equal energy" in name)
    assert abs(table["doublet, equal energy"]["trace"] - 10264) < 0.01 * 10264   # CASES.md §1
    # the square wave keeps its peak and its pulses
    sq = [u for name, u, _ in out["table"] if name.startswith("square")][0][:, 0]
    runs = np.diff(np.flatnonzero(np.r_[True, np.diff(sq) != 0, True]))
    assert runs.min() * c8_design.T_LONG / len(sq) >= 0.2 - 1e-9
    # the state limit: the rescaled input holds |alpha| at 10 deg
    peak, energy = out["alpha limit"]
    u = out["long"].u * np.sqrt(energy / c8_design.E_LONG)
    _, x = c8_design.states_of(u, c8_design.T_LONG)
    assert abs(np.max(np.abs(x[:, 1])) - c8_design.ALPHA_LIMIT) < 1e-6
    servo, dbl = out["servo"]
    assert servo.summary["trace"] > dbl["trace"]
    assert out["gusts"] < out["mu(T=4)"]
    assert len(list(tmp_path.glob("fig8_*.png"))) == 5


def test_c8_design_verdicts(out):
    """The README's report | mlid | verdict table: everything agrees or is
    within 5% but det M at T = 0.77 s (9% below the report, at the
    recomputed value) and the weighted ratio (the report stopped at 12
    iterations)."""
    rows = [(q.strip(), v) for q, _, _, _, v in c8_design.report_rows(out)]
    differs = [q for q, v in rows if v.startswith("differs")]
    assert differs == ["det M", "weighted (12 it.): diag(WM) max/min"]
    assert sum(v.startswith("close") for _, v in rows) == 2
