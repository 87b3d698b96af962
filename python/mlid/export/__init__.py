"""Export an identified model for a simulator: JSBSim's aerodynamics (or a
minimal aircraft around them) and a plain table set (JSON, CSV)."""

from .jsbsim import jsbsim, aerodynamics_text, aircraft_text
from .tableset import tables

__all__ = ["jsbsim", "aerodynamics_text", "aircraft_text", "tables"]
