"""The quadcopter's physics step and the frame-answering loop as plain Python (the reference: what
docs/sitl_physics.md explains and a reader follows) and their accelerator, physics.c (compiled, loaded with ctypes).

One call of :func:`step_py` advances the state by one SITL frame (1/frame_rate s) with the PWM and wind held in
the state; :func:`serve_py` is the lock-step loop (receive a servo frame, step, answer) that LockstepPhysics runs
for a whole communication step.  physics.c uses only + - * / sqrt and comparisons, in the same order, on the
same slot layout (below), and formats the answer with the same printf conversions, so it gives bit-identical
states and byte-identical answers (declared in sitlsim/accelerators.py, checked by the project's harness):
whether the compiler was there changes the speed, never a result.  The compiled ``serve`` also runs without the
GIL (ctypes.CDLL), so several vehicles can answer their frames in parallel threads.

The library is built by the project's one build path, ``master.native_build``: inside an FMU by
fmu_sources/build_fmus.py, which bundles it next to this file; outside an FMU (tests, benchmarks) on first use
into the per-user cache (a guarded import: sitlsim bundled into an FMU never needs ``master``).
``COSIM_MASTER_PURE_PYTHON=1`` forces the Python code.
"""
from __future__ import annotations

import ctypes
import os
import select
import shutil
import socket
import struct
import time
from math import sqrt
from pathlib import Path

from .frames import MAGIC_16, MAGIC_32, SIZE_16, SIZE_32, answer

LIBRARY = "_sitlsim_physics.so"
#: the one variable that switches every accelerator off (master/accel.py ENV; read here without importing master)
ENV = "COSIM_MASTER_PURE_PYTHON"
SOURCE = Path(__file__).resolve().parent / "physics.c"
#: -ffp-contract=off: no fused multiply-add, so the compiled twin rounds exactly as the Python one
FLAGS = ["-O2", "-fPIC", "-shared", "-ffp-contract=off", "-fno-fast-math", "-std=c99"]

# ---- state slots (physics.c: the first enum)
(S_K, S_PN, S_PE, S_PD, S_VN, S_VE, S_VD, S_QW, S_QX, S_QY, S_QZ, S_RP, S_RQ, S_RR, S_FX, S_FY, S_FZ,
 S_M1, S_M2, S_M3, S_M4, S_PWM1, S_PWM2, S_PWM3, S_PWM4, S_WN, S_WE, S_WD, S_POWER, S_ENERGY, S_GROUND,
 S_LAST, S_HAS_LAST, S_ANSWERED, S_RESETS, S_STALE, S_BAD, S_SITL_RATE) = range(38)
N_STATE = 38
# ---- parameter slots
(P_DT, P_G, P_MASS, P_IXX, P_IYY, P_IZZ, P_KF, P_WMAX, P_KM, P_AUP, P_ADN, P_RDRAG, P_BDRAG, P_EXPO,
 P_SPIN_MIN, P_SPIN_RANGE, P_PWM_MIN, P_PWM_RANGE, P_PIND, P_PPROF, P_EFF_INV, P_AVIONICS, P_RATE,
 P_Q0W, P_Q0Z, P_MX1) = range(26)     # P_MX1..: x, y, yaw sign of motor 1, then of 2, 3, 4
N_PARAM = P_MX1 + 12
# ---- serve in/out slots
(IO_NFRAMES, IO_TIMEOUT, IO_NO_TIME_SYNC, IO_STATUS, IO_WAITED, IO_T_WAIT, IO_T_PHYS, IO_T_IO,
 IO_ERRNO) = range(9)
N_IO = 9
OK, SILENT, SOCKET_ERROR, INTERRUPTED = 0, 1, 2, 3



