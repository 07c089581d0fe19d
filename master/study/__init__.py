"""``cosim-master study``: a grid of coupling algorithms, extrapolation orders and step sizes run through the
campaign machinery and measured against a reference (errors, observed order, FMU calls, figures)."""
from .study import StudySummary, run_study

__all__ = ["run_study", "StudySummary"]
