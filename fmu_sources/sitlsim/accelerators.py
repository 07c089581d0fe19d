"""The accelerators of sitlsim, each declared with the Python reference it replaces (master/accel.py's Protocol,
satisfied structurally: this module does not import ``master``, it is bundled into the UavSitl FMU).

- ``sitlsim.physics-step``: physics.c's ``sitl_step`` and ``sitl_format`` (reference: physics.step_py and
  physics.format_py): random flights about hover and tumbling ones, hitting and resting on the ground, wind,
  answers printed with odd numbers (NaN, infinities, tiny and huge values, signed zeros);
- ``sitlsim.physics-serve``: physics.c's ``sitl_serve``, the lock-step answering loop (physics.serve_py), fed
  servo frames through a local UDP socket: 16 and 32 channel frames, re-sent and malformed ones, a restarted
  SITL (frame counts going back), fewer frames than asked for (silent).

``reference`` and ``accelerated`` return the whole state after each frame (or serve call), the answers' bytes and
the serve loop's results (its wall-clock timings excepted).
"""
from __future__ import annotations

import math
import socket

from . import physics as ph
from .frames import encode_servo
from .iris import IrisParams

RATE = 1200


def _params(rng):
    prm = IrisParams(frame=rng.choice(["x", "+"])) if rng.random() < 0.3 else IrisParams()
    return prm, ph.kernel_params(prm, rng.choice([RATE, 400, 1000]), rng.uniform(-math.pi, math.pi))


def _start(rng, prm, p) -> list:
    s = ph.initial_state(p)
    if rng.random() < 0.7:                       # airborne, rotors spinning
        s[ph.S_PD], s[ph.S_GROUND] = -rng.uniform(0.05, 60.0), 0.0
        for i in range(4):
            s[ph.S_M1 + i] = rng.uniform(0.0, prm.max_rot_velocity)
        s[ph.S_VN], s[ph.S_VE], s[ph.S_VD] = (rng.uniform(-8, 8) for _ in range(3))
        s[ph.S_RP], s[ph.S_RQ], s[ph.S_RR] = (rng.uniform(-2, 2) for _ in range(3))
    return s


def _pwm(rng, prm, spread: float) -> list:
    hover = prm.hover_pwm
    return [min(2000.0, max(900.0, hover + rng.uniform(-spread, spread))) for _ in range(4)]


class PhysicsStep:
    """physics.c's frame step and answer formatting."""
    name = "sitlsim.physics-step"
    replaces = "sitlsim.physics:step_py"

    def load(self):
        k, why = ph.built()
        return (None, why) if k is None else (k, None)

    def cases(self, rng):
        for _ in range(12):
            prm, p = _params(rng)
            s = _start(rng, prm, p)
            spread = rng.choice([80.0, 600.0, 1100.0])
            frames = []
            for k in range(rng.choice([50, 200, 400])):
                wind = [rng.uniform(-12, 12), rng.uniform(-12, 12), rng.uniform(-2, 2)] if k % 100 == 0 else None
                frames.append((_pwm(rng, prm, spread), wind, rng.random() < 0.1))
            yield "fly", p, s, frames
        odd = [math.nan, math.inf, -math.inf, 2.5e-9, -3.5e-9, 0.5e-9, 1e12, -1e10, -0.0, 5e-324]
        prm, p = _params(rng)
        for trial in range(60):                    # answers with odd numbers in every printed slot
            s = ph.initial_state(p)
            s[ph.S_K] = float(rng.randrange(0, 10 ** 9))
            for i in range(ph.S_PN, ph.S_FZ + 1):
                s[i] = rng.choice(odd) if trial % 3 == 0 else rng.uniform(-1, 1) * 10 ** rng.randint(-12, 8)
            yield "format", p, s, rng.random() < 0.5

    def reference(self, case):
        return self._run(case, ph.step_py, ph.format_py)

    def accelerated(self, impl, case):
        return self._run(case, impl.step, impl.format)

    @staticmethod
    def _run(case, step, fmt):
        kind, p, s = case[0], case[1], list(case[2])
        if kind == "format":
            return fmt(s, p, case[3]), [float(v) for v in s]
        seen = []
        for pwm, wind, answer in case[3]:
            s[ph.S_PWM1:ph.S_PWM4 + 1] = pwm
            if wind is not None:
                s[ph.S_WN:ph.S_WD + 1] = wind
            step(s, p)
            seen.append([float(v) for v in s])
            if answer:
                seen.append(fmt(s, p, True))
        return seen