def kernel_params(params, frame_rate: int, yaw0: float = 0.0) -> tuple:
    """The flat parameter tuple both twins read, from an IrisParams, the frame rate and the initial yaw
    (rad; the vehicle starts level, on the ground at the origin)."""
    import math
    if int(frame_rate) != frame_rate or frame_rate <= 0:
        raise ValueError(f"frame_rate must be a positive integer, not {frame_rate!r}")
    dt = 1.0 / frame_rate
    disc = math.pi * params.rotor_radius ** 2
    w_h = params.hover_omega
    out = [dt, params.gravity, params.mass, *params.inertia, params.motor_constant, params.max_rot_velocity,
           params.moment_constant, 1.0 - math.exp(-dt / params.time_constant_up),
           1.0 - math.exp(-dt / params.time_constant_down), params.rotor_drag,
           0.5 * params.rho * params.flat_plate_area, params.thrust_expo, params.spin_min,
           params.spin_max - params.spin_min, params.pwm_min, params.pwm_max - params.pwm_min,
           (1.0 + params.induced_correction) / math.sqrt(2.0 * params.rho * disc),
           params.profile_power / 4.0 / (w_h * w_h * w_h), 1.0 / params.efficiency, params.avionics_power,
           float(frame_rate), math.cos(0.5 * yaw0), math.sin(0.5 * yaw0)]
    for (x, y), sign in params.motors:
        out += [x, y, float(sign)]
    assert len(out) == N_PARAM
    return tuple(float(v) for v in out)


def initial_state(p) -> list:
    s = [0.0] * N_STATE
    reset_py(s, p)
    return s


def reset_py(s: list, p) -> None:
    """Back to rest on the ground at the origin, time 0 (a SITL restart); energy and counters are kept."""
    for i in range(S_PN, S_WN):
        s[i] = 0.0
    s[S_K] = 0.0
    s[S_QW], s[S_QZ] = p[P_Q0W], p[P_Q0Z]
    s[S_FZ] = -p[P_G]
    s[S_GROUND] = 1.0
    s[S_POWER] = p[P_AVIONICS]


def timestamp_ns(k: int, rate: int) -> int:
    """The JSON timestamp of frame k, in integer nanoseconds.  SITL adds each timestamp difference to its
    integer microsecond clock with truncation (time_now_us += dt * 1e6), so 1/1200 s would count as 833 us
    and its clock would lose 0.4 ms per second.  The timestamp is instead floor(k 1e6 / rate) us plus k ns:
    every difference is a whole number of microseconds plus 1 ns, which truncates to exactly that whole
    number (the decimal-to-double rounding of SITL's atof is below 1e-5 us up to 1e5 s), so the firmware's
    clock reads floor(physics time in us).  The timestamp runs ahead of the physics time by k ns (1.2 us/s)."""
    return (k * 1000000) // rate * 1000 + k


def format_py(s, p, no_time_sync: bool = True) -> bytes:
    k = int(s[S_K])
    return answer(timestamp_ns(k, int(p[P_RATE])), s[S_RP:S_RR + 1], s[S_FX:S_FZ + 1], s[S_PN:S_PD + 1],
                  s[S_VN:S_VD + 1], s[S_QW:S_QZ + 1], no_time_sync)


