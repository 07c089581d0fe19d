"""Monitors: observers that look at the system between steps (collisions, zone incursions, ...) and may
take components out or end the run.

A monitor is switched on by an annotation in the SSD whose ``type`` it registered for, so the engine itself
stays generic. Monitors of other packages (the UAV study's, third parties') register through the
``cosim_master.monitors`` entry point group (name = annotation type, value = class).
"""
from __future__ import annotations

from ..registry import Registry
from ..ssp.connection_extrapolation import TYPE as EXTRAPOLATION_TYPE
from ..ssp.power_bonds import POWER_BONDS_TYPE
from ..ssp.settings_annotations import OUR_TYPE as SETTINGS_TYPE
from .base import Monitor, MonitorContext

MONITORS: Registry[type[Monitor]] = Registry("monitor", "cosim_master.monitors")

#: the engine's own annotation types, which no monitor is switched on by: an SSD with no others (every SSP that
#: ssp.writer writes has the settings annotation) is run without reading the installed packages' entry points
ENGINE_ANNOTATIONS = frozenset({SETTINGS_TYPE, POWER_BONDS_TYPE, EXTRAPOLATION_TYPE})


def register(annotation_type: str):
    """Class decorator: the monitor is switched on by SSD annotations of this type."""
    def deco(cls):
        cls.annotation_type = annotation_type
        return MONITORS.register(annotation_type, cls)
    return deco


def monitors_for(model, plan, shown_as) -> list[Monitor]:
    """One monitor per SSD annotation whose type a monitor registered for (a registered monitor that cannot
    be loaded is an error: the scenario must not run without it)."""
    found = []
    for typ, element in model.annotations.items():
        cls = MONITORS.find(typ) if typ and typ not in ENGINE_ANNOTATIONS else None
        if cls is not None:
            if not getattr(cls, "annotation_type", ""):
                cls.annotation_type = typ
            found.append(cls(element, plan, shown_as))
    return found


__all__ = ["MONITORS", "Monitor", "MonitorContext", "monitors_for", "register"]
