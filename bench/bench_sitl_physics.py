"""Speed of the SITL lock-step physics (sitlsim): the kernel alone, and ArduCopter SITL answered by it.

Usage::

    python bench/bench_sitl_physics.py                 # kernel + 1 SITL (disarmed, hovering) + 4 SITL disarmed
    python bench/bench_sitl_physics.py --no-sitl       # the kernel only
    python bench/bench_sitl_physics.py --fleet 0       # skip the 4-SITL row

Kernel rows: frames per second of one physics step (``step``) and of a step plus its JSON answer
(``step+answer``), for the Python twin and the compiled twin called through ctypes one frame per call
(persistent argument arrays; what a per-frame Python loop would cost).  The compiled answering loop
(``sitl_serve``) is measured in the SITL rows.  The CPU table (SITL's from /proc, ours per thread) does not
depend on what else runs on the machine, the wall-clock table does.

SITL rows (the binary from $ARDUPILOT_SITL, else ../shared/sitl/arducopter; copter.parm plus
sitlsim.iris.defaults_text(): quad X, our thrust curve and hover thrust, SITL's IMU noise off):
one instance answered by LockstepPhysics with ``no_time_sync``, advanced in 0.25 s steps with its MAVLink
stream (REQUEST_DATA_STREAM all at 4 Hz) read after each step, as the SITL vehicle FMU does.
Windows: ``disarmed`` = simulated 5-40 s (EKF initialising, on the ground); ``hover`` = 20 s hovering at
10 m after a GUIDED takeoff.  Real-time factor = simulated s / wall s of the window.  The split of the
window's wall time: ``firmware`` = time our loop is blocked in recvfrom() for SITL's next frame (the
firmware's main loop, the OS scheduling both processes, the receive), ``physics`` = step + JSON formatting,
``socket`` = sendto, ``python`` = the rest (advance() and the MAVLink reads between steps).  The 4-SITL row
advances four instances in four Python threads (the compiled loop releases the GIL), disarmed, 5-30 s.
"""
from __future__ import annotations

import argparse
import ctypes
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "fmu_sources"))

from sitlsim import physics as ph          # noqa: E402
from sitlsim.iris import IrisParams, defaults_text   # noqa: E402
from sitlsim.lockstep import LockstepPhysics   # noqa: E402


def kernel_rows(frames: int):
    p = ph.kernel_params(IrisParams(), 1200)
    rows = []
    s = ph.initial_state(p)
    s[ph.S_PD], s[ph.S_GROUND] = -50.0, 0.0
    s[ph.S_PWM1:ph.S_PWM4 + 1] = [IrisParams().hover_pwm] * 4
    for name, fn in (("step", lambda: ph.step_py(s, p)),
                     ("step+answer", lambda: (ph.step_py(s, p), ph.format_py(s, p)))):
        n = frames // 10
        t = time.perf_counter()
        for _ in range(n):
            fn()
        rows.append(("python", name, n / (time.perf_counter() - t)))
    k = ph.load()
    if k.compiled:
        lib = k._lib
        cs, cp = (ctypes.c_double * ph.N_STATE)(*s), (ctypes.c_double * ph.N_PARAM)(*p)
        buf = ctypes.create_string_buffer(1024)
        step, fmt = lib.sitl_step, lib.sitl_format
        one, cap = ctypes.c_int(1), ctypes.c_int(1024)
        for name, fn in (("step", lambda: step(cs, cp)),
                         ("step+answer", lambda: (step(cs, cp), fmt(cs, cp, one, buf, cap)))):
            t = time.perf_counter()
            for _ in range(frames):
                fn()
            rows.append(("compiled (ctypes per frame)", name, frames / (time.perf_counter() - t)))
    else:
        rows.append(("compiled", "-", "no C compiler"))
    return rows