def step_py(s: list, p) -> None:
    """One frame: rotor lag, forces and torques, rigid body, ground contact, power (docs/sitl_physics.md)."""
    dt, g, mass = p[P_DT], p[P_G], p[P_MASS]
    kf, wmax, km, aup, adn = p[P_KF], p[P_WMAX], p[P_KM], p[P_AUP], p[P_ADN]
    e, smin, srange, pmin, prange = p[P_EXPO], p[P_SPIN_MIN], p[P_SPIN_RANGE], p[P_PWM_MIN], p[P_PWM_RANGE]
    pind, pprof = p[P_PIND], p[P_PPROF]
    tsum = wsum = tx = ty = tz = pw = 0.0
    for i in range(4):
        x = ((s[S_PWM1 + i] - pmin) / prange - smin) / srange
        if x < 0.0:
            x = 0.0
        elif x > 1.0:
            x = 1.0
        wc = wmax * sqrt((1.0 - e) * x + e * x * x)
        w = s[S_M1 + i]
        if wc > w:
            w = w + aup * (wc - w)
        else:
            w = w + adn * (wc - w)
        s[S_M1 + i] = w
        t = kf * w * w
        j = P_MX1 + 3 * i
        tsum += t
        wsum += w
        tx -= p[j + 1] * t
        ty += p[j] * t
        tz += p[j + 2] * km * t
        pw += pind * t * sqrt(t) + pprof * w * w * w
    qw, qx, qy, qz = s[S_QW], s[S_QX], s[S_QY], s[S_QZ]
    r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
    r01 = 2.0 * (qx * qy - qw * qz)
    r02 = 2.0 * (qx * qz + qw * qy)
    r10 = 2.0 * (qx * qy + qw * qz)
    r11 = 1.0 - 2.0 * (qx * qx + qz * qz)
    r12 = 2.0 * (qy * qz - qw * qx)
    r20 = 2.0 * (qx * qz - qw * qy)
    r21 = 2.0 * (qy * qz + qw * qx)
    r22 = 1.0 - 2.0 * (qx * qx + qy * qy)
    an, ae, ad = s[S_VN] - s[S_WN], s[S_VE] - s[S_WE], s[S_VD] - s[S_WD]
    bx = r00 * an + r10 * ae + r20 * ad
    by = r01 * an + r11 * ae + r21 * ad
    bz = r02 * an + r12 * ae + r22 * ad
    va = sqrt(an * an + ae * ae + ad * ad)
    bd = p[P_BDRAG] * va
    rd = p[P_RDRAG] * wsum
    fx = (-rd * bx - bd * bx) / mass
    fy = (-rd * by - bd * by) / mass
    fz = (-tsum - bd * bz) / mass
    ixx, iyy, izz = p[P_IXX], p[P_IYY], p[P_IZZ]
    rp, rq, rr = s[S_RP], s[S_RQ], s[S_RR]
    rp2 = rp + (tx - (rq * izz * rr - rr * iyy * rq)) / ixx * dt
    rq2 = rq + (ty - (rr * ixx * rp - rp * izz * rr)) / iyy * dt
    rr2 = rr + (tz - (rp * iyy * rq - rq * ixx * rp)) / izz * dt
    h = 0.5 * dt
    nw = qw + (-qx * rp2 - qy * rq2 - qz * rr2) * h
    nx = qx + (qw * rp2 + qy * rr2 - qz * rq2) * h
    ny = qy + (qw * rq2 - qx * rr2 + qz * rp2) * h
    nz = qz + (qw * rr2 + qx * rq2 - qy * rp2) * h
    n = sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
    vn = s[S_VN] + (r00 * fx + r01 * fy + r02 * fz) * dt
    ve = s[S_VE] + (r10 * fx + r11 * fy + r12 * fz) * dt
    vd = s[S_VD] + (r20 * fx + r21 * fy + r22 * fz + g) * dt
    pn, pe, pd = s[S_PN] + vn * dt, s[S_PE] + ve * dt, s[S_PD] + vd * dt
    climb = -vd * mass * g
    if climb < 0.0:
        climb = 0.0
    power = (pw + bd * va * va + climb) * p[P_EFF_INV] + p[P_AVIONICS]
    if pd >= 0.0:
        # resting on the ground: no sinking, no bounce, held level and still by the landing gear
        pd = vn = ve = vd = rp2 = rq2 = rr2 = 0.0
        nw, nz = qw, qz                  # the heading of the frame's start, not turned by this frame's torque
        n = sqrt(nw * nw + nz * nz)
        nx = ny = 0.0
        fx = fy = 0.0
        fz = -g
        s[S_GROUND] = 1.0
    else:
        s[S_GROUND] = 0.0
    s[S_PN], s[S_PE], s[S_PD], s[S_VN], s[S_VE], s[S_VD] = pn, pe, pd, vn, ve, vd
    s[S_QW], s[S_QX], s[S_QY], s[S_QZ] = nw / n, nx / n, ny / n, nz / n
    s[S_RP], s[S_RQ], s[S_RR], s[S_FX], s[S_FY], s[S_FZ] = rp2, rq2, rr2, fx, fy, fz
    s[S_POWER] = power
    s[S_ENERGY] += power * dt
    s[S_K] += 1.0


