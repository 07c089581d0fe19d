"""The fleet as MAVLink vehicles, seen by a pymavlink ground station in the test (uavstudy/mavlink).

One run of the shipped 4-UAV mission with restricted zones (ssp/paper_zones_4uav_B.ssp, 150 s), stepped
from the test so that the ground station's requests and the run's answers interleave deterministically:
the expectations come from the scenario's YAML (targets and zones in WGS84, the equal split of the 24
targets in map order: docs/uav_models.md), from the run's own trajectory.csv and events.csv (what the stream
must agree with), and from the MAVLink protocol (mavlink.io: mission protocol, command protocol).
"""
from __future__ import annotations

import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

pytest.importorskip("pymavlink")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as m  # noqa: E402

from master.execution import Execution  # noqa: E402
from loopback import free_port  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
SSP = ROOT / "ssp" / "paper_zones_4uav_B.ssp"
YAML = ROOT / "ssp" / "scenarios" / "paper_area_zones.yaml"
STOP = 150.0
RTL_AT = 60.0          # uav2 is flying to its targets then (it takes off at 5 s)


class Gcs:
    """A ground station: pymavlink listening where the run sends (udpout), everything it got kept."""

    def __init__(self, port):
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
        self.got: list = []

    def drain(self, wait=0.05, until=None):
        """Keep what arrives for ``wait`` seconds, or until a message ``until(msg)`` is true (returned)."""
        end = time.monotonic() + wait
        while True:
            msg = self.conn.recv_match(blocking=False)
            if msg is None:
                if time.monotonic() > end:
                    return None
                time.sleep(0.002)
                continue
            if msg.get_type() != "BAD_DATA":
                self.got.append(msg)
                if until is not None and until(msg):
                    return msg

    def expect(self, ex, typ, sysid, **fields):
        """Step the run until the vehicle ``sysid`` answers with a ``typ`` message matching ``fields`` (the
        streaming process answers requests at once; a command reaches the run before its next step). Before
        each step the streaming process gets up to half a second to answer or to pass a command on, which a
        busy machine needs: an answer ends the wait at once, so an idle machine does not wait."""
        def wanted(msg):
            return msg.get_type() == typ and msg.get_srcSystem() == sysid and \
                all(getattr(msg, k) == v for k, v in fields.items())
        for _ in range(20):
            msg = self.drain(0.5, until=wanted)
            if msg is not None:
                return msg
            ex.step()
            msg = self.drain(0.02, until=wanted)
            if msg is not None:
                return msg
        raise AssertionError(f"no {typ} {fields} from vehicle {sysid}")

    def of(self, typ):
        return [g for g in self.got if g.get_type() == typ]


def download(gcs, ex, sysid, mission_type):
    """The mission protocol's download handshake; returns the items."""
    mav = gcs.conn.mav
    mav.mission_request_list_send(sysid, 1, mission_type)
    count = gcs.expect(ex, "MISSION_COUNT", sysid, mission_type=mission_type).count
    items = []
    for seq in range(count):
        mav.mission_request_int_send(sysid, 1, seq, mission_type)
        items.append(gcs.expect(ex, "MISSION_ITEM_INT", sysid, seq=seq, mission_type=mission_type))
    mav.mission_ack_send(sysid, 1, m.MAV_MISSION_ACCEPTED, mission_type)
    ex.step()
    return items