def sitl_binary():
    env = os.environ.get("ARDUPILOT_SITL")
    path = Path(env) if env else REPO.parent / "shared" / "sitl" / "arducopter"
    return path if path.is_file() else None


class Sitl:
    """One SITL process with its LockstepPhysics and MAVLink connection."""

    def __init__(self, binary: Path, n: int, folder: Path, kernel=None, rate: int = 1200, extra: str = ""):
        from pymavlink import mavutil
        self.mavutil = mavutil
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "frame.parm").write_text(defaults_text(IrisParams()) + extra)
        defaults = f"{binary.parent / 'copter.parm'},{folder / 'frame.parm'}"
        self.phys = LockstepPhysics(instance=n, kernel=kernel, frame_rate=rate)
        self.log = open(folder / "sitl.log", "w")
        self.proc = subprocess.Popen([str(binary), "--model", "JSON:127.0.0.1", "-I", str(n), "-w",
                                      "--rate", str(rate), "--speedup", "1", "--defaults", defaults,
                                      "--home", "-7.2153,-35.9098,550,0"], cwd=folder, stdout=self.log,
                                     stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 20
        while True:
            try:
                self.conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{5760 + 10 * n}", source_system=250,
                                                       autoreconnect=False)
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)
        self.msgs = {}
        self.streaming = False

    def step(self, h=0.25):
        st = self.phys.advance(h)
        while True:
            m = self.conn.recv_match(blocking=False)
            if m is None:
                break
            self.msgs[m.get_type()] = m
        if not self.streaming:
            self.conn.mav.request_data_stream_send(1, 0, self.mavutil.mavlink.MAV_DATA_STREAM_ALL, 4, 1)
            self.streaming = True
        return st

    def until(self, t):
        while self.phys.time < t - 1e-9:
            self.step(min(0.25, t - self.phys.time))

    def cpu(self):
        """CPU seconds (user + system) the SITL process has used."""
        fields = Path(f"/proc/{self.proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def window(self, seconds, action=None):
        """(real-time factor, shares, CPU s per simulated s of SITL, of this thread) of ``seconds``."""
        t0, w0, tm0 = self.phys.time, time.perf_counter(), dict(self.phys.timing)
        c0, m0 = self.cpu(), time.thread_time()
        while self.phys.time < t0 + seconds - 1e-9:
            self.step()
            if action:
                action()
        wall = time.perf_counter() - w0
        sim = self.phys.time - t0
        cpu_fw, cpu_us = (self.cpu() - c0) / sim, (time.thread_time() - m0) / sim
        d = {k: self.phys.timing[k] - tm0[k] for k in tm0}
        shares = {"firmware": d["wait"] / wall, "physics": d["physics"] / wall, "socket": d["io"] / wall}
        shares["python"] = 1 - sum(shares.values())
        return sim / wall, shares, cpu_fw, cpu_us

    def arm_and_takeoff(self, alt=10.0):
        mav = self.mavutil.mavlink
        deadline = self.phys.time + 60
        while self.phys.time < deadline:
            hb = self.msgs.get("HEARTBEAT")
            if hb and hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED:
                self.conn.mav.command_long_send(1, 1, mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, alt)
                self.until(self.phys.time + 15)
                return
            self.conn.set_mode("GUIDED")
            self.conn.mav.command_long_send(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
            self.until(self.phys.time + 1)
        raise RuntimeError("SITL did not arm within 60 s")

    def close(self):
        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self.proc.wait()
        self.conn.close()
        self.phys.close()
        self.log.close()


def sitl_rows(binary, tmp: Path, fleet: int, python_twin: bool, rate: int):
    rows = []
    kernels = [("compiled", None)] + ([("python", ph.python())] if python_twin else [])
    for kname, kernel in kernels:
        if rate != 1200:
            kname += f", {rate} Hz"
        v = Sitl(binary, 61, tmp / f"one_{kname.replace(', ', '_').replace(' ', '')}", kernel, rate)
        try:
            v.until(5.0)
            rows.append((f"1 SITL, {kname}", "disarmed 5-40 s", *v.window(35.0)))
            if kname.startswith("compiled"):
                v.until(43.0)
                v.arm_and_takeoff()
                rows.append((f"1 SITL, {kname}", "hover at 10 m, 20 s", *v.window(20.0)))
                st = v.phys.state
                print(f"  (hovering: altitude {-st.position_ned[2]:.2f} m, pwm {st.pwm}, {st.power_w:.1f} W)")
        finally:
            v.close()
    if fleet:
        vs = [Sitl(binary, 71 + i, tmp / f"fleet{i}", rate=rate) for i in range(fleet)]
        try:
            for v in vs:
                v.until(5.0)
            results = [None] * fleet
            w0 = time.perf_counter()

            def run(i):
                results[i] = vs[i].window(25.0)
            threads = [threading.Thread(target=run, args=(i,)) for i in range(fleet)]
            for t in threads:
                t.start()
            for t in threads:
                t.join()
            wall = time.perf_counter() - w0
            shares = {k: sum(r[1][k] for r in results) / fleet for k in results[0][1]}
            rows.append((f"{fleet} SITL in threads" + (f", {rate} Hz" if rate != 1200 else ""), "disarmed 5-30 s, each", 25.0 / wall, shares,
                         sum(r[2] for r in results) / fleet, sum(r[3] for r in results) / fleet))
        finally:
            for v in vs:
                v.close()
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=200_000, help="kernel frames per compiled measurement")
    ap.add_argument("--no-sitl", action="store_true")
    ap.add_argument("--fleet", type=int, default=4, help="SITL instances of the fleet row (0: none)")
    ap.add_argument("--python-twin", action="store_true", help="also a 1-SITL row with the Python twin")
    ap.add_argument("--rate", type=int, default=1200, help="SITL physics frame rate (--rate; copter 1200 Hz)")
    a = ap.parse_args(argv)
    print(f"load average {os.getloadavg()}, {os.cpu_count()} cores\n")
    print("| kernel | what | frames/s |\n| --- | --- | ---: |")
    for twin, what, fps in kernel_rows(a.frames):
        print(f"| {twin} | {what} | {fps if isinstance(fps, str) else f'{fps:,.0f}'} |")
    if a.no_sitl:
        return 0
    binary = sitl_binary()
    if binary is None:
        print("\nno SITL binary ($ARDUPILOT_SITL or ../shared/sitl/arducopter): SITL rows skipped")
        return 0
    tmp = Path(tempfile.mkdtemp(prefix="bench_sitl_"))
    try:
        rows = sitl_rows(binary, tmp, a.fleet, a.python_twin, a.rate)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print("\nWall clock (depends on the machine's load; shares of the window's wall time):\n")
    print("| run | window | real-time factor | frames/s | firmware | physics | socket | python |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for run, window, rtf, sh, *_ in rows:
        print(f"| {run} | {window} | {rtf:.1f}x | {rtf * a.rate:,.0f} | {sh['firmware']:.0%} | {sh['physics']:.0%} "
              f"| {sh['socket']:.0%} | {sh['python']:.0%} |")
    print("\nCPU time per simulated second (independent of other load; 'bound' = 1 / (SITL + ours), the\n"
          "real-time factor of one vehicle on an idle core; 'fleet bound' = cores / (4 x that sum)):\n")
    print("| run | window | SITL CPU ms/s | our CPU ms/s | bound | 4 UAVs on this machine, bound |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    cores = os.cpu_count() or 1
    for run, window, rtf, sh, cfw, cus in rows:
        print(f"| {run} | {window} | {cfw * 1e3:.0f} | {cus * 1e3:.0f} | {1 / (cfw + cus):.0f}x "
              f"| {cores / (4 * (cfw + cus)):.1f}x |")
    print(f"\nload average after: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
