"""Geodesy convention of the cosim-master project (the single one; use only this).

Convention
----------
* Ellipsoid: WGS84 (a = 6378137 m, f = 1/298.257223563).
* Geodetic coordinates: latitude and longitude in **degrees** (north/east
  positive), altitude in **metres** above the ellipsoid (no geoid/MSL model).
* Local frame: **east-north-up (ENU)**, a Cartesian frame tangent to the
  ellipsoid at an origin ``(lat0, lon0, alt0)``; ``e`` points east, ``n``
  north, ``u`` along the ellipsoid normal (up).  All local positions of the
  project (UAV states, targets, zones, monitors) are ENU metres about the
  scenario's base point.
* The transform is the exact one through Earth-centred Earth-fixed (ECEF)
  coordinates (no flat-earth approximation): ENU = R(lat0, lon0) (ECEF(p) -
  ECEF(origin)).  The inverse rotates back to ECEF and converts ECEF to
  geodetic with Bowring's method followed by Newton-like refinement of the
  latitude (two iterations, converged to well below 1e-9 m for terrestrial
  altitudes).

Error bound
-----------
``geodetic_from_enu(*enu_from_geodetic(p, origin), origin)`` reproduces ``p``
to better than **1 mm** within 50 km of the origin (and for altitudes between
-1 km and +50 km); measured: the maximum round-trip position error over
random points within 50 km (tests/fmu_sources/uavsim/test_geodesy.py) is ~3e-9 m (limited by
float64 rounding of ECEF coordinates of size ~6.4e6 m, i.e. ~1e-9 m per ulp).
The forward transform has no approximation error beyond float64 rounding.

All functions accept scalars or numpy arrays (broadcasting) and return numpy
float64 values (0-d arrays for scalar input, which behave like floats).
"""
from __future__ import annotations

import numpy as np

# WGS84 defining constants
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563
WGS84_B = WGS84_A * (1.0 - WGS84_F)
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)            # first eccentricity squared
WGS84_EP2 = WGS84_E2 / (1.0 - WGS84_E2)         # second eccentricity squared

__all__ = [
    "WGS84_A", "WGS84_F", "WGS84_B", "WGS84_E2",
    "ecef_from_geodetic", "geodetic_from_ecef",
    "enu_from_ecef", "ecef_from_enu",
    "enu_from_geodetic", "geodetic_from_enu",
    "meridian_radius", "prime_vertical_radius",
]


def prime_vertical_radius(lat):
    """Radius of curvature in the prime vertical N(lat) [m], lat in degrees."""
    s = np.sin(np.radians(np.asarray(lat, dtype=float)))
    return WGS84_A / np.sqrt(1.0 - WGS84_E2 * s * s)


def meridian_radius(lat):
    """Meridian radius of curvature M(lat) [m], lat in degrees."""
    s = np.sin(np.radians(np.asarray(lat, dtype=float)))
    return WGS84_A * (1.0 - WGS84_E2) / (1.0 - WGS84_E2 * s * s) ** 1.5


def ecef_from_geodetic(lat, lon, alt=0.0):
    """Geodetic (deg, deg, m) -> ECEF (x, y, z) in metres."""
    lat_r = np.radians(np.asarray(lat, dtype=float))
    lon_r = np.radians(np.asarray(lon, dtype=float))
    alt = np.asarray(alt, dtype=float)
    sl, cl = np.sin(lat_r), np.cos(lat_r)
    N = WGS84_A / np.sqrt(1.0 - WGS84_E2 * sl * sl)
    x = (N + alt) * cl * np.cos(lon_r)
    y = (N + alt) * cl * np.sin(lon_r)
    z = (N * (1.0 - WGS84_E2) + alt) * sl
    return x, y, z


