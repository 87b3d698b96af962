"""The path mlid.core.input_signal, which the README documented when the
core's wrappers were one module here, kept working.  The wrappers now live in
their layers (estimate.fit, design.simulate, design.signals, ...)."""

from .design.signals import input_signal

__all__ = ["input_signal"]