@pytest.fixture(scope="module")
def streamed(tmp_path_factory):
    out = tmp_path_factory.mktemp("mavlink") / "run"
    port = free_port()
    gcs = Gcs(port)
    ex = Execution(SSP, output=out, stop_time=STOP, mavlink=[f"udpout:127.0.0.1:{port}"])
    ex.initialize()
    ex.simulate_until(1.0)
    gcs.drain()
    plans = {sysid: download(gcs, ex, sysid, m.MAV_MISSION_TYPE_MISSION) for sysid in (1, 2, 3, 4)}
    fence = download(gcs, ex, 3, m.MAV_MISSION_TYPE_FENCE)
    # an upload is refused: the plan is the scenario's
    gcs.conn.mav.mission_count_send(1, 1, 3, m.MAV_MISSION_TYPE_MISSION)
    upload = gcs.expect(ex, "MISSION_ACK", 1)
    while ex.time < RTL_AT - 1e-9:
        ex.simulate_until(min(RTL_AT, ex.time + 2.0))
        gcs.drain(0.01)
    gcs.conn.mav.command_long_send(2, 1, m.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0, 0)
    rtl_ack = gcs.expect(ex, "COMMAND_ACK", 2, command=m.MAV_CMD_NAV_RETURN_TO_LAUNCH)
    gcs.conn.mav.command_long_send(3, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
    other_ack = gcs.expect(ex, "COMMAND_ACK", 3, command=m.MAV_CMD_DO_SET_MODE)
    while not ex.done:
        ex.simulate_until(ex.time + 2.0)
        gcs.drain(0.01)
    ex.close("completed")
    gcs.drain(0.2)
    gcs.conn.close()
    return dict(out=out, gcs=gcs, plans=plans, fence=fence, upload=upload, rtl_ack=rtl_ack, other_ack=other_ack,
                meta=ex.metadata, scenario=yaml.safe_load(YAML.read_text()))


def test_every_uav_is_its_own_vehicle(streamed):
    hb = streamed["gcs"].of("HEARTBEAT")
    assert {h.get_srcSystem() for h in hb} == {1, 2, 3, 4}         # the scenario's 4 UAVs
    assert {h.get_srcComponent() for h in hb} == {1}
    assert {(h.type, h.autopilot) for h in hb} == {(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_GENERIC)}
    # 1 Hz of simulated time: one per vehicle and simulated second (plus the first at t=0)
    assert len(hb) == 4 * (int(STOP) + 1)
    # armed exactly while airborne (landed state of the same second says so)
    types = {t.get_type() for t in streamed["gcs"].got}
    assert {"GLOBAL_POSITION_INT", "ATTITUDE", "VFR_HUD", "SYS_STATUS", "BATTERY_STATUS", "HOME_POSITION",
            "EXTENDED_SYS_STATE", "MISSION_CURRENT", "MISSION_ITEM_REACHED", "STATUSTEXT"} <= types


def test_positions_match_the_trajectory_at_the_same_times(streamed):
    traj = pd.read_csv(streamed["out"] / "trajectory.csv")
    traj = traj[traj.status == "active"]
    by_key = {(row.uav, round(row.time * 1000)): row for row in traj.itertuples()}
    pos = streamed["gcs"].of("GLOBAL_POSITION_INT")
    assert len(pos) == 4 * (int(STOP * 10) + 1)                     # 10 Hz of simulated time, every vehicle
    compared = 0
    for p in pos:
        row = by_key.get((f"uav{p.get_srcSystem()}", p.time_boot_ms))
        if row is None:
            continue
        compared += 1
        assert abs(p.lat - row.lat * 1e7) <= 0.51 and abs(p.lon - row.lon * 1e7) <= 0.51
        assert abs(p.relative_alt - row.z * 1000) <= 0.51 and abs(p.alt - row.alt * 1000) <= 0.51
    assert compared == 4 * (int(STOP) + 1)          # trajectory.csv: the SSP's record interval, 1 s


def test_mission_and_fence_downloaded_with_the_handshake(streamed):
    scn = streamed["scenario"]
    targets = scn["targets"]
    for sysid, items in streamed["plans"].items():
        cmds = [i.command for i in items]
        # take-off, the UAV's 6 targets (the equal split of 24 in map order), return to launch
        assert cmds == [m.MAV_CMD_NAV_TAKEOFF] + [m.MAV_CMD_NAV_WAYPOINT] * 6 + [m.MAV_CMD_NAV_RETURN_TO_LAUNCH]
        for item, (lat, lon) in zip(items[1:7], targets[6 * (sysid - 1): 6 * sysid]):
            assert abs(item.x - lat * 1e7) <= 1 and abs(item.y - lon * 1e7) <= 1
            assert item.z == pytest.approx(scn["takeoff_altitude"])
    zones = scn["zones"]
    fence = streamed["fence"]
    assert len(fence) == sum(len(z["polygon"]) for z in zones)
    assert {f.command for f in fence} == {m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION}
    k = 0
    for z in zones:
        for lat, lon in z["polygon"]:
            assert fence[k].param1 == len(z["polygon"])
            assert abs(fence[k].x - lat * 1e7) <= 1 and abs(fence[k].y - lon * 1e7) <= 1
            k += 1
    downloads = streamed["meta"]["observers"]["mavlink"]["downloads"]
    assert len(downloads) == 5 and all(d["acknowledged"] and d["items_sent"] == d["items"] for d in downloads)
    assert streamed["upload"].type == m.MAV_MISSION_UNSUPPORTED


def test_a_statustext_for_every_event(streamed):
    events = pd.read_csv(streamed["out"] / "events.csv")
    texts = [(f"uav{t.get_srcSystem()}", t.text.split(":")[0]) for t in streamed["gcs"].of("STATUSTEXT")]
    monitor = events[events.type == "mission"]
    expected = sorted(zip(monitor.uav, monitor.event))
    assert sorted(t for t in texts if t[1] not in ("photo", "command")) == expected
    photos = pd.read_csv(streamed["out"] / "photos.csv")
    assert sorted(t for t in texts if t[1] == "photo") == sorted((u, "photo") for u in photos.uav)
    reached = streamed["gcs"].of("MISSION_ITEM_REACHED")
    assert len(reached) == len(photos)


def test_return_to_launch_is_applied_acknowledged_and_recorded(streamed):
    assert streamed["rtl_ack"].result == m.MAV_RESULT_ACCEPTED
    assert streamed["other_ack"].result == m.MAV_RESULT_UNSUPPORTED
    events = pd.read_csv(streamed["out"] / "events.csv")
    cmd = events[events.type == "command"]
    assert list(zip(cmd.uav, cmd.event)) == [("uav2", "return_to_launch")]
    applied = cmd.time.iloc[0]
    assert RTL_AT <= applied < RTL_AT + 1.0           # the step after the ground station sent it
    assert cmd.detail.iloc[0].startswith("accepted")
    uav2 = events[(events.uav == "uav2") & (events.type == "mission")]
    assert list(uav2.event)[-3:] == ["return_commanded", "landing", "landed_base"]
    assert uav2[uav2.event == "return_commanded"].time.iloc[0] == applied     # taken in that very step
    summary = pd.read_csv(streamed["out"] / "summary.csv").set_index("uav")
    # sent home with targets left: a commanded return, not a success; the others fly on to the stop time
    assert summary.loc["uav2", "outcome"] == "commanded_return"
    assert summary.loc["uav2", "targets_visited"] < 6
    assert set(summary.loc[["uav1", "uav3", "uav4"], "outcome"]) == {"timeout"}


def test_each_vehicle_counts_its_sequence_without_gaps(streamed):
    """A ground station measures link loss from each system's sequence numbers (MAVLink serialization)."""
    last = {}
    for msg in streamed["gcs"].got:
        sysid, seq = msg.get_srcSystem(), msg.get_seq()
        if sysid in last:
            assert seq == (last[sysid] + 1) % 256, (sysid, last[sysid], seq)
        last[sysid] = seq
    assert sorted(last) == [1, 2, 3, 4]


def test_a_replay_of_the_commands_is_the_same_run(streamed, tmp_path):
    """events.csv holds what the ground station did: replayed without one, the run is bit-identical."""
    import pyarrow.parquet as pq

    from master.runner import run
    from uavstudy.mavlink.replay import CommandReplay
    replay = run(SSP, output=tmp_path / "replay", stop_time=STOP,
                 manipulators=[CommandReplay(streamed["out"] / "events.csv")])
    assert pq.read_table(tmp_path / "replay" / "results.parquet").equals(
        pq.read_table(streamed["out"] / "results.parquet"))
    for name in ("summary.csv", "trajectory.csv", "photos.csv"):
        assert (tmp_path / "replay" / name).read_bytes() == (streamed["out"] / name).read_bytes(), name
    mission = pd.read_csv(tmp_path / "replay" / "events.csv")
    live = pd.read_csv(streamed["out"] / "events.csv")
    cols = ["time", "type", "event", "uav", "x", "y", "z", "consumed", "detail"]
    assert mission[cols].equals(live[live.type != "command"].reset_index(drop=True)[cols])
