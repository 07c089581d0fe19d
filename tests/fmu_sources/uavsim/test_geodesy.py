"""Tests of uavsim.geodesy against independent reference values."""
import math

import numpy as np
import pytest

from uavsim.geodesy import (
    WGS84_A, WGS84_B, ecef_from_geodetic, geodetic_from_ecef,
    enu_from_geodetic, geodetic_from_enu, meridian_radius,
)


def test_ecef_equator_prime_meridian():
    x, y, z = ecef_from_geodetic(0.0, 0.0, 0.0)
    assert (float(x), float(y), float(z)) == pytest.approx((6378137.0, 0.0, 0.0), abs=1e-9)


def test_ecef_equator_90e_with_altitude():
    x, y, z = ecef_from_geodetic(0.0, 90.0, 100.0)
    assert float(x) == pytest.approx(0.0, abs=1e-6)
    assert float(y) == pytest.approx(6378237.0, abs=1e-6)
    assert float(z) == pytest.approx(0.0, abs=1e-9)


def test_ecef_poles_are_semi_minor_axis():
    # b = a (1 - f) = 6356752.314245 m (WGS84 published value)
    assert WGS84_B == pytest.approx(6356752.314245, abs=1e-6)
    x, y, z = ecef_from_geodetic(90.0, 0.0, 0.0)
    assert float(z) == pytest.approx(6356752.314245, abs=1e-6)
    assert abs(float(x)) < 1e-6 and abs(float(y)) < 1e-6
    x, y, z = ecef_from_geodetic(-90.0, 0.0, 0.0)
    assert float(z) == pytest.approx(-6356752.314245, abs=1e-6)
    lat, lon, alt = geodetic_from_ecef(0.0, 0.0, 6356752.314245 + 10.0)
    assert float(lat) == pytest.approx(90.0, abs=1e-12)
    assert float(alt) == pytest.approx(10.0, abs=1e-6)


def test_ecef_45_degrees_reference():
    # independent: N = a / sqrt(1 - e2 sin^2) written out by hand
    e2 = 0.00669437999014
    N = 6378137.0 / math.sqrt(1 - e2 * 0.5)
    x, y, z = ecef_from_geodetic(45.0, 45.0, 0.0)
    assert float(x) == pytest.approx(N * 0.5, abs=1e-3)
    assert float(y) == pytest.approx(N * 0.5, abs=1e-3)
    assert float(z) == pytest.approx(N * (1 - e2) * math.sqrt(0.5), abs=1e-3)


def test_one_arcsecond_latitude_at_45_deg():
    # meridian radius M(45) = a(1-e2)/(1-e2/2)^1.5 = 6367381.8 m; 1" = M * pi/648000
    M = meridian_radius(45.0)
    assert float(M) == pytest.approx(6367381.8, abs=0.1)
    expected = float(M) * math.pi / 648000.0
    assert expected == pytest.approx(30.87, abs=0.01)
    e, n, u = enu_from_geodetic(45.0 + 1.0 / 3600.0, 10.0, 0.0, 45.0, 10.0, 0.0)
    assert float(n) == pytest.approx(expected, abs=1e-4)
    assert abs(float(e)) < 1e-9
    # curvature drop over 31 m is n^2/(2R) ~ 0.075 mm
    assert float(u) == pytest.approx(-expected ** 2 / (2 * 6367000.0), abs=1e-5)


def test_one_arcsecond_longitude_at_45_deg():
    # parallel radius N cos(lat); 1" of longitude ~ 21.90 m at 45 deg
    e2 = 0.00669437999014
    N = 6378137.0 / math.sqrt(1 - e2 * 0.5)
    expected = N * math.sqrt(0.5) * math.pi / 648000.0
    e, n, u = enu_from_geodetic(45.0, 10.0 + 1.0 / 3600.0, 0.0, 45.0, 10.0, 0.0)
    assert float(e) == pytest.approx(expected, abs=1e-4)
    assert float(e) == pytest.approx(21.90, abs=0.01)


