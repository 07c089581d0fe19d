"""Monitors: plugins that look at the system between steps (collisions, zone incursions, ...).

A monitor is switched on by an annotation in the SSD whose ``type`` it registered for, so the master
itself stays generic. Third-party monitors register through the ``cosim_master.monitors`` entry point
group (name = annotation type, value = class).
"""
from __future__ import annotations

from .base import Monitor, MonitorContext

MONITORS: dict[str, type[Monitor]] = {}


def register(annotation_type: str):
    def deco(cls):
        cls.annotation_type = annotation_type
        MONITORS[annotation_type] = cls
        return cls
    return deco


def _load_builtin():
    from . import uav  # noqa: F401  (registers itself)


_entry_points_scanned = False


def _load_entry_points():
    global _entry_points_scanned
    if _entry_points_scanned:      # scanning the installed distributions costs ~10 ms: once per process
        return
    _entry_points_scanned = True
    try:
        from importlib.metadata import entry_points
        for ep in entry_points(group="cosim_master.monitors"):
            MONITORS.setdefault(ep.name, ep.load())
    except Exception:
        pass


def monitors_for(model, plan, shown_as) -> list[Monitor]:
    try:
        _load_builtin()
    except ImportError:
        pass
    if any(typ not in MONITORS for typ in model.annotations):
        _load_entry_points()
    found = []
    for typ, element in model.annotations.items():
        cls = MONITORS.get(typ)
        if cls is not None:
            found.append(cls(element, plan, shown_as))
    return found
