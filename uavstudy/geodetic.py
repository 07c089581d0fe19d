"""ENU <-> geodetic for the monitor's events and the mission outputs (both write lat/lon/alt).

Its own module so that the monitor and the outputs it hands its results to need not import each other.
"""
from __future__ import annotations


def to_geodetic(origin, x, y, z):
    """ENU metres about the origin -> (lat, lon, alt) in degrees / metres above the ellipsoid."""
    from uavsim.geodesy import geodetic_from_enu
    lat, lon, alt = geodetic_from_enu(x, y, z, *origin)
    return lat, lon, alt


def frame(origin):
    """The same conversion for one point at a time on Python floats (``uavsim.geodesy.EnuFrame``: agrees
    with ``to_geodetic`` to float64 rounding), for hot loops over a few points."""
    from uavsim.geodesy import EnuFrame
    return EnuFrame(*origin)
