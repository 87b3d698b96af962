"""The discrepancy demos (cases/discrepancy): the hidden gust of the M2/F3
record and the hidden Y_p of the HL-10 record are named first."""

import sys

from conftest import REPO

sys.path.insert(0, str(REPO / "cases" / "discrepancy"))
import demos  # noqa: E402


def test_m2f3_gust_is_named():
    d = demos.m2f3_demo()
    assert d.effects[0].family == "process noise"
    assert d.after[0]["Q"] < 0.1 * d.before[0]["Q"]          # p's residuals nearly white


def test_hl10_side_force_derivative_is_named():
    d = demos.hl10_demo()
    assert d.effects[0].family == "missing derivative" and d.effects[0].name.startswith("Y_")
