"""Helpers of the lock-step physics tests: the SITL binary, free instance numbers, a fake SITL peer."""
from __future__ import annotations

import json
import os
import random
import socket
import threading
import time
from pathlib import Path

from sitlsim.frames import encode_servo

REPO = Path(__file__).resolve().parents[1]


def sitl_binary() -> tuple[Path | None, str]:
    """(path, why-not): $ARDUPILOT_SITL, else ../shared/sitl/arducopter from the project root."""
    env = os.environ.get("ARDUPILOT_SITL")
    path = Path(env) if env else REPO.parent / "shared" / "sitl" / "arducopter"
    src = "ARDUPILOT_SITL" if env else "../shared/sitl/arducopter"
    if not path.is_file():
        return None, f"no ArduPilot SITL binary: {src} = {path} does not exist"
    if not os.access(path, os.X_OK):
        return None, f"ArduPilot SITL binary {path} is not executable"
    return path, ""


def _free(kind, port) -> bool:
    s = socket.socket(socket.AF_INET, kind)
    try:
        s.bind(("127.0.0.1", port))
        return True
    except OSError:
        return False
    finally:
        s.close()


def free_instance(lo: int = 40, hi: int = 200) -> int:
    """A SITL instance number N whose ports (TCP 5760/5762/5763+10N, UDP 9002/9003+10N) are free now;
    drawn at random so parallel test workers and other runs on the machine rarely meet."""
    rng = random.Random()
    for _ in range(200):
        n = rng.randrange(lo, hi)
        if all(_free(socket.SOCK_STREAM, 5760 + 10 * n + d) for d in (0, 2, 3)) and \
                all(_free(socket.SOCK_DGRAM, 9002 + 10 * n + d) for d in (0, 1)):
            return n
    raise RuntimeError("no free SITL instance number found")


def thrust_pwm(thrust: float, p) -> float:
    """PWM for a motor thrust, by hand from the documented curve (docs/sitl_physics.md): thrust fraction
    f = T / (k_f w_max^2) = (1-e) x + e x^2 solved for x, actuator a = spin_min + (spin_max-spin_min) x,
    pwm = pwm_min + (pwm_max - pwm_min) a."""
    f = thrust / (p.motor_constant * p.max_rot_velocity ** 2)
    e = p.thrust_expo
    x = (-(1 - e) + ((1 - e) ** 2 + 4 * e * f) ** 0.5) / (2 * e)
    return p.pwm_min + (p.pwm_max - p.pwm_min) * (p.spin_min + (p.spin_max - p.spin_min) * x)


class FakeSitl:
    """A UDP peer that behaves like SITL's JSON backend: it sends servo frame c, waits for an answer
    (re-sending the same frame after ``resend_after`` s of silence), parses it and sends c + 1.

    duplicate: send every frame twice (a re-send that crosses our answer).
    drop_answer: frame counts whose first answer is thrown away (as if lost).
    restart_at: after answering this many frames, start over at frame_count 0 (a restarted SITL).
    pause_after: {frame_count: s} to wait after that frame's answer before sending the next (a busy SITL).
    """

    def __init__(self, port: int, pwm=lambda c: (1000,) * 4, frames: int = 10 ** 9, duplicate=False,
                 drop_answer=(), restart_at=None, resend_after=0.5, pause_after=None):
        self.port, self.pwm, self.frames = port, pwm, frames
        self.duplicate, self.drop = duplicate, set(drop_answer)
        self.restart_at, self.resend_after = restart_at, resend_after
        self.pause_after = dict(pause_after or {})
        self.answers: list[bytes] = []      # every datagram received, in order
        self.answered_counts: list[int] = []
        self.sent = 0
        self._stop = threading.Event()
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.02)        # short, so stop() is quick; re-sends follow resend_after
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self):
        self.thread.start()
        return self

    def _send(self, count):
        pwm = tuple(self.pwm(count)) + (0,) * 12
        self.sock.sendto(encode_servo(1200, count, pwm), ("127.0.0.1", self.port))
        self.sent += 1
        self._last_send = time.monotonic()

    def wait_answered(self, n: int, timeout: float = 5.0):
        """Block until n frames have been answered (the answer to the last one may still be in flight
        when advance() returns)."""
        deadline = time.monotonic() + timeout
        while len(self.answered_counts) < n and time.monotonic() < deadline:
            time.sleep(0.001)
        return self

    def _run(self):
        count, done, restarted = 0, 0, False
        while not self._stop.is_set() and done < self.frames:
            self._send(count)
            if self.duplicate:
                self._send(count)
            while not self._stop.is_set():
                try:
                    data = self.sock.recv(4096)
                except socket.timeout:
                    if time.monotonic() - self._last_send >= self.resend_after:
                        self._send(count)       # SITL re-sends the same frame while it waits
                    continue
                except OSError:
                    return
                self.answers.append(data)
                if count in self.drop:
                    self.drop.discard(count)    # this answer is "lost": wait and re-send
                    continue
                json.loads(data)                # a complete JSON object, or the test fails here
                self.answered_counts.append(count)
                break
            if count in self.pause_after:
                self._stop.wait(self.pause_after[count])
            done += 1
            count += 1
            if self.restart_at is not None and not restarted and done == self.restart_at:
                count, restarted = 0, True

    def stop(self):
        self._stop.set()
        self.thread.join(timeout=5)
        self.sock.close()
