"""LockstepPhysics against a fake SITL peer of our own and against the real ArduCopter SITL binary."""
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sitlsim import physics as ph
from sitlsim.frames import seconds
from sitlsim.iris import IrisParams, defaults_text
from sitlsim.lockstep import LockstepPhysics, SitlSilent
from sitlphys_helpers import FakeSitl, free_instance, sitl_binary  # noqa: E402


@pytest.fixture(params=["python", "compiled"])
def kernel(request, tmp_path_factory):
    if request.param == "python":
        return ph.python()
    folder = tmp_path_factory.mktemp("sitlsim")
    if ph.compile_library(folder) is None:
        pytest.skip("no C compiler: the compiled twin cannot be built here")
    return ph._try(folder / ph.LIBRARY)


def lockstep(kernel, **kw):
    kw.setdefault("wall_timeout", 5.0)
    return LockstepPhysics(port=_free_udp_port(), kernel=kernel, **kw)


def _free_udp_port():
    import socket
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def stamps(peer):
    return [json.loads(a)["timestamp"] for a in peer.answers]


def test_advance_answers_exactly_h_times_rate_frames(kernel):
    with lockstep(kernel) as phys:
        peer = FakeSitl(phys.port).start()
        try:
            for h, total in ((0.5, 600), (0.25, 900), (1 / 1200, 901), (0.0, 901)):
                st = phys.advance(h)
                assert phys.frames_answered == total
                assert phys.time == total / 1200 and st.time == phys.time
            peer.wait_answered(901)
            time.sleep(0.05)             # the peer has sent frame 901 and waits: nothing more is answered
            assert len(peer.answers) == 901 and peer.answered_counts == list(range(901))
        finally:
            peer.stop()
    ts = stamps(peer)
    assert ts == [float(seconds(ph.timestamp_ns(k, 1200))) for k in range(1, 902)]
    assert phys.sitl_frame_rate == 1200 and st.frame_count == 900


def test_resent_frames_do_not_advance_the_physics(kernel):
    with lockstep(kernel) as phys:
        peer = FakeSitl(phys.port, duplicate=True).start()
        try:
            phys.advance(0.1)
            peer.wait_answered(120)
            time.sleep(0.05)
        finally:
            peer.stop()
    assert phys.frames_answered == 120 and phys.time == 0.1
    assert phys.stale_frames >= 119
    assert len(peer.answers) == 120           # one answer per frame, none for the re-sent copies


def test_a_resent_frame_is_never_answered_twice_however_slow_sitl_is(kernel):
    # SITL re-sends a frame when our answer is late (a pause between doSteps); the copy reaches us after we
    # answered.  If SITL then takes long for its next frame, a second answer would be read by SITL as the
    # answer to that next frame: the firmware would run one frame ahead of the physics from then on.
    with lockstep(kernel) as phys:
        peer = FakeSitl(phys.port, duplicate=True, pause_after={5: 0.6}).start()
        try:
            phys.advance(10 / 1200)
            peer.wait_answered(10)
            time.sleep(0.05)
        finally:
            peer.stop()
    assert phys.frames_answered == 10 and phys.stale_frames == 9     # the tenth copy is still unread
    assert peer.answered_counts == list(range(10))
    assert len(peer.answers) == 10                     # one datagram per frame, nothing queued behind
    assert stamps(peer) == [float(seconds(ph.timestamp_ns(k, 1200))) for k in range(1, 11)]


def test_a_lost_answer_is_not_sent_again_and_sitl_is_reported_silent(kernel):
    # on loopback an answer is never lost; if it were, answering SITL's re-sent copy could not be told apart
    # from the crossing above, so the step ends with SitlSilent after the wall-clock timeout instead
    with lockstep(kernel, wall_timeout=0.6) as phys:
        peer = FakeSitl(phys.port, drop_answer={5}, resend_after=0.1).start()
        try:
            with pytest.raises(SitlSilent, match=r"6 of 10 frames of this step answered, [3-9] re-sent frames"):
                phys.advance(10 / 1200)
        finally:
            peer.stop()
    assert phys.frames_answered == 6 and peer.answered_counts == list(range(5))


def test_a_restarted_sitl_resets_the_physics(kernel):
    with lockstep(kernel) as phys:
        peer = FakeSitl(phys.port, pwm=lambda c: (2000,) * 4, restart_at=600).start()
        try:
            st = phys.advance(0.5)                # full throttle: off the ground
            assert not st.on_ground and st.position_ned[2] < -0.1
            st = phys.advance(0.1)                # the restart came at frame 600: 120 frames since
            peer.wait_answered(720)
        finally:
            peer.stop()
    assert phys.resets == 1 and phys.frames_answered == 720
    assert phys.time == pytest.approx(0.1)
    assert stamps(peer)[600] == float(seconds(ph.timestamp_ns(1, 1200)))     # the new SITL sees time start again


