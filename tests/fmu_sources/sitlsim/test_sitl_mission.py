"""Where a SITL vehicle is sent, and what run.json says about its clock (docs/sitl.md, "Position targets").

Without the binary: the firmware's lat/lon rule (sitlsim/ap_location.py) against hand-derived values (a
sphere of radius 6378100 m: 1e-7 deg of latitude = 6378100 * pi / 180 * 1e-7 m), and the size of the error
WGS84 coordinates would give the firmware, from the WGS84 meridian radius of curvature
M = a (1 - e^2) / (1 - e^2 sin^2 lat)^1.5 and the base's height above the ellipsoid.  With the real ArduCopter SITL: a vehicle sent 450 m south-west of
its pad settles on the set-point (the firmware's position controller holds a GUIDED target to centimetres;
with WGS84 targets it settled 2.6 m off), and run.json carries the clock monitor's per-vehicle facts.
"""
from __future__ import annotations

import json
import math
import socket

import pytest
from sitlveh_helpers import lean_sitl, real_binary

from sitlsim import ap_location as A
from sitlsim.process import ports
from sitlsim.vehicle import FLY, SitlConfig, SitlVehicle
from uavsim.geodesy import WGS84_A, WGS84_E2, EnuFrame

BASE = (-7.275, -35.965, 540.0)
BINARY, WHY = real_binary()
needs_sitl = pytest.mark.skipif(BINARY is None, reason=f"{WHY}: the real-SITL tests are skipped")
R_AP = 6378100.0     # ArduPilot's RADIUS_OF_EARTH (m)


def test_one_e7_degree_of_latitude_is_the_firmware_sphere_arc():
    assert A.LOCATION_SCALING_FACTOR == pytest.approx(R_AP * math.pi / 180.0 * 1e-7, rel=1e-15)
    home = (A.to_e7(BASE[0]), A.to_e7(BASE[1]))
    assert home == (-72750000, -359650000)
    lat, lon = A.offset(*home, 1000.0, 0.0)
    assert (lat - home[0], lon) == (int(1000.0 / (R_AP * math.pi / 180.0 * 1e-7)), home[1])   # 89832
    # east: the same arc shrunk by cos(latitude) at the mid latitude
    lat, lon = A.offset(*home, 0.0, 1000.0)
    assert lat == home[0]
    assert lon - home[1] == int(1000.0 / (R_AP * math.pi / 180.0 * 1e-7) / math.cos(math.radians(7.275)))


@pytest.mark.parametrize("north, east", [(450.9, 0.0), (-450.9, -566.0), (30.0, 20.0), (0.0, 600.0)])
def test_offset_and_distance_are_inverse_to_a_centimetre(north, east):
    home = (A.to_e7(BASE[0]), A.to_e7(BASE[1]))
    n, e = A.distance_ne(*home, *A.offset(*home, north, east))
    # truncation to whole 1e-7 deg: at most 1.1 cm north, 1.1 cm / cos(lat) east
    assert abs(n - north) < 0.0112 and abs(e - east) < 0.0113


def test_wgs84_coordinates_put_a_far_target_beyond_the_arrival_radius_for_the_firmware():
    """What the 4-UAV mission met: 450.9 m north of the base (h0 = 540 m above the ellipsoid) spans the angle
    450.9 / (M + h0), which the firmware's sphere turns into 450.9 * R / (M + h0) m north."""
    fr = EnuFrame(*BASE)
    lat, lon, _ = fr.to_geodetic(0.0, 450.9, 0.0)
    home = (A.to_e7(BASE[0]), A.to_e7(BASE[1]))
    n, _ = A.distance_ne(*home, A.to_e7(lat), A.to_e7(lon))
    phi = math.radians(BASE[0] + 0.5 * (lat - BASE[0]))
    meridian = WGS84_A * (1 - WGS84_E2) / (1 - WGS84_E2 * math.sin(phi) ** 2) ** 1.5
    assert n == pytest.approx(450.9 * R_AP / (meridian + BASE[2]), abs=0.012)     # 1e-7 deg truncation
    assert n - 450.9 > 2.0          # more than the strategy's arrival radius (2 m)