_PKT = struct.Struct("<HHI4H")


def serve_py(sock: socket.socket, s: list, p, io: list) -> int:
    """Answer io[IO_NFRAMES] new servo frames on ``sock`` (see physics.c: sitl_serve, the same loop; a
    re-sent frame is counted and never answered twice)."""
    nframes, timeout = int(io[IO_NFRAMES]), io[IO_TIMEOUT]
    nts = io[IO_NO_TIME_SYNC] != 0.0
    clock = time.perf_counter
    answered = 0
    last_new = clock()
    t_wait = t_phys = t_io = 0.0
    status = OK
    fd = sock.fileno()
    while answered < nframes:
        now = clock()
        left = timeout - (now - last_new)
        t1 = clock()
        ready = select.select([fd], [], [], max(0.0, left))[0]
        t2 = clock()
        t_wait += t2 - t1
        if not ready:
            now = clock()
            if now - last_new >= timeout:
                status = SILENT
                io[IO_WAITED] = now - last_new
                break
            continue
        try:
            data, addr = sock.recvfrom(4096)
        except ConnectionRefusedError:       # an ICMP error of an earlier sendto (SITL gone): keep waiting
            continue
        except OSError as exc:
            status = SOCKET_ERROR
            io[IO_ERRNO] = exc.errno or 0
            break
        t3 = clock()
        t_io += t3 - t2
        n = len(data)
        if n < 8:
            s[S_BAD] += 1
            continue
        magic, rate, count, m1, m2, m3, m4 = _PKT.unpack_from(data) if n >= _PKT.size else (0,) * 7
        if not ((magic == MAGIC_16 and n == SIZE_16) or (magic == MAGIC_32 and n == SIZE_32)):
            s[S_BAD] += 1
            continue
        if s[S_HAS_LAST] != 0.0 and count == s[S_LAST]:
            s[S_STALE] += 1
            continue
        if s[S_HAS_LAST] != 0.0 and count < s[S_LAST]:
            reset_py(s, p)
            s[S_RESETS] += 1
        s[S_PWM1], s[S_PWM2], s[S_PWM3], s[S_PWM4] = float(m1), float(m2), float(m3), float(m4)
        s[S_SITL_RATE] = float(rate)
        step_py(s, p)
        msg = format_py(s, p, nts)
        t4 = clock()
        t_phys += t4 - t3
        sock.sendto(msg, addr)
        last_new = clock()
        t_io += last_new - t4
        s[S_LAST] = float(count)
        s[S_HAS_LAST] = 1.0
        s[S_ANSWERED] += 1
        answered += 1
    io[IO_STATUS] = status
    if status == OK:
        io[IO_WAITED] = 0.0
    io[IO_T_WAIT], io[IO_T_PHYS], io[IO_T_IO] = t_wait, t_phys, t_io
    return answered