def test_a_silent_sitl_raises_naming_the_wall_time(kernel):
    with lockstep(kernel, wall_timeout=0.3) as phys:
        t0 = time.monotonic()
        with pytest.raises(SitlSilent, match=r"no new servo frame for 0\.[3-9] s of wall clock"):
            phys.advance(0.01)
        assert 0.29 < time.monotonic() - t0 < 2.0
        assert phys.frames_answered == 0


def test_a_watch_ends_the_wait_for_a_dead_sitl_early(kernel):
    calls = []

    def watch():
        calls.append(time.monotonic())
        return "SITL exited with code -9" if peer.thread.is_alive() is False else None
    with lockstep(kernel, wall_timeout=5.0, watch=watch, watch_interval=0.2) as phys:
        peer = FakeSitl(phys.port, frames=12).start()         # answers 12 frames' worth, then goes away
        t0 = time.monotonic()
        with pytest.raises(SitlSilent, match=r"of wall clock: SITL exited with code -9 \(physics time 0\.0100 s, "
                                             r"12 of 120 frames"):
            phys.advance(0.1)
        # well before the 5 s timeout, with room for a loaded machine (the fake peer's 12 frames take wall time)
        assert time.monotonic() - t0 < 3.5 and len(calls) >= 1
        peer.stop()
    # a watch that sees nothing wrong does not shorten the wall-clock timeout: the silences add up
    with lockstep(kernel, wall_timeout=0.9, watch=lambda: None, watch_interval=0.2) as phys:
        t0 = time.monotonic()
        with pytest.raises(SitlSilent, match=r"for 0\.9 s of wall clock \(physics"):
            phys.advance(0.1)
        assert 0.85 < time.monotonic() - t0 < 2.0


class _Stop(Exception):
    pass


def test_a_signal_interrupts_a_waiting_advance_at_once(kernel):
    # what Ctrl-C does (KeyboardInterrupt would end the pytest session, so SIGUSR1 raising _Stop stands in)
    import threading

    def handler(signum, frame):
        raise _Stop()
    old = signal.signal(signal.SIGUSR1, handler)
    main = threading.main_thread().ident
    timer = threading.Timer(0.2, lambda: signal.pthread_kill(main, signal.SIGUSR1))
    try:
        with lockstep(kernel, wall_timeout=5.0) as phys:
            t0 = time.monotonic()
            timer.start()
            with pytest.raises(_Stop):
                phys.advance(1.0)
            assert time.monotonic() - t0 < 1.0
    finally:
        timer.cancel()
        signal.signal(signal.SIGUSR1, old)


def test_garbage_datagrams_are_ignored(kernel):
    import socket
    with lockstep(kernel) as phys:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.sendto(b"hello", ("127.0.0.1", phys.port))
        s.sendto(b"\x00" * 40, ("127.0.0.1", phys.port))
        s.close()
        peer = FakeSitl(phys.port).start()
        try:
            phys.advance(0.01)
        finally:
            peer.stop()
        assert phys.frames_answered == 12 and phys._s[ph.S_BAD] == 2


def test_python_and_compiled_serve_send_the_same_bytes(tmp_path):
    folder = tmp_path / "lib"
    folder.mkdir()
    if ph.compile_library(folder) is None:
        pytest.skip("no C compiler")
    compiled = ph._try(folder / ph.LIBRARY)

    def pwm(c):            # a deterministic take-off-and-wobble sequence
        return tuple(int(1700 + 150 * math.sin(0.01 * c * (i + 1))) for i in range(4))
    runs = []
    for k in (ph.python(), compiled):
        with lockstep(k) as phys:
            peer = FakeSitl(phys.port, pwm=pwm).start()
            try:
                phys.advance(1.0, wind_ned=(3.0, -1.0, 0.0))
                peer.wait_answered(1200)
            finally:
                peer.stop()
        runs.append(peer.answers[:1200])
    assert runs[0] == runs[1]


