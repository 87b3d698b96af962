"""Export an identified model for a simulator: JSBSim's aerodynamics (or a
minimal aircraft around them), DAVE-ML 2.0 (AIAA S-119) and a plain table
set (JSON, CSV)."""

from .daveml import daveml, daveml_text
from .jsbsim import jsbsim, aerodynamics_text, aircraft_text
from .tableset import tables

__all__ = ["daveml", "daveml_text", "jsbsim", "aerodynamics_text", "aircraft_text", "tables"]