class _Peer:
    """A SITL stand-in on a local UDP socket pair: sends servo frames, collects the answers."""

    def __init__(self):
        self.physics = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.physics.bind(("127.0.0.1", 0))
        self.sitl = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sitl.bind(("127.0.0.1", 0))

    def send(self, packets):
        for data in packets:
            self.sitl.sendto(data, self.physics.getsockname())

    def answers(self) -> list:
        out = []
        self.sitl.setblocking(False)
        try:
            while True:
                out.append(self.sitl.recv(4096))
        except BlockingIOError:
            pass
        self.sitl.setblocking(True)
        return out

    def close(self):
        self.physics.close()
        self.sitl.close()


_TIMINGS = (ph.IO_WAITED, ph.IO_T_WAIT, ph.IO_T_PHYS, ph.IO_T_IO)


class PhysicsServe:
    """physics.c's lock-step answering loop on a real (local) socket."""
    name = "sitlsim.physics-serve"
    replaces = "sitlsim.physics:serve_py"

    def load(self):
        k, why = ph.built()
        return (None, why) if k is None else (k, None)

    def cases(self, rng):
        for _ in range(8):
            prm, p = _params(rng)
            rate = int(p[ph.P_RATE])
            calls, count = [], rng.randrange(0, 1000)
            for _ in range(rng.choice([1, 3, 6])):
                packets, new = [], 0
                for _ in range(rng.randrange(1, 40)):
                    r = rng.random()
                    pwm = [int(v) for v in _pwm(rng, prm, 600.0)]
                    channels = rng.choice([16, 16, 32])
                    if r < 0.05:
                        packets.append(b"\x00" * rng.randrange(0, 12))            # too short or malformed
                        continue
                    if r < 0.1 and count > 0:
                        packets.append(encode_servo(rate, count, pwm + [1500] * (channels - 4)))   # re-sent
                        continue
                    if r < 0.12:
                        count = rng.randrange(0, max(1, count))                   # SITL restarted
                    else:
                        count += 1
                    packets.append(encode_servo(rate, count, pwm + [1500] * (channels - 4)))
                    new += 1
                silent = rng.random() < 0.15
                calls.append((packets, new + (2 if silent else 0), rng.random() < 0.5))
            yield p, ph.initial_state(p), calls

    def reference(self, case):
        return self._run(case, lambda sock, p: (lambda s, io: ph.serve_py(sock, s, p, io)))

    def accelerated(self, impl, case):
        return self._run(case, impl.bind_serve)

    @staticmethod
    def _run(case, bind):
        p, s, calls = case[0], list(case[1]), case[2]
        peer = _Peer()
        seen = []
        try:
            serve = bind(peer.physics, p)
            for packets, nframes, nts in calls:
                peer.send(packets)
                io = [0.0] * ph.N_IO
                io[ph.IO_NFRAMES], io[ph.IO_TIMEOUT], io[ph.IO_NO_TIME_SYNC] = float(nframes), 0.02, float(nts)
                n = serve(s, io)
                for i in _TIMINGS:
                    io[i] = 0.0                # wall-clock measurements, not results
                seen.append((n, [float(v) for v in s], [float(v) for v in io], peer.answers()))
        finally:
            peer.close()
        return seen


PHYSICS_STEP = PhysicsStep()
PHYSICS_SERVE = PhysicsServe()
