"""The hook for vehicles with their own MAVLink stream (uavstudy/mavlink/forward.py): a fake firmware in the
test stands for a SITL-backed UAV; the ground station sees its messages as sent, with its own system id, its
commands reach it, and the simulated UAVs take the other system ids."""
import socket
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as m

from master.execution import Execution
from uavstudy.mavlink import forward
from test_mavlink_stream import Gcs, free_port

SSP = Path(__file__).resolve().parents[3] / "ssp" / "paper_zones_4uav_B.ssp"
FIRMWARE_SYSID = 2                       # what SYSID_THISMAV would say: it clashes with a simulated default


@pytest.fixture
def firmware():
    server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    server.bind(("127.0.0.1", 0))
    server.listen(1)
    port = server.getsockname()[1]
    source = forward.register_source(
        lambda monitor, plan: [forward.Forwarded("uav1", f"tcp:127.0.0.1:{port}", FIRMWARE_SYSID)])
    yield server
    forward.SOURCES.remove(source)
    server.close()


def test_a_forwarded_vehicle_keeps_its_stream_and_gets_its_commands(firmware, tmp_path):
    port = free_port()
    gcs = Gcs(port)
    ex = Execution(SSP, output=tmp_path / "out", stop_time=10, mavlink=[f"udpout:127.0.0.1:{port}"])
    ex.initialize()
    conn, _ = firmware.accept()                          # the stream connected to the firmware
    fw = m.MAVLink(None, srcSystem=FIRMWARE_SYSID, srcComponent=1)
    own = fw.heartbeat_encode(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 4, 4, 3).pack(fw)
    conn.sendall(own)
    gcs.drain(0.2)
    ex.simulate_until(2.0)
    gcs.drain(0.2)
    hb = gcs.of("HEARTBEAT")
    assert any(h.get_srcSystem() == FIRMWARE_SYSID and h.autopilot == m.MAV_AUTOPILOT_ARDUPILOTMEGA for h in hb)
    simulated = {h.get_srcSystem() for h in hb if h.autopilot == m.MAV_AUTOPILOT_GENERIC}
    assert simulated == {1, 3, 4}                         # uav2..uav4; the firmware's id is skipped
    assert not any(h.get_srcSystem() == FIRMWARE_SYSID and h.autopilot == m.MAV_AUTOPILOT_GENERIC for h in hb)
    gcs.conn.mav.command_long_send(FIRMWARE_SYSID, 1, m.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 0, 0, 0, 0, 0, 0, 0)
    conn.settimeout(5.0)
    parser, got, end = m.MAVLink(None), [], time.monotonic() + 5
    while not got and time.monotonic() < end:
        ex.step()
        try:
            got = [g for g in parser.parse_buffer(conn.recv(4096)) or [] if g.get_type() == "COMMAND_LONG"]
        except socket.timeout:
            pass
    assert got and got[0].command == m.MAV_CMD_NAV_RETURN_TO_LAUNCH and got[0].target_system == FIRMWARE_SYSID
    ex.close("completed")
    conn.close()
    gcs.conn.close()
