"""Online (recursive) estimation: estimates updated sample by sample, for
monitoring a test point, envelope expansion or adaptive control (the core's
fortran/estimation/online/)."""

from .rls import OnlineEstimate, rls
from .ftr import ftr

__all__ = ["OnlineEstimate", "rls", "ftr"]
