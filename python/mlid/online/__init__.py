"""Online (recursive) estimation: estimates updated sample by sample, for
monitoring a test point, envelope expansion or adaptive control (the core's
fortran/estimation/online/)."""

from .filters import ekf, ukf
from .rls import OnlineEstimate, rls
from .ftr import ftr

__all__ = ["OnlineEstimate", "ekf", "ftr", "rls", "ukf"]