class Kernel:
    """The twins behind one interface: ``step(s, p)``, ``format(s, p, nts) -> bytes`` and
    ``serve(sock, s, p, io) -> frames answered`` on Python lists; ``compiled`` says which twin runs."""

    def __init__(self, lib=None):
        self.compiled = lib is not None
        self.library = getattr(lib, "_name", None)
        self._lib = lib
        if lib is not None:
            lib.sitl_format.restype = ctypes.c_int
            lib.sitl_serve.restype = ctypes.c_int
            self._buf = ctypes.create_string_buffer(1024)

    def step(self, s: list, p) -> None:
        if self._lib is None:
            return step_py(s, p)
        cs, cp = _arr(s), _arr(p)
        self._lib.sitl_step(cs, cp)
        s[:] = cs

    def format(self, s, p, no_time_sync: bool = True) -> bytes:
        if self._lib is None:
            return format_py(s, p, no_time_sync)
        n = self._lib.sitl_format(_arr(s), _arr(p), ctypes.c_int(1 if no_time_sync else 0), self._buf,
                                  ctypes.c_int(len(self._buf)))
        return self._buf.raw[:n]

    def bind_serve(self, sock: socket.socket, p):
        """A function ``serve(s, io) -> answered`` for one socket and parameter tuple (buffers made once)."""
        if self._lib is None:
            return lambda s, io: serve_py(sock, s, p, io)
        lib, fd = self._lib, ctypes.c_int(sock.fileno())
        cs, cp, cio = (ctypes.c_double * N_STATE)(), _arr(p), (ctypes.c_double * N_IO)()

        def serve(s, io):
            cs[:] = s
            cio[:] = io
            n = lib.sitl_serve(fd, cs, cp, cio)
            s[:] = cs
            io[:] = cio
            return n
        return serve


def _arr(values):
    return (ctypes.c_double * len(values))(*values)


_loaded: dict = {}
_HERE = Path(__file__).resolve().parent


def disabled() -> bool:
    return os.environ.get(ENV, "") not in ("", "0")


def build_library(source: Path = SOURCE) -> tuple[Path | None, str | None]:
    """physics.c compiled by master.native_build into the per-user cache: (path, None) or (None, why not).
    Without ``master`` (sitlsim bundled into an FMU) nothing is built: the FMU carries its library."""
    try:
        from master.native_build import compile_cached
    except ImportError:
        return None, "master.native_build is not importable here (an FMU carries the library built with it)"
    if not Path(source).is_file():
        return None, f"no {Path(source).name}"
    return compile_cached(Path(source), LIBRARY[1:-3], "sitlsim", FLAGS)


def compile_library(dest_dir, source: Path = SOURCE) -> Path | None:
    """physics.c built (master.native_build) and copied to dest_dir/_sitlsim_physics.so; None without a C compiler
    (a failing compiler raises)."""
    path, why = build_library(source)
    if path is None:
        if why and why.startswith("the C compiler failed"):
            raise RuntimeError(f"compiling {Path(source).name} failed: {why}")
        return None
    out = Path(dest_dir) / LIBRARY
    tmp = out.with_name(f".{LIBRARY}.{os.getpid()}.tmp")
    shutil.copyfile(path, tmp)
    os.replace(tmp, out)          # atomic: a concurrent process sees the old library or the new one
    return out


def load(*folders, build: bool = True) -> Kernel:
    """The compiled twin from this file's folder (an FMU bundles it there) or ``folders``, else (``build``,
    outside an FMU) built by master.native_build into the cache, else the Python twin.  Cached per library path."""
    if disabled():
        return python()
    for folder in (_HERE, *map(Path, folders)):
        k = _try(Path(folder) / LIBRARY)
        if k is not None:
            return k
    if build:
        k, _ = built()
        if k is not None:
            return k
    return python()


def built() -> tuple[Kernel | None, str | None]:
    """The compiled twin built here through master.native_build: (Kernel, None) or (None, why not)."""
    if disabled():
        return None, f"{ENV} is set"
    path, why = build_library()
    if path is None:
        return None, why
    k = _try(path)
    return (k, None) if k is not None else (None, f"{path.name} does not load")


def _try(path: Path):
    key = str(path)
    if key in _loaded:
        return _loaded[key]
    if not path.is_file():
        return None
    try:
        lib = ctypes.CDLL(key)     # CDLL releases the GIL during calls: vehicles serve in parallel threads
    except OSError:                # another platform or architecture
        return None
    _loaded[key] = Kernel(lib)
    return _loaded[key]


def python() -> Kernel:
    k = _loaded.get(None)
    if k is None:
        k = _loaded[None] = Kernel(None)
    return k
