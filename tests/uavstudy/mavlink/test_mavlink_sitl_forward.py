"""SITL-backed UAVs on the ground station (uavstudy/mavlink/sitl_source.py): the firmware's own stream is
forwarded, the simulated telemetry of that UAV is not sent, its mission events come from the firmware's system.

Without the binary: which UAVs are picked (those whose dynamics component is UavSitl.fmu, from the scenario
built by uavstudy/build.py: UAV k gets SITL ``--sysid k``), the address (SITL's SERIAL1, TCP 5762+10N, from
ArduPilot's port scheme), and a fake firmware standing for uav1 whose mission events arrive as STATUSTEXT from
component 191 of its system.  With the real ArduCopter SITL ($ARDUPILOT_SITL, else ../shared/sitl/arducopter;
skipped with the reason when absent): a ground station sees HEARTBEAT with autopilot ARDUPILOTMEGA and
GLOBAL_POSITION_INT at the scenario's home from the firmware's system id, and its SET_MESSAGE_INTERVAL and
MAV_CMD_REQUEST_MESSAGE reach the firmware, which answers COMMAND_ACK (ArduPilot's documented behaviour).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as m

import master
from master.errors import CosimError
from master.execution import Execution
from uavsim.geodesy import EnuFrame
from uavstudy.build import build_ssp
from uavstudy.mavlink import sitl_source
from uavstudy.mavlink.fleet import Fleet
from uavstudy.mavlink.forward import forwarded_vehicles
from uavstudy.scenario import SitlOptions, UavScenario
from test_mavlink_forward import FIRMWARE_SYSID, SSP, firmware  # noqa: F401 - the fake firmware fixture
from test_mavlink_stream import Gcs, free_port

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "fmu_sources" / "sitlsim"))   # test_sitl_vehicle
from sitlveh_helpers import lean_sitl, real_binary  # noqa: E402
from test_sitl_vehicle import sitl_pids  # noqa: E402

BASE = (-7.275, -35.965, 540.0)
BINARY, WHY = real_binary()
COMPANION = m.MAV_COMP_ID_ONBOARD_COMPUTER


def sitl_scenario(tmp_path, vehicle, n_uavs, stop=30.0, gcs_port=True) -> Path:
    """At the test rates (lean_sitl: nothing asserted here depends on them), SERIAL1 open unless ``gcs_port``
    is false."""
    fr = EnuFrame(*BASE)
    targets = [fr.to_geodetic(30.0 * (k + 1), 20.0, 0.0)[:2] for k in range(n_uavs)]
    scn = UavScenario(name="fwd", base=BASE, n_uavs=n_uavs, strategy="B", targets=targets, takeoff_altitude=5.0,
                      stop_time=stop, seed=3, vehicle=vehicle,
                      sitl=SitlOptions(coupling="lockstep", speedup=80.0, **lean_sitl(gcs_port=gcs_port)))
    return build_ssp(scn, tmp_path / "fwd.ssp")


def monitor_and_plan(ssp):
    ex = Execution(ssp, output=None)        # set up only: no output folder (the working directory is not ours)
    ex.setup()
    monitor = next(mo for mo in ex.monitors if hasattr(mo, "cfg"))
    return monitor, ex.prepared.plan


# ------------------------------------------------------------------------------------------ without the binary
def test_the_uavs_flown_by_sitl_are_forwarded_from_serial1_with_their_own_ids(tmp_path):
    monitor, plan = monitor_and_plan(sitl_scenario(tmp_path, ["point_mass", "sitl", "point_mass", "sitl"], 4))
    fwd = forwarded_vehicles(monitor, plan)
    assert [(f.uav, f.sysid) for f in fwd] == [("uav2", 2), ("uav4", 4)]      # build.py: --sysid k for UAV k
    assert [f.variables for f in fwd] == [("uav2_dyn.sitl_instance",), ("uav4_dyn.sitl_instance",)]
    assert fwd[0].address({"uav2_dyn.sitl_instance": 3}.get) == "tcp:127.0.0.1:5792"   # 5762 + 10*3
    fleet = Fleet(monitor, plan, fwd)
    assert [(v.name, v.sysid) for v in fleet.vehicles] == [("uav1", 1), ("uav3", 3)]   # simulated: the others
    assert set(fleet.required_variables()) >= {"uav2_dyn.sitl_instance", "uav4_dyn.sitl_instance"}
    assert not any(q.startswith(("uav2_", "uav4_")) and not q.endswith("sitl_instance")
                   for q in fleet.required_variables())                        # no telemetry read for them


def test_a_headless_sitl_cannot_be_forwarded_and_says_why(tmp_path):
    monitor, plan = monitor_and_plan(sitl_scenario(tmp_path, ["point_mass", "sitl"], 2, gcs_port=False))
    with pytest.raises(CosimError) as err:
        forwarded_vehicles(monitor, plan)
    msg = str(err.value)
    assert "uav2" in msg and "uav2_dyn.gcs_port false" in msg and "sitl.gcs_port" in msg and "\n" not in msg


def test_two_firmwares_with_one_system_id_are_refused(tmp_path):
    ssp = sitl_scenario(tmp_path, "sitl", 2)
    res = master.run(ssp, output=tmp_path / "out", raise_on_error=False, mavlink=[f"udpout:127.0.0.1:{free_port()}"],
                     params={"uav2_dyn.sysid": 1})
    msg = res.metadata.get("error") or ""
    assert "uav1 and uav2 both speak MAVLink as system id 1" in msg and "\n" not in msg


def test_a_forwarded_uavs_mission_events_come_from_its_system_not_its_autopilot(firmware, tmp_path):  # noqa: F811
    port = free_port()
    gcs = Gcs(port)
    ex = Execution(SSP, output=tmp_path / "out", stop_time=20, mavlink=[f"udpout:127.0.0.1:{port}"])
    ex.initialize()
    conn, _ = firmware.accept()
    ex.simulate_until(17.0)
    gcs.drain(0.3)
    uav1 = [e["event"] for e in ex.events if e.get("uav") == "uav1" and e.get("type") == "mission"]
    assert uav1, "the scenario gives uav1 no mission event in 17 s"
    texts = [t for t in gcs.of("STATUSTEXT") if t.get_srcSystem() == FIRMWARE_SYSID]
    assert [t.text.split(":")[0] for t in texts] == uav1 == ["takeoff", "transit"]
    assert {t.get_srcComponent() for t in texts} == {COMPANION}
    assert not [g for g in gcs.got if g.get_srcSystem() == FIRMWARE_SYSID and g.get_srcComponent() == 1]
    ex.close("completed")
    conn.close()
    gcs.conn.close()


# ------------------------------------------------------------------------------------------ with the real binary
@pytest.mark.skipif(BINARY is None, reason=f"{WHY}: the real-SITL forwarding test is skipped")
def test_the_ground_station_sees_and_commands_the_real_firmware(tmp_path, monkeypatch):
    monkeypatch.setenv("ARDUPILOT_SITL", BINARY)
    port = free_port()
    gcs = Gcs(port)
    ex = Execution(sitl_scenario(tmp_path, "sitl", 1), output=tmp_path / "out", stop_time=30,
                   mavlink=[f"udpout:127.0.0.1:{port}"])
    ex.initialize()                                      # SITL started and ready to arm
    mav, sysid = gcs.conn.mav, 1

    def seen():
        got = [g for g in gcs.got if g.get_srcSystem() == sysid and g.get_srcComponent() == 1]
        acks = {a.command: a.result for a in got if a.get_type() == "COMMAND_ACK"}
        return ({g.get_type() for g in got}, acks)
    asked = False
    end = time.monotonic() + 25
    while time.monotonic() < end and ex.n < ex.settings.steps:
        ex.step()
        gcs.drain(0.005)
        types, acks = seen()
        if "HEARTBEAT" in types and not asked:     # the ground station answers whoever it heard from
            asked = True
            mav.command_long_send(sysid, 1, m.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                  m.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 200_000, 0, 0, 0, 0, 0)
            mav.command_long_send(sysid, 1, m.MAV_CMD_REQUEST_MESSAGE, 0, m.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
                                  0, 0, 0, 0, 0, 0)
        texts = [g for g in gcs.of("STATUSTEXT") if (g.get_srcSystem(), g.get_srcComponent()) == (sysid, COMPANION)]
        if {"GLOBAL_POSITION_INT", "AUTOPILOT_VERSION"} <= types and len(acks) == 2 and texts:
            break
    t = ex.time
    meta = ex.close("completed")
    gcs.drain(0.1)
    gcs.conn.close()
    types, acks = seen()
    assert acks == {m.MAV_CMD_SET_MESSAGE_INTERVAL: m.MAV_RESULT_ACCEPTED,
                    m.MAV_CMD_REQUEST_MESSAGE: m.MAV_RESULT_ACCEPTED}, (t, types)
    hb = [h for h in gcs.of("HEARTBEAT") if h.get_srcSystem() == sysid]
    assert hb and all(h.autopilot == m.MAV_AUTOPILOT_ARDUPILOTMEGA for h in hb)      # the firmware, not ours
    assert not [h for h in gcs.of("HEARTBEAT") if h.autopilot == m.MAV_AUTOPILOT_GENERIC]   # no simulated uav1
    pos = [p for p in gcs.of("GLOBAL_POSITION_INT") if p.get_srcSystem() == sysid]
    assert pos and abs(pos[-1].lat / 1e7 - BASE[0]) < 1e-3 and abs(pos[-1].lon / 1e7 - BASE[1]) < 1e-3
    assert "AUTOPILOT_VERSION" in types
    takeoff = [e["time"] for e in ex.events if e.get("event") == "takeoff"]
    assert takeoff and [x.text for x in texts][:1] == ["takeoff: taking off"], (t, takeoff)   # the monitor's event
    assert meta["observers"]["mavlink"]["forwarded"] == [{"uav": "uav1", "sysid": 1, "from": ANY_SERIAL1}]
    assert sitl_pids(tmp_path) == []


class _Serial1:
    """Equal to the address of some SITL instance's SERIAL1 on 127.0.0.1 (5762 + 10 N)."""

    def __eq__(self, url):
        port = int(url.rsplit(":", 1)[1])
        return url.startswith("tcp:127.0.0.1:") and port >= 5762 and (port - 5762) % 10 == 0


ANY_SERIAL1 = _Serial1()
