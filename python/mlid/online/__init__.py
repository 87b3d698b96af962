"""Online (recursive) estimation: estimates updated sample by sample, for
monitoring a test point, envelope expansion or adaptive control (the core's
fortran/estimation/online/)."""

from .rls import OnlineEstimate, rls

__all__ = ["OnlineEstimate", "rls"]
