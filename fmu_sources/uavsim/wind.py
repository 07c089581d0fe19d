"""Stochastic wind of the paper, with optional Dryden turbulence and discrete 1-cosine gusts.

Episode model (the paper: "a pseudorandom algorithm that selects the presence of wind and its
intensity (weak, moderate or strong) ... a force that pushes the UAV from east to west"):

* time is divided into decision intervals k = 0, 1, ... of length T (``decision_interval``);
* at the start of interval k, with probability ``probability`` a wind episode occurs; its level is
  weak / moderate / strong with probabilities p_weak, p_moderate, 1 - p_weak - p_moderate and its
  mean speed is speed_weak / speed_moderate / speed_strong;
* the episode starts at kT and lasts D = min(``duration``, T) seconds, with linear onset and decay
  ramps of ``ramp`` seconds (trapezoid), so the mean speed is
  U(t) = U_k * clip(min(t - kT, kT + D - t) / ramp, 0, 1);
* the wind blows from ``direction_deg`` (meteorological convention: the direction the wind comes
  FROM, clockwise from north; 90 = from the east).  The air velocity (direction it blows TO) is
  w = -U (sin(dir), cos(dir), 0) in ENU, so the default 90 deg gives w_x = -U (east -> west).

Optional Dryden turbulence (MIL-F-8785C low-altitude model, h < 1000 ft), W20 = U_k (speed of the
episode, taken as the wind at 20 ft = 6 m):
    sigma_w = 0.1 W20,  sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
    L_w = h,            L_u = L_v = h / (0.177 + 0.000823 h)^1.2          (h, L in ft)
Each component is the first-order Dryden (Markov) process advected past the vehicle at the mean
wind speed (Taylor's frozen turbulence; the vehicle hovers or is slow relative to the air mass),
discretised exactly on a fixed grid of ``turb_dt``:
    x[n+1] = a x[n] + sigma sqrt(1 - a^2) eta[n],  a = exp(-U turb_dt / L),  eta ~ N(0, 1)
(longitudinal u along the mean wind, lateral v across it, vertical w).  Turbulence is zero
outside episodes (no wind, no turbulence); each episode starts from a draw of the stationary
distribution N(0, sigma^2), so every sample has the Dryden variance.

Optional discrete gust (MIL-F-8785C "1-cosine"): within each episode one gust of amplitude
A = ``gust_amplitude`` * U_k along the mean wind, length T_g = min(``gust_length``, D) s (a gust
longer than the episode is shortened to it, so the whole 1-cosine lies inside the episode), starting
at t_g = kT + u (D - T_g) with u uniform in [0, 1) (t_g = kT when T_g = D):
u_g(t) = A/2 (1 - cos(2 pi (t - t_g)/T_g)) for t_g <= t <= t_g + T_g.
Gust and turbulence are scaled by the ramp factor U(t)/U_k, so the wind is continuous.

Determinism: all random numbers for interval k are drawn when interval k is first entered, from
three independent PCG64 streams (episode, gust, turbulence) spawned from SeedSequence(seed) (with
``stream`` >= 0, from SeedSequence((seed, stream + 1)): one independent wind per UAV of a fleet); the
same numbers are drawn whether or not turbulence/gusts are enabled (the turbulence stream, which feeds
nothing else, only when turbulence is).  The output at time t is a
function of t only (turbulence is held piecewise-constant on the turb_dt grid), hence identical
for any master step size.

This module is the reference: the plain code a reader follows and changes.  Its accelerator, uavsim/_wind_ext.c,
computes the UavWind FMU's step (``mean_over`` of the coming step) exactly the same, faster, from the public fields
of :class:`Wind` (``intervals``, ``occurs``, ``drawn``, ``calm``, ``ux``, ``uy``, ``p``), leaving random draws and
turbulence to this code; it is declared in uavsim/accelerators.py and checked against this code by the accelerator
harness (``COSIM_MASTER_PURE_PYTHON=1`` switches it off).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import params as P

FT = 0.3048


@dataclass
class WindParams:
    probability: float = P.WIND_PROBABILITY          # 1 per decision interval
    seed: int = 0
    stream: int = -1                                 # -1: the fleet's one wind; i >= 0: UAV i's own
    direction_deg: float = P.WIND_DIRECTION_DEG      # deg, "from", clockwise from north
    decision_interval: float = P.WIND_DECISION_INTERVAL  # s
    duration: float = P.WIND_DURATION                # s
    ramp: float = P.WIND_RAMP                        # s
    speed_weak: float = P.WIND_SPEED_WEAK            # m/s
    speed_moderate: float = P.WIND_SPEED_MODERATE    # m/s
    speed_strong: float = P.WIND_SPEED_STRONG        # m/s
    p_weak: float = P.WIND_P_WEAK                    # 1
    p_moderate: float = P.WIND_P_MODERATE            # 1
    turbulence: bool = False
    turb_dt: float = P.TURB_DT                       # s
    turb_altitude: float = P.TURB_ALTITUDE           # m
    gusts: bool = False
    gust_amplitude: float = P.GUST_AMPLITUDE         # fraction of U_k
    gust_length: float = P.GUST_LENGTH               # s


def dryden_low_altitude(w20: float, h_m: float):
    """(sigma_u, sigma_v, sigma_w) [m/s] and (L_u, L_v, L_w) [m] of MIL-F-8785C below 1000 ft."""
    h = max(h_m / FT, 10.0)          # ft; the model is not defined at the ground
    h = min(h, 1000.0)
    f = 0.177 + 0.000823 * h
    sw = 0.1 * w20
    su = sw / f ** 0.4
    lw = h * FT
    lu = h / f ** 1.2 * FT
    return (su, su, sw), (lu, lu, lw)


class Interval:
    """The numbers drawn for decision interval k (its noise: the turbulence stream's block, None without
    turbulence; turb, turb_n: the Dryden state of its last sample)."""
    __slots__ = ("k", "occurs", "level", "speed", "gust_start", "noise", "turb", "turb_n")


class Wind:
    """Wind field w(t) = (w_x, w_y, w_z); call ``at(t)`` with non-decreasing t."""

    def __init__(self, params: WindParams | None = None):
        self.p = params or WindParams()
        seed = int(self.p.seed)
        ss = np.random.SeedSequence(seed if int(self.p.stream) < 0 else (seed, int(self.p.stream) + 1))
        s_ep, s_gust, s_turb = ss.spawn(3)
        self._rng_ep = np.random.Generator(np.random.PCG64(s_ep))
        self._rng_gust = np.random.Generator(np.random.PCG64(s_gust))
        self._rng_turb = np.random.Generator(np.random.PCG64(s_turb))
        # the state, public: the compiled step (uavsim/_wind_ext.c) reads these fields by these names and sets calm
        self.intervals: dict[int, Interval] = {}   # the intervals drawn, by index k
        self.occurs: list[bool] = []        # occurs[k]: wind in interval k (drawn intervals only)
        self.drawn = 0                      # intervals 0 ... drawn - 1 are drawn
        self.calm = (math.inf, -math.inf)   # a time window in calm intervals only (see mean_over)
        self.n_turb = max(1, int(round(self.p.decision_interval / self.p.turb_dt)))
        d = math.radians(self.p.direction_deg)
        self.ux, self.uy = -math.sin(d), -math.cos(d)     # unit vector the wind blows toward

    # ------------------------------------------------------------------ random draws
    def _interval(self, k: int) -> Interval:
        while self.drawn <= k:
            self._draw(self.drawn)
            self.drawn += 1
        return self.intervals[k]

    def _draw(self, k: int) -> None:
        p = self.p
        iv = Interval()
        iv.k = k
        # two scalar draws: the same two numbers of the stream as random(2), as Python floats, at half the cost
        rng_ep = self._rng_ep
        u_occ = rng_ep.random()
        u_lvl = rng_ep.random()
        iv.occurs = bool(u_occ < p.probability)
        if not iv.occurs:
            iv.level, iv.speed = 0, 0.0
        elif u_lvl < p.p_weak:
            iv.level, iv.speed = 1, p.speed_weak
        elif u_lvl < p.p_weak + p.p_moderate:
            iv.level, iv.speed = 2, p.speed_moderate
        else:
            iv.level, iv.speed = 3, p.speed_strong
        iv.gust_start = self._rng_gust.random()
        # the turbulence stream feeds nothing else, so without turbulence it is not drawn at all (most of the cost
        # of a draw; interval k's episode and gust numbers are the same either way), and a windy 256-UAV hour holds
        # no ~220 MB of unused noise (row 0 of the noise: the initial state)
        iv.noise = self._rng_turb.standard_normal((self.n_turb + 1, 3)) if p.turbulence else None
        iv.turb = None
        iv.turb_n = -1
        self.intervals[k] = iv
        self.occurs.append(iv.occurs)

    # ------------------------------------------------------------------ evaluation
    def _episode_length(self) -> float:
        return min(self.p.duration, self.p.decision_interval)

    def gust_window(self, k: int) -> tuple[float, float]:
        """(start time, length) of the 1-cosine gust of interval k (whether or not wind occurs).

        The gust length is clipped to the episode, T_g = min(gust_length, D), and its start is drawn
        uniformly in [kT, kT + D - T_g], so the gust always lies inside the episode."""
        p = self.p
        D = self._episode_length()
        tg_len = min(max(p.gust_length, 0.0), D)
        iv = self._interval(max(int(k), 0))
        return k * p.decision_interval + (D - tg_len) * iv.gust_start, tg_len

    def level_at(self, t: float) -> tuple[int, float]:
        """(level, mean speed U(t)) at time t."""
        p = self.p
        k = int(math.floor(t / p.decision_interval + 1e-12))
        iv = self._interval(max(k, 0))
        if not iv.occurs:
            return 0, 0.0
        tau = t - k * p.decision_interval
        D = self._episode_length()
        if tau < 0.0 or tau >= D:
            return 0, 0.0
        if p.ramp > 0.0:
            f = min(1.0, tau / p.ramp, (D - tau) / p.ramp)
        else:
            f = 1.0
        return iv.level, iv.speed * max(0.0, f)

    def _turbulence(self, iv: Interval, tau: float):
        p = self.p
        n = min(self.n_turb - 1, int(math.floor(tau / p.turb_dt + 1e-9)))
        if n == iv.turb_n and iv.turb is not None:
            return iv.turb                       # the same grid cell as the last sample (most samples)
        sig, L = dryden_low_altitude(iv.speed, p.turb_altitude)
        if iv.turb is None or n < iv.turb_n:     # first use, or time went backwards: recompute
            # start each episode in the stationary distribution N(0, sigma^2)
            iv.turb = np.array([sig[j] * iv.noise[0, j] for j in range(3)])
            iv.turb_n = 0
        U = max(iv.speed, 1.0)
        while iv.turb_n < n:
            for j in range(3):
                a = math.exp(-U * p.turb_dt / L[j])
                iv.turb[j] = a * iv.turb[j] + sig[j] * math.sqrt(1.0 - a * a) * iv.noise[iv.turb_n + 1, j]
            iv.turb_n += 1
        return iv.turb

    def mean_over(self, t0: float, t1: float, resolution: float = 0.05) -> tuple[float, float, float, int]:
        """Mean air velocity over [t0, t1] (midpoint rule on sub-intervals of at most ``resolution``) and
        the strongest level seen in it.

        A master holds an output constant over its communication step (zero-order hold); a vehicle fed the
        instantaneous wind at t0 would feel an episode's onset ramp (0 at the episode start) for the whole
        step and, with steps as long as the episodes, no wind at all. Fed the step mean, it receives the
        same impulse whatever the step."""
        if not self.p.probability > 0.0:
            return 0.0, 0.0, 0.0, 0          # no episode can occur (u < probability never holds): calm
        h = t1 - t0
        if h <= 0.0:
            return self.at(t0)
        lo, hi = self.calm
        if lo <= t0 and t1 <= hi:
            return 0.0, 0.0, 0.0, 0          # every sample (in [t0, t1]) lies in a calm interval
        m = math.ceil(h / resolution - 1e-9)          # then clipped to 1 ... 200 samples
        m = 1 if m < 1 else (200 if m > 200 else m)
        p = self.p
        di = p.decision_interval
        floor = math.floor
        k0 = floor((t0 + 0.5 * h / m) / di + 1e-12)
        k1 = floor((t0 + (m - 0.5) * h / m) / di + 1e-12)
        if k0 < 0:
            return self._mean_of_samples(t0, h, m)
        if k1 >= self.drawn:
            self._interval(k1)
        occurs = self.occurs
        if not (occurs[k0] if k0 == k1 else any(occurs[k0:k1 + 1])):
            self.calm = self._calm_window(k0, k1)
            return 0.0, 0.0, 0.0, 0          # calm intervals (most of them): every sample is zero
        # the samples of at(t), written out in one loop (this runs every step of every UAV in wind): the
        # same expressions in the same order, so the same bits as summing at(t) (tests/fmu_sources/uavsim/test_uav_wind.py)
        D = self._episode_length()
        ramp = p.ramp
        gusts = p.gusts
        tg_len = min(p.gust_length, D)
        gust = gusts and tg_len > 0.0
        amp = p.gust_amplitude
        turbulence = p.turbulence
        ux, uy = self.ux, self.uy
        intervals = self.intervals
        cos, two_pi = math.cos, 2.0 * math.pi
        sx = sy = sz = 0.0
        level = 0
        for j in range(m):
            t = t0 + (j + 0.5) * h / m
            k = floor(t / di + 1e-12)
            if not occurs[k]:
                continue                     # at(t) is (0, 0, 0, 0): adding +0.0 to a sum that starts at +0.0
            iv = intervals[k]
            tau = t - k * di
            if tau < 0.0 or tau >= D:
                continue                     # outside the episode: (0, 0, 0, 0) as well
            lv = iv.level
            if lv > level:
                level = lv
            if ramp > 0.0:
                f = min(1.0, tau / ramp, (D - tau) / ramp)
            else:
                f = 1.0
            U = iv.speed * max(0.0, f)
            if U <= 0.0:
                continue
            along, cross, up = U, 0.0, 0.0
            f = U / iv.speed
            if gust:
                s = tau - (D - tg_len) * iv.gust_start
                if 0.0 <= s <= tg_len:
                    along += f * 0.5 * amp * iv.speed * (1.0 - cos(two_pi * s / tg_len))
            if turbulence:
                tu = self._turbulence(iv, tau)
                along += f * float(tu[0])
                cross += f * float(tu[1])
                up += f * float(tu[2])
            sx += along * ux - cross * uy
            sy += along * uy + cross * ux
            sz += up
        return sx / m, sy / m, sz / m, level

    def _calm_window(self, k0: int, k1: int, ahead: int = 16) -> tuple[float, float]:
        """A time window [a, b] whose every t has floor(t / T + 1e-12) in calm intervals k0 ... kb: the
        calm intervals k0 ... k1 and those after them (drawn ahead: each interval's numbers are the same
        whenever it is drawn, the streams draw interval after interval; at most ``ahead`` of them, as each
        holds its turbulence numbers and a fleet has a wind per UAV).  The 1e-6 margins exceed the
        rounding of t / T by far (for k below 1e9), so a step inside the window needs no sampling."""
        occurs = self.occurs
        kb = k1
        while kb - k0 < ahead:
            if kb + 1 >= self.drawn:
                self._interval(kb + 1)
            if occurs[kb + 1]:
                break
            kb += 1
        di = self.p.decision_interval
        return (k0 + 1e-6) * di, (kb + 1 - 1e-6) * di

    def _mean_of_samples(self, t0: float, h: float, m: int) -> tuple[float, float, float, int]:
        """The definition of :meth:`mean_over`: the mean of m midpoint samples of :meth:`at`."""
        sx = sy = sz = 0.0
        level = 0
        for j in range(m):
            wx, wy, wz, lv = self.at(t0 + (j + 0.5) * h / m)
            sx += wx
            sy += wy
            sz += wz
            level = max(level, lv)
        return sx / m, sy / m, sz / m, level

    def at(self, t: float) -> tuple[float, float, float, int]:
        """(w_x, w_y, w_z, level) at time t [m/s]."""
        p = self.p
        level, U = self.level_at(t)
        if U <= 0.0:
            return 0.0, 0.0, 0.0, level
        k = int(math.floor(t / p.decision_interval + 1e-12))
        iv = self._interval(k)
        tau = t - k * p.decision_interval
        along, cross, up = U, 0.0, 0.0
        f = U / iv.speed            # ramp factor: gust and turbulence fade in/out with the episode
        if p.gusts:
            D = self._episode_length()
            tg_len = min(p.gust_length, D)           # a gust never outlasts its episode
            if tg_len > 0.0:
                s = tau - (D - tg_len) * iv.gust_start
                if 0.0 <= s <= tg_len:
                    along += f * 0.5 * p.gust_amplitude * iv.speed * (1.0 - math.cos(2.0 * math.pi * s / tg_len))
        if p.turbulence:
            tu = self._turbulence(iv, tau)
            along += f * float(tu[0])
            cross += f * float(tu[1])
            up += f * float(tu[2])
        # along-wind unit (ux, uy); cross-wind unit rotated +90 deg: (-uy, ux)
        wx = along * self.ux - cross * self.uy
        wy = along * self.uy + cross * self.ux
        return wx, wy, up, level