# ------------------------------------------------------------------ the real binary
@pytest.fixture(scope="module")
def sitl(tmp_path_factory):
    """One ArduCopter SITL (JSON model) answered by LockstepPhysics, with a pymavlink connection."""
    binary, why = sitl_binary()
    if binary is None:
        print(f"skipping the real-SITL tests: {why}")
        pytest.skip(why)
    from pymavlink import mavutil
    n = free_instance()
    wd = tmp_path_factory.mktemp("sitl")
    phys = LockstepPhysics(instance=n, wall_timeout=10.0)
    parm = binary.parent / "copter.parm"
    ours = wd / "sitlsim.parm"
    ours.write_text(defaults_text(IrisParams()))
    defaults = f"{parm},{ours}" if parm.is_file() else str(ours)
    cmd = [str(binary), "--model", "JSON:127.0.0.1", "-I", str(n), "-w", "--speedup", "1",
           "--home", "-7.2153,-35.9098,550,0", "--defaults", defaults]
    log = open(wd / "sitl.log", "w")
    proc = subprocess.Popen(cmd, cwd=wd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    conn = None
    try:
        deadline = time.monotonic() + 15
        while conn is None:
            try:
                conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{5760 + 10 * n}", source_system=250,
                                                  autoreconnect=False)
            except OSError:
                if proc.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"SITL did not open its MAVLink port: {(wd / 'sitl.log').read_text()[-800:]}")
                time.sleep(0.1)
        yield phys, conn, proc
    finally:
        os.killpg(proc.pid, signal.SIGKILL)      # JSON mode ignores SIGTERM while it waits for physics
        proc.wait(timeout=10)
        if conn is not None:
            conn.close()
        phys.close()
        log.close()
        assert proc.poll() is not None


def drain(conn):
    out = []
    while True:
        m = conn.recv_match(blocking=False)
        if m is None:
            return out
        out.append(m)


def firmware_time_at(phys, conn, token):
    """Send TIMESYNC(tc1=0, ts1=token) and answer single frames until the reply comes: (physics time at the
    request, firmware time in s of the reply)."""
    drain(conn)
    t_req = phys.time
    conn.mav.timesync_send(0, token)
    for _ in range(400):
        phys.advance(1 / 1200)
        for m in drain(conn):
            if m.get_type() == "TIMESYNC" and m.ts1 == token and m.tc1 != 0:
                return t_req, m.tc1 * 1e-9
    raise AssertionError("no TIMESYNC reply within 1/3 s of simulated time")


def test_real_sitl_clock_equals_the_physics_clock(sitl):
    phys, conn, proc = sitl
    offsets = []
    for k, target in enumerate((2.0, 4.0, 6.0, 8.0)):
        phys.advance(target - phys.time)
        assert phys.time == target
        t_req, t_fw = firmware_time_at(phys, conn, 1000 + k)
        offsets.append(t_fw - t_req)
    # the firmware answers within one of its 400 Hz loops of the request (2.5 ms), and its clock does not
    # drift from ours: the offsets agree to within a frame (plain k/1200 timestamps lose 0.8 ms per 2 s)
    assert all(abs(o) < 0.0025 + 1 / 1200 for o in offsets), offsets
    assert max(offsets) - min(offsets) <= 1 / 1200, offsets
    assert proc.poll() is None


def test_real_sitl_rests_level_on_the_ground_while_disarmed(sitl):
    phys, conn, proc = sitl
    from pymavlink import mavutil
    conn.mav.request_data_stream_send(conn.target_system or 1, 0, mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)
    seen = {}
    for _ in range(6):
        st = phys.advance(1.0)
        for m in drain(conn):
            seen[m.get_type()] = m
        assert st.position_ned == (0.0, 0.0, 0.0) and st.velocity_ned == (0.0, 0.0, 0.0)
        assert st.on_ground and st.accel_body == (0.0, 0.0, -9.80665)
        assert st.pwm[:4] == (1000.0,) * 4 or max(st.pwm[:4]) <= 1000.0     # disarmed: motors stopped
        assert st.power_w == 5.0                                             # avionics only
    att = seen["ATTITUDE"]
    assert abs(att.roll) < 0.01 and abs(att.pitch) < 0.01        # SITL's own attitude estimate: level
    hb = seen["HEARTBEAT"]
    assert not hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert phys.resets == 0
    # the firmware took our defaults file: it mixes for the quad X this physics is
    values = {}
    for name in ("FRAME_TYPE", "MOT_THST_HOVER"):
        conn.mav.param_request_read_send(conn.target_system or 1, 1, name.encode(), -1)
    for _ in range(20):
        phys.advance(0.05)
        for m in drain(conn):
            if m.get_type() == "PARAM_VALUE":
                values[m.param_id] = m.param_value
        if len(values) == 2:
            break
    assert values["FRAME_TYPE"] == 1 and values["MOT_THST_HOVER"] == pytest.approx(0.5204, abs=1e-6)
