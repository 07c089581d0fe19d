"""The UAV study's live MAVLink stream (``--mavlink URL``): every UAV of a run as a vehicle that a ground
station (QGroundControl, MAVProxy) shows and commands.  Published to the engine under the entry point group
``cosim_master.live`` as ``mavlink`` (master/live.py); docs/ground_station.md says what it sends and takes.
"""
from __future__ import annotations

from master.errors import CosimError
from master.live import LiveParts, LiveStream

from ..names import MONITOR_TYPE
from .fleet import Fleet
from .forward import forwarded_vehicles
from .links import open_link, parse_url
from .stream import CommandInput, Hub, VehicleStream
from . import sitl_source  # noqa: F401,E402 - registers the SITL-backed UAVs as forwarded vehicles


class MavlinkStream(LiveStream):
    def check(self, urls):
        for url in urls:
            parse_url(url)

    def open(self, urls, *, monitors, plan, settings, options) -> LiveParts:
        monitor = next((mo for mo in monitors if getattr(mo, "annotation_type", None) == MONITOR_TYPE), None)
        if monitor is None:
            raise CosimError(f"this scenario has no UAV monitor (annotation {MONITOR_TYPE}): no vehicle to stream",
                             element="--mavlink")
        rate = float(getattr(options, "mavlink_rate", 10.0))
        if not rate > 0:
            raise CosimError(f"must be a positive number of messages per simulated second, got {rate}",
                             element="--mavlink-rate")
        fleet = Fleet(monitor, plan, forwarded_vehicles(monitor, plan))
        links = []
        try:
            for url in urls:
                links.append(open_link(url))
        except BaseException:
            for link in links:
                link.close()
            raise
        hub = Hub(fleet, links, rate)          # the forwarded vehicles' streams open once they run (attach)
        return LiveParts([VehicleStream(hub, monitor)], [CommandInput(hub)])


MAVLINK = MavlinkStream()