@pytest.mark.parametrize("home_enu", [(0.0, 0.0), (5.656854, 0.0)])
def test_set_points_reach_the_firmware_as_metres_from_its_home(home_enu):
    """The vehicle writes an ENU set-point so that the firmware measures it where our physics' metres put it."""
    fr = EnuFrame(*BASE)
    hlat, hlon, _ = fr.to_geodetic(*home_enu, 0.0)
    v = SitlVehicle(SitlConfig(home=(hlat, hlon, BASE[2], 0.0)), home_enu)
    for x, y in [(-566.0, -450.9), (275.6, -389.2), (0.0, 0.0)]:
        lat, lon = v._geodetic(x, y)
        n, e = A.distance_ne(*v.home_e7, round(lat * 1e7), round(lon * 1e7))     # as the link encodes them
        assert abs(n - (y - home_enu[1])) < 0.0112 and abs(e - (x - home_enu[0])) < 0.0113


# ------------------------------------------------------------------------------------------ with the real binary
@needs_sitl
def test_a_far_set_point_is_held_to_centimetres(tmp_path):
    cfg = SitlConfig(binary=BINARY, workdir=str(tmp_path / "sitl"), home=(*BASE, 0.0), takeoff_altitude=5.0,
                     **lean_sitl(WPNAV_SPEED=1500.0))
    v = SitlVehicle(cfg, (0.0, 0.0))
    sp = (-300.0, -400.0, 5.0)           # 500 m out: WGS84 targets were 2.6 m off here
    try:
        v.start()
        # the test rates reached the firmware: its servo frames say 400 a second, and it opened no ground-station
        # port (SERIAL1, TCP 5762+10N)
        assert v.physics.sitl_frame_rate == 400
        with pytest.raises(ConnectionRefusedError):
            socket.create_connection(("127.0.0.1", ports(v.instance)["serial1"]), timeout=5).close()
        t, h = 0.0, 0.5
        while v.phase != FLY:
            v.step(t, h, 1, sp, (0.0, 0.0, 0.0))
            t += h
            assert t < 30.0, f"no take-off by t={t}"
        still = 0
        while still < 4:                 # settled: 2 s near the set-point below 5 cm/s
            v.step(t, h, 2, sp, (0.0, 0.0, 0.0))
            t += h
            near = math.hypot(v.pos[0] - sp[0], v.pos[1] - sp[1]) < 5.0
            still = still + 1 if near and math.hypot(v.vel[0], v.vel[1]) < 0.05 else 0
            assert t < 120.0, f"not settled by t={t}: at {v.pos}"
        assert math.hypot(v.pos[0] - sp[0], v.pos[1] - sp[1]) < 0.3
        assert v.max_slip == 0.0         # 0.5 s = 200 whole frames: the clocks agree
    finally:
        v.close()


@needs_sitl
@pytest.mark.parametrize("coupling", ["lockstep", "paced"])
def test_run_json_carries_each_sitl_vehicles_clock(request, coupling):
    """On the runs shared with test_sitl_vehicle.py (conftest.py): lock-step, four SITL UAVs and a point-mass
    one stepped by two threads; paced, the one-UAV short mission."""
    shared = request.getfixturevalue("sitl_fleet" if coupling == "lockstep" else "paced_mission")
    res = shared.result
    assert res.metadata["outcome"] == "completed", res.metadata.get("error")
    clock = json.loads((shared.out / "run.json").read_text())["monitors"]["org.cosim-master.sitl-clock"]
    info = clock["vehicles"]
    sitl = [f"uav{k}_dyn" for k in range(1, 5)] if coupling == "lockstep" else ["uav1_dyn"]
    assert list(info) == sitl                          # the point-mass UAV (uav5) has no clock of its own
    # every step of the run: to the stop time (lock-step fleet), to the landing (paced mission)
    steps = round(res.frame["time"].iloc[-1] / 0.1)
    assert coupling == "paced" or steps == round(shared.stop / 0.1)
    for name in sitl:
        u = info[name]
        assert u["coupling"] == coupling and u["steps"] == steps
        if coupling == "lockstep":
            assert u["max_slip_s"] == 0.0                  # 0.1 s = 40 whole frames (at the test rate, 400)
        else:
            # the monitor's view of every step agrees with the FMU's own running maximum; the vehicle clock is
            # never behind a communication point (the step waits for it)
            assert u["max_slip_s"] == res.frame[f"{name}.max_slip"].iloc[-1]
            assert (res.frame[f"{name}.slip"] >= 0.0).all()
            assert 0.0 <= u["mean_slip_s"] <= u["max_slip_s"] and 0.0 <= u["p95_slip_s"] <= u["max_slip_s"]
        # the firmware is ready once its EKF uses GPS (~41.6 s after boot, ../shared/sitl/README.md)
        assert 35.0 < u["ready_time_s"] < 60.0