def test_origin_maps_to_zero_and_up_is_up():
    e, n, u = enu_from_geodetic(-22.9, -43.2, 15.0, -22.9, -43.2, 5.0)
    assert float(e) == pytest.approx(0.0, abs=1e-9)
    assert float(n) == pytest.approx(0.0, abs=1e-9)
    assert float(u) == pytest.approx(10.0, abs=1e-9)


def test_round_trip_within_50km_below_1mm():
    rng = np.random.default_rng(1234)
    worst = 0.0
    for lat0, lon0, alt0 in [(-22.9, -43.2, 5.0), (45.0, 7.6, 300.0), (0.0, 0.0, 0.0),
                             (69.6, 18.9, 10.0), (-89.0, 120.0, 2800.0)]:
        n = 2000
        e = rng.uniform(-50e3, 50e3, n)
        nn = rng.uniform(-50e3, 50e3, n)
        keep = np.hypot(e, nn) <= 50e3
        e, nn = e[keep], nn[keep]
        u = rng.uniform(-1000.0, 5000.0, e.size)
        lat, lon, alt = geodetic_from_enu(e, nn, u, lat0, lon0, alt0)
        e2, n2, u2 = enu_from_geodetic(lat, lon, alt, lat0, lon0, alt0)
        err = np.sqrt((e2 - e) ** 2 + (n2 - nn) ** 2 + (u2 - u) ** 2)
        worst = max(worst, float(err.max()))
        # and geodetic -> enu -> geodetic
        lat3, lon3, alt3 = geodetic_from_enu(e2, n2, u2, lat0, lon0, alt0)
        assert np.max(np.abs(lat3 - lat)) * 111e3 < 1e-3
        assert np.max(np.abs(alt3 - alt)) < 1e-3
    assert worst < 1e-3
    print(f"max ENU round-trip error within 50 km: {worst:.3e} m")


def test_geodetic_ecef_round_trip_high_altitude():
    rng = np.random.default_rng(7)
    lat = rng.uniform(-90, 90, 1000)
    lon = rng.uniform(-180, 180, 1000)
    alt = rng.uniform(-5000, 1e5, 1000)
    lat2, lon2, alt2 = geodetic_from_ecef(*ecef_from_geodetic(lat, lon, alt))
    assert np.max(np.abs(lat2 - lat)) < 1e-10
    assert np.max(np.abs(alt2 - alt)) < 1e-6
    d = np.abs((lon2 - lon + 180) % 360 - 180) * np.cos(np.radians(lat))
    assert np.max(d) < 1e-10


def test_array_broadcasting_shapes():
    lat = np.array([[45.0, 45.001], [45.002, 45.003]])
    e, n, u = enu_from_geodetic(lat, 7.0, 0.0, 45.0, 7.0, 0.0)
    assert e.shape == n.shape == u.shape == (2, 2)
    assert float(n[0, 1]) == pytest.approx(111.13, abs=0.05)


def test_enu_frame_scalar_fast_path_matches_numpy():
    from uavsim.geodesy import EnuFrame
    rng = np.random.default_rng(1)
    for lat0, lon0, alt0 in ((-7.275, -35.965, 540.0), (52.5, 13.4, 34.0), (-89.0, 170.0, 2800.0), (0.0, 0.0, 0.0)):
        fr = EnuFrame(lat0, lon0, alt0)
        for e, n, u in rng.uniform([-5e4, -5e4, -100], [5e4, 5e4, 5e3], size=(200, 3)):
            lat, lon, alt = fr.to_geodetic(float(e), float(n), float(u))
            rl, ro, ra = geodetic_from_enu(e, n, u, lat0, lon0, alt0)
            assert isinstance(lat, float) and isinstance(alt, float)
            assert abs(lat - float(rl)) < 1e-12 and abs(lon - float(ro)) < 1e-12 and abs(alt - float(ra)) < 1e-8
