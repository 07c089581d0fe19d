"""ArduPilot's own latitude/longitude <-> metres convention, for the position targets we send to SITL.

The project's geodesy is WGS84 through ECEF (uavsim/geodesy.py), and our ENU positions of a SITL vehicle are
its physics' metres north/east of SITL's home.  The firmware, however, measures everything on a sphere of
radius 6378100 m about integer 1e-7 degree coordinates (AP_Common/Location.cpp: ``Location::offset`` and
``get_distance_NE``, LOCATION_SCALING_FACTOR = 0.011131884502145034 m per 1e-7 deg); SITL turns the physics
position into the GPS fix with the same ``offset`` from its home.  A point 450 m north of home written with
WGS84 is, to the firmware, 450 m x R / (M + h) ~ 453 m north at 7 deg S (M the WGS84 meridian radius of
curvature, ~6336.4 km there, h the height above the ellipsoid, R = 6378.1 km): 2.9 m beyond it, more than the
strategy's 2 m arrival radius, so a vehicle sent to a far target would hover beside it until its battery
ran low.  Position targets are therefore expressed with
the firmware's own rule about the same home that the physics' metres start from; what is left is the
rounding of coordinates to 1e-7 deg (about 1 cm).
"""
from __future__ import annotations

import math

__all__ = ["LOCATION_SCALING_FACTOR", "offset", "distance_ne", "to_e7"]

#: metres per 1e-7 degree of latitude (= 1e-7 deg in rad x 6378100 m)
LOCATION_SCALING_FACTOR = 0.011131884502145034
LOCATION_SCALING_FACTOR_INV = 89.83204953368922


def to_e7(deg: float) -> int:
    """Degrees to the firmware's int32 1e-7 degrees, truncated as a C cast does."""
    return int(float(deg) * 1.0e7)


def _longitude_scale(lat_e7: int) -> float:
    return min(1.0, max(0.01, math.cos(math.radians(lat_e7 * 1.0e-7))))


def _c_div(a: int, b: int) -> int:
    """C integer division (truncates toward zero)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def offset(lat_e7: int, lon_e7: int, north: float, east: float) -> tuple[int, int]:
    """The point ``north``/``east`` metres from (lat_e7, lon_e7), in 1e-7 degrees, as Location::offset."""
    dlat = int(north * LOCATION_SCALING_FACTOR_INV)
    dlon = int((east * LOCATION_SCALING_FACTOR_INV) / _longitude_scale(lat_e7 + _c_div(dlat, 2)))
    return lat_e7 + dlat, lon_e7 + dlon


def distance_ne(lat1_e7: int, lon1_e7: int, lat2_e7: int, lon2_e7: int) -> tuple[float, float]:
    """Metres north and east from point 1 to point 2, as Location::get_distance_NE."""
    dlon = lon2_e7 - lon1_e7
    if dlon > 1800000000:
        dlon -= 3600000000
    elif dlon < -1800000000:
        dlon += 3600000000
    return ((lat2_e7 - lat1_e7) * LOCATION_SCALING_FACTOR,
            dlon * LOCATION_SCALING_FACTOR * _longitude_scale(_c_div(lat1_e7 + lat2_e7, 2)))
