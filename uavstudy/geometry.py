"""Geometry engine of the master's UAV monitor (pure numpy / shapely 2).

Both detectors work on one co-simulation macro step [t0, t1] at a time and get
the vehicle positions at the start (``p0``) and at the end (``p1``) of the
step as ``(N, 3)`` float arrays in local ENU metres (see ``uavsim.geodesy``),
plus a boolean ``(N,)`` mask ``active`` of the vehicles to check (airborne and
not yet removed).  Motion within a step is taken as **linear** (constant
velocity between the two samples), so contacts and zone entries that happen
*between* samples (vehicles crossing each other, a zone corner cut) are found.

UAV-UAV collisions (``CollisionDetector``)
------------------------------------------
The paper delimits "a circular area of 2.6 m diameter around the centre of the
UAV" and "checks for the intersection of areas".  Two discs of diameter ``D``
intersect (touch) when the distance between their centres is ``<= D``; hence a
collision is declared when the minimum centre distance over the step is
``<= impact_diameter`` (+1e-9 m rounding tolerance, so the exact boundary,
e.g. two vehicles exactly 2.6 m apart, *is* a collision).  The distance is the
3D Euclidean distance (spheres of diameter D); with all UAVs at the same
cruise altitude this is the paper's planar disc test.

* Narrow phase: relative motion ``d(tau) = dp + dv tau``, tau in [0, 1];
  closest approach ``tau* = clamp(-dp.dv / dv.dv, 0, 1)``; the first contact
  is the earliest root of ``|dp + dv tau| = D`` (0 if already in contact at
  t0), computed in the cancellation-free form ``tau = 2c / (-b + sqrt(b^2-4ac))``.
* Broad phase (not quadratic): each vehicle's swept axis-aligned bounding box
  over the step (inflated by D/2) is hashed into a uniform xy grid (cell size
  default ``max(D, typical step displacement + D)``, typical = median
  displacement of the active vehicles); candidate pairs come only from shared
  cells, are deduplicated and filtered by full 3D AABB overlap.  Result is
  identical to the brute-force all-pairs test (``check_bruteforce``).  For
  very small fleets (``<= small_n`` active vehicles, default 12, i.e. <= 66
  pairs) hashing costs more than it saves, so all pairs go straight to the
  AABB filter, and up to ``py_n`` (default 8) active vehicles that filter runs
  on Python floats (a few numpy calls on tiny arrays cost more than the whole
  test).  ``check_few`` is the entry point for callers that already hold the
  positions as Python lists (the UAV monitor for small fleets).  All paths
  hand the same candidate pairs, in the same order, to the same narrow phase.

Restricted zones (``ZoneDetector``)
-----------------------------------
Zones are 2D polygons in local metres (xy = east/north) of **infinite height**
(the altitude is ignored, as in the paper, where the UAVs fly at one cruise
altitude).  There is no impact radius for zones: a vehicle is in incursion if
its xy position at t1 lies in a zone (boundary included), or if the segment
p0->p1 (xy) intersects the zone (a corner cut between two samples).  The
reported entry is the first point of the segment that meets the zone: fraction
0 (time t0) if p0 is already in the zone, otherwise the fraction along the
segment where it first reaches the polygon boundary.

Cheap reject: a vehicle whose step segment's bounding box is disjoint from
every zone's bounding box cannot meet a zone and is dropped before shapely
(``may_enter`` is the same test on Python floats for one segment).  The
result is unchanged (each vehicle's incursions do not depend on the others).

Skipping steps that provably hold no event (``SKIP_MARGIN``, ``pair_clearances``, ``ZoneDetector.clearance``)
-------------------------------------------------------------------------------------------------------------
Between two samples a vehicle moves on the segment p0->p1 (the linear motion above), so within a step it
stays within ``l = |p1 - p0|`` of p0, and after several steps within the sum ``T`` of its segment lengths of
the position where that sum started (triangle inequality).  Hence if two vehicles were ``d`` apart at a
reference time and have travelled ``T_i`` and ``T_j`` since, their centre distance at every instant up to
the end of the current step is at least ``d - T_i - T_j``; if that exceeds ``D`` they cannot be in contact
and the narrow phase would find nothing.  Likewise a vehicle ``e`` from the nearest zone bounding box that
has travelled ``T < e`` cannot meet a zone.  No speed limit of the model is assumed: ``T`` is measured from
the very positions the detectors are given.  The bound is made conservative against rounding: the
clearances are reduced by ``SKIP_MARGIN`` = 1 mm (the narrow phase's own rounding is ~1e-15 x the
coordinates, i.e. far below 1 mm for any map under 1e9 m; its tolerance ``_DIST_TOL`` is 1e-9 m) and the
travel is scaled by ``1 + SKIP_REL`` (the rounding of a float sum of n positive terms is below
n x 1.1e-16 of the sum, so this holds for up to ~1e9 steps between two resets).  NaN or inf anywhere makes
the comparison false, so such steps always take the exact path.  The UAV monitor's reference step
(``uavstudy.monitor_step``) runs the exact checks on every step; its accelerated step (``uavstudy.monitor_fast``)
skips by this bound, and ``uavstudy/monitor_step.c`` repeats the tests, ``pair_clearances``,
``ZoneDetector.clearance`` / ``may_enter`` and the broad phase of ``CollisionDetector.check_few`` in C with
the same operations: a change here must be made there too.  The accelerator harness (tests/accelerators/,
fleets from ``uavstudy.monitor_accel``) compares both with the reference bit for bit;
tests/uavstudy/test_uav_monitor_precheck.py checks the bound where it is tight.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import shapely

__all__ = ["Contact", "ZoneIncursion", "CollisionDetector", "ZoneDetector", "pair_clearances",
           "SKIP_MARGIN", "SKIP_REL"]

_DIST_TOL = 1e-9  # m, tolerance of the "<= D" test against rounding
SKIP_MARGIN = 1e-3  # m, taken off every clearance of the skip test (see the module doc)
SKIP_REL = 1e-6     # relative margin on the travelled distance of the skip test (float sums)


def pair_clearances(rows, impact_diameter: float) -> list[list[float]]:
    """``c[i][j] = |p_i - p_j| - impact_diameter - SKIP_MARGIN`` for the positions ``rows`` ((x, y, z)
    Python floats): two vehicles that travel ``T_i + T_j < c[i][j]`` from here cannot touch (module doc)."""
    sqrt = math.sqrt
    lim = impact_diameter + SKIP_MARGIN
    n = len(rows)
    out = [[-math.inf] * n for _ in range(n)]
    for i in range(n - 1):
        xi, yi, zi = rows[i]
        ci = out[i]
        for j in range(i + 1, n):
            xj, yj, zj = rows[j]
            dx, dy, dz = xj - xi, yj - yi, zj - zi
            ci[j] = out[j][i] = sqrt(dx * dx + dy * dy + dz * dz) - lim
    return out


@dataclass(frozen=True)
class Contact:
    """A UAV-UAV contact within a step.

    ``i < j`` are vehicle indices (rows of p0/p1); ``time`` the first time the
    centre distance reaches ``impact_diameter``; ``pos_i``/``pos_j`` the
    positions at that time; ``min_distance`` the minimum centre distance over
    the step, reached at ``time_min``.
    """
    i: int
    j: int
    time: float
    pos_i: tuple[float, float, float]
    pos_j: tuple[float, float, float]
    min_distance: float
    time_min: float


@dataclass(frozen=True)
class ZoneIncursion:
    """A vehicle entering (or being in) a restricted zone within a step."""
    vehicle: int
    zone: int
    zone_name: str
    time: float
    position: tuple[float, float, float]
    fraction: float          # along the step segment, 0 = t0
    inside_at_end: bool      # p1 (xy) is in the zone


def _as_inputs(p0, p1, active):
    p0 = np.asarray(p0, dtype=float)
    p1 = np.asarray(p1, dtype=float)
    if p0.ndim != 2 or p0.shape[1] != 3 or p1.shape != p0.shape:
        raise ValueError(f"p0 and p1 must both be (N, 3) arrays, got {p0.shape} and {p1.shape}")
    n = p0.shape[0]
    if active is None:
        active = np.ones(n, dtype=bool)
    else:
        active = np.asarray(active, dtype=bool)
        if active.shape != (n,):
            raise ValueError(f"active must be a bool array of shape ({n},), got {active.shape}")
    return p0, p1, active


class CollisionDetector:
    """Continuous (swept) UAV-UAV collision detection with a spatial-hash broad phase."""

    def __init__(self, impact_diameter: float = 2.6, cell_size: float | None = None,
                 small_n: int = 16, py_n: int = 16, sweep: bool = True):
        if not impact_diameter > 0:
            raise ValueError("impact_diameter must be > 0")
        if cell_size is not None and not cell_size > 0:
            raise ValueError("cell_size must be > 0")
        self.impact_diameter = float(impact_diameter)
        self.cell_size = None if cell_size is None else float(cell_size)
        self.small_n = int(small_n)
        self.py_n = min(int(py_n), self.small_n)
        self.sweep = bool(sweep)
        self.last_candidate_count = 0   # diagnostics: pairs passed to the narrow phase

    # ----------------------------------------------------------------- broad
    def _cell_size_for(self, disp: np.ndarray) -> float:
        if self.cell_size is not None:
            return self.cell_size
        typical = float(np.median(disp)) if disp.size else 0.0
        return max(self.impact_diameter, typical + self.impact_diameter)

    def candidate_pairs(self, p0, p1, active=None) -> np.ndarray:
        """Candidate pairs (K, 2) of vehicle indices (i < j, unique, sorted)
        whose inflated swept AABBs overlap, found by uniform-grid hashing."""
        p0, p1, active = _as_inputs(p0, p1, active)
        idx = np.flatnonzero(active)
        if idx.size < 2:
            self.last_candidate_count = 0
            return np.empty((0, 2), dtype=np.int64)
        if idx.size <= self.py_n:
            il = idx.tolist()
            pi, pj = self._pairs_few(il, p0[idx].tolist(), p1[idx].tolist(), local=True)
            return np.array([pi, pj], dtype=np.int64).T.reshape(-1, 2)
        a, b = p0[idx], p1[idx]
        r = 0.5 * self.impact_diameter
        lo = np.minimum(a, b) - r
        hi = np.maximum(a, b) + r
        m = idx.size
        if m <= self.small_n:
            pa, pb = np.triu_indices(m, k=1)
            return self._aabb_filter(idx, lo, hi, pa, pb)
        if self.sweep and self.cell_size is None:
            pairs = self._sweep_pairs(idx, lo, hi, m)
            if pairs is not None:
                return pairs
        disp = np.linalg.norm(b - a, axis=1)
        cell = self._cell_size_for(disp)

        while True:
            c_lo = np.floor(lo[:, :2] / cell).astype(np.int64)
            c_hi = np.floor(hi[:, :2] / cell).astype(np.int64)
            nx = c_hi[:, 0] - c_lo[:, 0] + 1
            ny = c_hi[:, 1] - c_lo[:, 1] + 1
            counts = nx * ny
            total = int(counts.sum())
            # guard against outliers (a very long displacement) blowing up
            # the number of cell entries: coarsen the grid
            if total <= 16 * m + 64:
                break
            cell *= 2.0

        owner = np.repeat(np.arange(m), counts)
        start = np.cumsum(counts) - counts
        local = np.arange(total) - np.repeat(start, counts)
        nyr = np.repeat(ny, counts)
        cx = np.repeat(c_lo[:, 0], counts) + local // nyr
        cy = np.repeat(c_lo[:, 1], counts) + local % nyr
        cx -= cx.min()
        cy -= cy.min()
        key = cx * (int(cy.max()) + 1) + cy

        order = np.lexsort((owner, key))
        key = key[order]
        owner = owner[order]
        # group boundaries
        brk = np.flatnonzero(np.diff(key)) + 1
        g_start = np.concatenate(([0], brk))
        g_end = np.concatenate((brk, [total]))
        g_size = g_end - g_start
        multi = g_size > 1
        if not multi.any():
            self.last_candidate_count = 0
            return np.empty((0, 2), dtype=np.int64)
        # for each entry of a multi-vehicle cell: pair with the later entries
        end_of = np.repeat(g_end, g_size)
        pos = np.arange(total)
        npair = end_of - pos - 1
        npair[~np.repeat(multi, g_size)] = 0
        tot_pairs = int(npair.sum())
        first = np.repeat(pos, npair)
        pstart = np.cumsum(npair) - npair
        second = first + 1 + (np.arange(tot_pairs) - np.repeat(pstart, npair))
        ia = owner[first]
        ib = owner[second]
        pa = np.minimum(ia, ib)
        pb = np.maximum(ia, ib)
        code = np.unique(pa * m + pb)
        pa, pb = code // m, code % m
        return self._aabb_filter(idx, lo, hi, pa, pb)

    def _sweep_pairs(self, idx, lo, hi, m):
        """Sort and sweep on x: the pairs whose x intervals overlap, then the AABB filter; None when there
        are more than ``16 m + 64`` x-overlapping pairs (e.g. a fleet lined up north-south), where the 2D
        hash is the better broad phase.  Same pairs, in the same order, as the hash."""
        order = np.argsort(lo[:, 0], kind="stable")
        end = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
        cnt = end - np.arange(1, m + 1)
        np.maximum(cnt, 0, out=cnt)
        total = int(cnt.sum())
        if total > 16 * m + 64:
            return None
        if total == 0:
            self.last_candidate_count = 0
            return np.empty((0, 2), dtype=np.int64)
        first = np.repeat(np.arange(m), cnt)
        start = np.cumsum(cnt) - cnt
        second = first + 1 + (np.arange(total) - np.repeat(start, cnt))
        ia, ib = order[first], order[second]
        code = np.sort(np.minimum(ia, ib) * m + np.maximum(ia, ib))
        return self._aabb_filter(idx, lo, hi, code // m, code % m)

    def _pairs_few(self, idx, rows0, rows1, local=False):
        """The AABB filter of ``_aabb_filter`` over all pairs of the few vehicles ``idx`` (ascending), on
        Python floats: ``rows0[k]``/``rows1[k]`` are the (x, y, z) of vehicle ``idx[k]`` if ``local``, else
        of vehicle ``k``.  Returns (pi, pj) lists of vehicle indices in the order of ``np.triu_indices``."""
        r = 0.5 * self.impact_diameter
        boxes = []
        for n, k in enumerate(idx):
            a = rows0[n if local else k]
            b = rows1[n if local else k]
            ax, ay, az = a
            bx, by, bz = b
            if not (ax == ax and ay == ay and az == az and bx == bx and by == by and bz == bz):
                continue    # a NaN coordinate: np.minimum/maximum give a NaN bound, which overlaps nothing
            boxes.append((k, (ax if ax <= bx else bx) - r, (ay if ay <= by else by) - r,
                          (az if az <= bz else bz) - r, (ax if ax >= bx else bx) + r,
                          (ay if ay >= by else by) + r, (az if az >= bz else bz) + r))
        pi, pj = [], []
        m = len(boxes)
        for u in range(m - 1):
            k, lx, ly, lz, hx, hy, hz = boxes[u]
            for v in range(u + 1, m):
                q, mx, my, mz, nx, ny, nz = boxes[v]
                if lx <= nx and mx <= hx and ly <= ny and my <= hy and lz <= nz and mz <= hz:
                    pi.append(k)
                    pj.append(q)
        self.last_candidate_count = len(pi)
        return pi, pj

    def _aabb_filter(self, idx, lo, hi, pa, pb):
        # exact 3D AABB overlap filter
        ok = np.all((lo[pa] <= hi[pb]) & (lo[pb] <= hi[pa]), axis=1)
        pa, pb = pa[ok], pb[ok]
        self.last_candidate_count = int(pa.size)
        return np.stack((idx[pa], idx[pb]), axis=1).astype(np.int64)

    # ---------------------------------------------------------------- narrow
    def _narrow(self, t0, t1, p0, p1, pi, pj) -> list[Contact]:
        if pi.size == 0:
            return []
        D = self.impact_diameter
        dp = p0[pj] - p0[pi]
        dv = (p1[pj] - p1[pi]) - dp
        a = np.einsum("ij,ij->i", dv, dv)
        bh = np.einsum("ij,ij->i", dp, dv)          # b / 2
        c = np.einsum("ij,ij->i", dp, dp) - D * D
        with np.errstate(divide="ignore", invalid="ignore"):
            tau_min = np.where(a > 0, np.clip(-bh / np.where(a > 0, a, 1.0), 0.0, 1.0), 0.0)
        dmin = np.linalg.norm(dp + dv * tau_min[:, None], axis=1)
        hit = dmin <= D + _DIST_TOL
        if not hit.any():
            return []
        pi, pj = pi[hit], pj[hit]
        a, bh, c, tau_min, dmin = a[hit], bh[hit], c[hit], tau_min[hit], dmin[hit]
        # earliest root of a tau^2 + 2 bh tau + c = 0 (c > 0 and bh < 0 if not
        # in contact at t0): tau = c / (-bh + sqrt(bh^2 - a c))
        disc = np.maximum(bh * bh - a * c, 0.0)
        den = -bh + np.sqrt(disc)
        with np.errstate(divide="ignore", invalid="ignore"):
            tau = np.where((c > 0) & (den > 0), c / np.where(den > 0, den, 1.0), 0.0)
        tau = np.clip(np.minimum(tau, tau_min), 0.0, 1.0)
        tau = np.where(c <= 0, 0.0, tau)
        dt = t1 - t0
        times = t0 + tau * dt
        xi = p0[pi] + (p1[pi] - p0[pi]) * tau[:, None]
        xj = p0[pj] + (p1[pj] - p0[pj]) * tau[:, None]
        tmin = t0 + tau_min * dt
        order = np.lexsort((pj, pi, times))
        return [Contact(int(pi[k]), int(pj[k]), float(times[k]),
                        tuple(map(float, xi[k])), tuple(map(float, xj[k])),
                        float(dmin[k]), float(tmin[k])) for k in order]

    # ------------------------------------------------------------------- api
    def check(self, t0: float, t1: float, p0, p1, active=None) -> list[Contact]:
        """Contacts of active vehicles over the step [t0, t1], sorted by (time, i, j)."""
        p0, p1, active = _as_inputs(p0, p1, active)
        pairs = self.candidate_pairs(p0, p1, active)
        return self._narrow(float(t0), float(t1), p0, p1, pairs[:, 0], pairs[:, 1])

    def check_few(self, t0: float, t1: float, p0, p1, idx, rows0, rows1) -> list[Contact]:
        """``check`` for a few active vehicles held as Python data: ``idx`` the active vehicles (ascending
        list), ``rows0``/``rows1`` ``p0.tolist()``/``p1.tolist()`` of the (N, 3) float arrays p0/p1 (which
        the narrow phase still uses).  Same result as ``check(t0, t1, p0, p1, active)``."""
        if len(idx) < 2:
            self.last_candidate_count = 0
            return []
        pi, pj = self._pairs_few(idx, rows0, rows1)
        if not pi:
            return []
        return self._narrow(float(t0), float(t1), p0, p1, np.array(pi, dtype=np.int64),
                            np.array(pj, dtype=np.int64))

    def check_bruteforce(self, t0: float, t1: float, p0, p1, active=None) -> list[Contact]:
        """Reference O(N^2) version of ``check`` (same narrow phase, all pairs)."""
        p0, p1, active = _as_inputs(p0, p1, active)
        idx = np.flatnonzero(active)
        ii, jj = np.triu_indices(idx.size, k=1)
        return self._narrow(float(t0), float(t1), p0, p1, idx[ii], idx[jj])


class ZoneDetector:
    """Restricted-zone incursion detection (2D polygons of infinite height)."""

    def __init__(self, polygons: Sequence[Sequence[Sequence[float]]],
                 names: Sequence[str] | None = None):
        polys = []
        for k, ring in enumerate(polygons):
            coords = np.asarray(ring, dtype=float)
            if coords.ndim != 2 or coords.shape[1] != 2 or coords.shape[0] < 3:
                raise ValueError(f"zone {k}: polygon needs >= 3 (x, y) vertices")
            poly = shapely.Polygon(coords)
            if not poly.is_valid:
                poly = shapely.make_valid(poly)
            if poly.is_empty or poly.area <= 0:
                raise ValueError(f"zone {k}: polygon has zero area")
            polys.append(poly)
        if names is None:
            names = [f"zone{k}" for k in range(len(polys))]
        names = [str(n) for n in names]
        if len(names) != len(polys):
            raise ValueError("names must have one entry per polygon")
        self.names = names
        self.polygons = np.array(polys, dtype=object)
        for poly in self.polygons:
            shapely.prepare(poly)
        self._tree = shapely.STRtree(self.polygons) if len(polys) else None
        # bounding boxes (minx, miny, maxx, maxy) of the zones and of all of them: the cheap reject
        self.bounds = shapely.bounds(self.polygons).reshape(-1, 4) if len(polys) else np.empty((0, 4))
        self._bounds_list = [tuple(map(float, b)) for b in self.bounds]
        self._envelope = ((float(self.bounds[:, 0].min()), float(self.bounds[:, 1].min()),
                           float(self.bounds[:, 2].max()), float(self.bounds[:, 3].max()))
                          if len(polys) else None)

    def may_enter(self, x0: float, y0: float, x1: float, y1: float) -> bool:
        """False when the segment (x0, y0)-(x1, y1) certainly meets no zone: its bounding box is disjoint
        from every zone's (Python floats; a NaN coordinate never rejects)."""
        env = self._envelope
        if env is None:
            return False
        if not (x0 == x0 and y0 == y0 and x1 == x1 and y1 == y1):
            return True
        if x0 <= x1:
            lx, hx = x0, x1
        else:
            lx, hx = x1, x0
        if y0 <= y1:
            ly, hy = y0, y1
        else:
            ly, hy = y1, y0
        if hx < env[0] or lx > env[2] or hy < env[1] or ly > env[3]:
            return False
        for bx0, by0, bx1, by1 in self._bounds_list:
            if not (hx < bx0 or lx > bx1 or hy < by0 or ly > by1):
                return True
        return False

    def clearance(self, x: float, y: float) -> float:
        """Distance from (x, y) to the nearest zone bounding box less ``SKIP_MARGIN`` (negative inside a box,
        NaN for a NaN coordinate): a vehicle that travels less than this from here meets no zone."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return math.nan     # never skips: a non-finite position always takes the exact path
        best = math.inf
        for bx0, by0, bx1, by1 in self._bounds_list:
            dx = bx0 - x if x < bx0 else (x - bx1 if x > bx1 else 0.0)
            dy = by0 - y if y < by0 else (y - by1 if y > by1 else 0.0)
            d = math.sqrt(dx * dx + dy * dy)
            if d < best:
                best = d
        return best - SKIP_MARGIN

    def check(self, t0: float, t1: float, p0, p1, active=None) -> list[ZoneIncursion]:
        """Incursions of active vehicles during [t0, t1], sorted by (time, vehicle, zone)."""
        p0, p1, active = _as_inputs(p0, p1, active)
        idx = np.flatnonzero(active)
        if self._tree is None or idx.size == 0:
            return []
        a, b = p0[idx], p1[idx]
        a2, b2 = a[:, :2], b[:, :2]
        # cheap reject: the segment's bounding box must overlap a zone's (NaN never rejects)
        lo, hi = np.minimum(a2, b2), np.maximum(a2, b2)
        bd = self.bounds if len(self.bounds) <= 64 else np.array([self._envelope])
        away = ((hi[:, None, 0] < bd[None, :, 0]) | (lo[:, None, 0] > bd[None, :, 2])
                | (hi[:, None, 1] < bd[None, :, 1]) | (lo[:, None, 1] > bd[None, :, 3])).all(axis=1)
        if away.all():
            return []
        if away.any():
            near = ~away
            idx, a, b, a2, b2 = idx[near], a[near], b[near], a2[near], b2[near]
        moving = np.any(a2 != b2, axis=1)
        geoms = np.empty(idx.size, dtype=object)
        if moving.any():
            geoms[moving] = shapely.linestrings(
                np.stack((a2[moving], b2[moving]), axis=1))
        if (~moving).any():
            geoms[~moving] = shapely.points(a2[~moving])
        vi, zi = self._tree.query(geoms, predicate="intersects")
        if vi.size == 0:
            return []
        polys = self.polygons[zi]
        start_in = shapely.intersects_xy(polys, a2[vi, 0], a2[vi, 1])
        end_in = shapely.intersects_xy(polys, b2[vi, 0], b2[vi, 1])
        frac = np.zeros(vi.size)
        todo = np.flatnonzero(~start_in & moving[vi])
        if todo.size:
            # portion(s) of the segment inside the zone; its first point is the entry
            inter = shapely.intersection(geoms[vi[todo]], polys[todo])
            coords, which = shapely.get_coordinates(inter, return_index=True)
            seg0 = a2[vi[todo]]
            d = b2[vi[todo]] - seg0
            dd = np.einsum("ij,ij->i", d, d)
            f = np.einsum("ij,ij->i", coords - seg0[which], d[which]) / dd[which]
            fmin = np.full(todo.size, np.inf)
            np.minimum.at(fmin, which, f)
            # empty intersection cannot happen (predicate said intersects) but guard
            fmin[~np.isfinite(fmin)] = 1.0
            frac[todo] = np.clip(fmin, 0.0, 1.0)
        times = t0 + frac * (t1 - t0)
        pos = a[vi] + (b[vi] - a[vi]) * frac[:, None]
        veh = idx[vi]
        order = np.lexsort((zi, veh, times))
        return [ZoneIncursion(int(veh[k]), int(zi[k]), self.names[zi[k]], float(times[k]),
                              tuple(map(float, pos[k])), float(frac[k]), bool(end_in[k]))
                for k in order]
