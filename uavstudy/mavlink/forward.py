"""The hook for UAVs whose autopilot speaks MAVLink itself (SITL-backed vehicles): their own stream is
forwarded to the ground stations unchanged, and what the ground stations send them goes back to them.

A vehicle source is a function ``source(monitor, plan) -> list[Forwarded]`` registered with
``register_source``; the package that builds such vehicles (e.g. ArduCopter SITL components,
:mod:`uavstudy.mavlink.sitl_source`) registers one that names, for each of its UAVs, the MAVLink address of
the firmware's own stream and the system id the firmware uses (SYSID_THISMAV, distinct per vehicle).  Those
UAVs are then left out of the simulated vehicles, whose system ids skip the forwarded ones.  Relaying is
bytes in, bytes out: the ground station sees the firmware's true state, sequence numbers and all.

The address may be known only once the components are initialised (a SITL picks its free instance, hence its
ports, when it starts): ``url`` is then a callable ``url(read) -> str``, called after initialisation with
``read(qualified)`` giving a variable's value; ``variables`` lists the variables it reads.
"""
from __future__ import annotations

from typing import Callable, NamedTuple, Union

from master.errors import CosimError


class Forwarded(NamedTuple):
    uav: str          # the UAV's name in the monitor annotation (uav1, ...)
    url: Union[str, Callable]   # where the firmware's MAVLink stream is (pymavlink form: udpin:..., tcp:...)
    sysid: int        # the firmware's own system id
    variables: tuple = ()       # what a callable ``url`` reads

    def address(self, read) -> str:
        return self.url(read) if callable(self.url) else self.url


SOURCES: list[Callable] = []


def register_source(source: Callable) -> Callable:
    SOURCES.append(source)
    return source


def forwarded_vehicles(monitor, plan) -> list[Forwarded]:
    out = []
    for source in SOURCES:
        out += source(monitor, plan) or []
    seen: dict[int, str] = {}
    for f in out:
        if f.sysid in seen:
            raise CosimError(f"{seen[f.sysid]} and {f.uav} both speak MAVLink as system id {f.sysid}: give every "
                             "firmware its own (parameter 'sysid' of its dynamics component)", element="--mavlink")
        if not 1 <= f.sysid <= 254:
            raise CosimError(f"{f.uav}: system id {f.sysid} is not 1-254", element="--mavlink")
        seen[f.sysid] = f.uav
    return out
