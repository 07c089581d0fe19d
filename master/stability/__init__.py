"""Stability of the coupled step: the step map of a fixed-step co-simulation identified from its FMUs
(step_map.py), swept over steps and parameters into stability.csv and a figure (sweep.py); docs/coupling.md."""
from .step_map import StepMap, identify, spectral_radius

__all__ = ["StepMap", "identify", "spectral_radius"]
