"""Online (recursive) estimation: estimates updated sample by sample, for
monitoring a test point, envelope expansion or adaptive control (the core's
fortran/estimation/online/)."""

from .filters import efrls, ekf, ukf
from .rls import OnlineEstimate, rls
from .ftr import ftr

__all__ = ["OnlineEstimate", "efrls", "ekf", "ftr", "rls", "ukf"]
