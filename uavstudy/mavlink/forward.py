"""The hook for UAVs whose autopilot speaks MAVLink itself (SITL-backed vehicles): their own stream is
forwarded to the ground stations unchanged, and what the ground stations send them goes back to them.

A vehicle source is a function ``source(monitor, plan) -> list[Forwarded]`` registered with
``register_source``; the package that builds such vehicles (e.g. ArduCopter SITL components) registers one
that names, for each of its UAVs, the MAVLink address of the firmware's own stream and the system id the
firmware uses (SYSID_THISMAV, distinct per vehicle).  Those UAVs are then left out of the simulated
vehicles, whose system ids skip the forwarded ones.  Relaying is bytes in, bytes out: the ground station sees
the firmware's true state, sequence numbers and all.
"""
from __future__ import annotations

from typing import Callable, NamedTuple


class Forwarded(NamedTuple):
    uav: str          # the UAV's name in the monitor annotation (uav1, ...)
    url: str          # where the firmware's MAVLink stream is (pymavlink form: udpin:..., tcp:...)
    sysid: int        # the firmware's own system id


SOURCES: list[Callable] = []


def register_source(source: Callable) -> Callable:
    SOURCES.append(source)
    return source


def forwarded_vehicles(monitor, plan) -> list[Forwarded]:
    out = []
    for source in SOURCES:
        out += source(monitor, plan) or []
    return out