def geodetic_from_ecef(x, y, z):
    """ECEF (m) -> geodetic (lat deg, lon deg, alt m).

    Bowring's initial parametric-latitude estimate, then two refinement
    iterations of tan(lat) = (z + e2 N sin(lat)) / p.  Valid everywhere
    except exactly at the Earth's centre; at the poles (p = 0) the altitude
    is computed from |z|.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    z = np.asarray(z, dtype=float)
    a, b, e2, ep2 = WGS84_A, WGS84_B, WGS84_E2, WGS84_EP2
    p = np.hypot(x, y)
    lon = np.arctan2(y, x)
    # Bowring (1976)
    theta = np.arctan2(z * a, p * b)
    st, ct = np.sin(theta), np.cos(theta)
    lat = np.arctan2(z + ep2 * b * st ** 3, p - e2 * a * ct ** 3)
    for _ in range(2):
        sl = np.sin(lat)
        N = a / np.sqrt(1.0 - e2 * sl * sl)
        lat = np.arctan2(z + e2 * N * sl, p)
    sl, cl = np.sin(lat), np.cos(lat)
    N = a / np.sqrt(1.0 - e2 * sl * sl)
    # numerically robust altitude for all latitudes
    alt = p * cl + z * sl - a * np.sqrt(1.0 - e2 * sl * sl)
    return np.degrees(lat), np.degrees(lon), alt


def _rotation(lat0, lon0):
    lat0 = np.radians(np.asarray(lat0, dtype=float))
    lon0 = np.radians(np.asarray(lon0, dtype=float))
    return np.sin(lat0), np.cos(lat0), np.sin(lon0), np.cos(lon0)


def enu_from_ecef(x, y, z, lat0, lon0, alt0=0.0):
    """ECEF point(s) -> ENU about the geodetic origin."""
    x0, y0, z0 = ecef_from_geodetic(lat0, lon0, alt0)
    dx = np.asarray(x, dtype=float) - x0
    dy = np.asarray(y, dtype=float) - y0
    dz = np.asarray(z, dtype=float) - z0
    sp, cp, sl, cl = _rotation(lat0, lon0)
    e = -sl * dx + cl * dy
    n = -sp * cl * dx - sp * sl * dy + cp * dz
    u = cp * cl * dx + cp * sl * dy + sp * dz
    return e, n, u


def ecef_from_enu(e, n, u, lat0, lon0, alt0=0.0):
    """ENU about the geodetic origin -> ECEF point(s)."""
    x0, y0, z0 = ecef_from_geodetic(lat0, lon0, alt0)
    e = np.asarray(e, dtype=float)
    n = np.asarray(n, dtype=float)
    u = np.asarray(u, dtype=float)
    sp, cp, sl, cl = _rotation(lat0, lon0)
    dx = -sl * e - sp * cl * n + cp * cl * u
    dy = cl * e - sp * sl * n + cp * sl * u
    dz = cp * n + sp * u
    return x0 + dx, y0 + dy, z0 + dz


def enu_from_geodetic(lat, lon, alt, lat0, lon0, alt0=0.0):
    """Geodetic (deg, deg, m) -> local ENU (e, n, u) [m] about (lat0, lon0, alt0)."""
    x, y, z = ecef_from_geodetic(lat, lon, alt)
    return enu_from_ecef(x, y, z, lat0, lon0, alt0)


def geodetic_from_enu(e, n, u, lat0, lon0, alt0=0.0):
    """Local ENU (e, n, u) [m] about (lat0, lon0, alt0) -> geodetic (deg, deg, m)."""
    x, y, z = ecef_from_enu(e, n, u, lat0, lon0, alt0)
    return geodetic_from_ecef(x, y, z)


class EnuFrame:
    """A fixed ENU origin with its constants precomputed, for scalar conversions in a hot loop.

    ``to_geodetic(e, n, u)`` is the same computation as :func:`geodetic_from_enu` (ENU -> ECEF by
    the rotation about the origin, then Bowring's estimate and two refinement iterations) written
    with the ``math`` module on Python floats: it agrees with the numpy version to float64
    rounding (tested), at a fraction of the cost (no numpy scalars, the origin's ECEF position and
    rotation computed once).
    """

    __slots__ = ("lat0", "lon0", "alt0", "_x0", "_y0", "_z0", "_sp", "_cp", "_sl", "_cl")

    def __init__(self, lat0: float, lon0: float, alt0: float = 0.0):
        import math
        self.lat0, self.lon0, self.alt0 = float(lat0), float(lon0), float(alt0)
        p, l = math.radians(self.lat0), math.radians(self.lon0)
        sp, cp, sl, cl = math.sin(p), math.cos(p), math.sin(l), math.cos(l)
        n0 = WGS84_A / math.sqrt(1.0 - WGS84_E2 * sp * sp)
        self._x0 = (n0 + self.alt0) * cp * cl
        self._y0 = (n0 + self.alt0) * cp * sl
        self._z0 = (n0 * (1.0 - WGS84_E2) + self.alt0) * sp
        self._sp, self._cp, self._sl, self._cl = sp, cp, sl, cl

    @property
    def constants(self) -> tuple:
        """(x0, y0, z0, sin lat0, cos lat0, sin lon0, cos lon0): the origin in ECEF and its rotation, as
        :meth:`to_geodetic` uses them (read by the compiled lat/lon/alt getters of uavsim/_dynamics_ext.c)."""
        return self._x0, self._y0, self._z0, self._sp, self._cp, self._sl, self._cl

    def to_geodetic(self, e: float, n: float, u: float) -> tuple[float, float, float]:
        """ENU (m) -> (lat deg, lon deg, alt m) as Python floats."""
        from math import atan2, cos, degrees, hypot, sin, sqrt
        sp, cp, sl, cl = self._sp, self._cp, self._sl, self._cl
        x = self._x0 + (-sl * e - sp * cl * n + cp * cl * u)
        y = self._y0 + (cl * e - sp * sl * n + cp * sl * u)
        z = self._z0 + (cp * n + sp * u)
        a, b, e2, ep2 = WGS84_A, WGS84_B, WGS84_E2, WGS84_EP2
        p = hypot(x, y)
        lon = atan2(y, x)
        theta = atan2(z * a, p * b)
        st, ct = sin(theta), cos(theta)
        lat = atan2(z + ep2 * b * st ** 3, p - e2 * a * ct ** 3)
        for _ in range(2):
            s = sin(lat)
            lat = atan2(z + e2 * (a / sqrt(1.0 - e2 * s * s)) * s, p)
        s, c = sin(lat), cos(lat)
        alt = p * c + z * s - a * sqrt(1.0 - e2 * s * s)
        return degrees(lat), degrees(lon), alt
