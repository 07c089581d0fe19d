"""The mission layout a scenario flies: targets, zones and which UAV starts where and when.

``layout: fixed`` flies the scenario's own targets and zones (the shipped area, frozen in its YAML) with the
UAVs on their pads in index order.  ``layout: random`` draws a new area of the same kind from ``layout_seed``:
as many targets and zones as the scenario gives, by the rules the shipped area was made with
(docs/paper_config_format.md), and a random pad (or take-off) order.  A campaign gives every repetition its own
``layout_seed`` (uavstudy/campaign_kind.py), so the repetitions of a cell are different areas, and the same
repetition index flies the same area in every cell (strategy A and B, any wind, any fleet size): the layout is
a block of the design.

Targets, zones and the pad order come from three independent streams of ``SeedSequence(layout_seed)``, so the
free and the restricted-zones variant of one repetition share their targets and their pad order.
``area_scale`` then scales every coordinate about the base (zones grow with the area).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Layout", "realize", "random_targets", "random_zones", "AREA_HALF_SIDE"]

AREA_HALF_SIDE = 600.0        # m: targets uniform in the 1.2 km square centred on the base (the shipped area)
TARGET_SPACING = 60.0         # m between targets
TARGET_BASE_CLEARANCE = 80.0  # m from the base
ZONE_LENGTH = (70.0, 150.0)   # m, long side of a restricted rectangle
ZONE_WIDTH = (50.0, 110.0)    # m, short side
ZONE_TARGET_CLEARANCE = 35.0  # m from every target
ZONE_BASE_CLEARANCE = 80.0    # m from the base
ZONE_SPACING = 20.0           # m between zones
ZONE_CANDIDATES = 60          # random rectangles the zones are chosen from (those crossing most legs)
MAX_DRAWS = 200_000


@dataclass(frozen=True)
class Layout:
    targets: np.ndarray             # (K, 2) ENU m, map order
    zones: list                     # [{"name": str, "polygon": (M, 2) ENU m}]
    order: tuple                    # order[i]: the pad (ring) or take-off slot (staggered) of UAV i
    layout_id: str                  # "fixed" or "random-<seed>"


def random_targets(rng: np.random.Generator, count: int) -> np.ndarray:
    """``count`` points uniform in the square, TARGET_SPACING apart and TARGET_BASE_CLEARANCE from the base."""
    pts: list[tuple[float, float]] = []
    for _ in range(MAX_DRAWS):
        if len(pts) == count:
            break
        x, y = rng.uniform(-AREA_HALF_SIDE, AREA_HALF_SIDE, 2).tolist()
        if math.hypot(x, y) < TARGET_BASE_CLEARANCE:
            continue
        if all(math.hypot(x - a, y - b) >= TARGET_SPACING for a, b in pts):
            pts.append((x, y))
    if len(pts) < count:
        raise ValueError(f"cannot place {count} targets {TARGET_SPACING:g} m apart in the area")
    return np.array(pts).reshape(-1, 2)


def _tour_legs(targets: np.ndarray) -> list[tuple[tuple, tuple]]:
    """The legs of one UAV's strategy A tour (map order) and strategy B tour (nearest first), base to base."""
    pts = [tuple(p) for p in targets.tolist()]
    legs = []
    a = [(0.0, 0.0), *pts, (0.0, 0.0)]
    legs += list(zip(a[:-1], a[1:]))
    here, left, b = (0.0, 0.0), list(range(len(pts))), [(0.0, 0.0)]
    while left:
        k = min(left, key=lambda j: (math.hypot(pts[j][0] - here[0], pts[j][1] - here[1]), j))
        left.remove(k)
        here = pts[k]
        b.append(here)
    b.append((0.0, 0.0))
    legs += list(zip(b[:-1], b[1:]))
    return legs


def random_zones(rng: np.random.Generator, count: int, targets: np.ndarray) -> list[dict]:
    """``count`` rotated rectangles clear of the targets and the base, chosen among ZONE_CANDIDATES random ones
    by the number of strategy A and B legs they cross (the shipped area's zones were placed on flight legs)."""
    import shapely
    from shapely.geometry import Point, Polygon
    if count == 0:
        return []
    legs = shapely.linestrings(_tour_legs(targets))
    tpts = shapely.points(targets) if len(targets) else None
    cands: list[tuple[int, int, Polygon]] = []
    for draw in range(MAX_DRAWS):
        if len(cands) >= ZONE_CANDIDATES:
            break
        cx, cy = rng.uniform(-AREA_HALF_SIDE, AREA_HALF_SIDE, 2).tolist()
        length, width = rng.uniform(*ZONE_LENGTH), rng.uniform(*ZONE_WIDTH)
        ang = rng.uniform(0.0, math.pi)
        c, s = math.cos(ang), math.sin(ang)
        corners = [(cx + c * u - s * w, cy + s * u + c * w)
                   for u, w in ((-length / 2, -width / 2), (length / 2, -width / 2),
                                (length / 2, width / 2), (-length / 2, width / 2))]
        poly = Polygon(corners)
        if poly.distance(Point(0.0, 0.0)) < ZONE_BASE_CLEARANCE:
            continue
        if tpts is not None and float(shapely.distance(poly, tpts).min()) < ZONE_TARGET_CLEARANCE:
            continue
        cands.append((-int(np.count_nonzero(shapely.intersects(poly, legs))), len(cands), poly))
    chosen: list = []
    for _score, _k, poly in sorted(cands, key=lambda c: (c[0], c[1])):
        if all(poly.distance(q) >= ZONE_SPACING for q in chosen):
            chosen.append(poly)
        if len(chosen) == count:
            break
    if len(chosen) < count:
        raise ValueError(f"cannot place {count} restricted zones clear of the targets and the base")
    return [{"name": f"zone{i + 1}", "polygon": np.round(np.array(p.exterior.coords[:-1]), 3)}
            for i, p in enumerate(chosen)]


@functools.lru_cache(maxsize=64)
def _random_area(seed: int, n_targets: int, n_zones: int) -> tuple:
    """The targets and zones drawn from ``seed`` (read-only arrays): a campaign flies every repetition's area in
    all its cells (any fleet size, strategy, wind), and drawing the zones is most of a run's layout cost."""
    s_targets, s_zones, _ = np.random.SeedSequence(seed).spawn(3)
    targets = np.round(random_targets(np.random.default_rng(s_targets), n_targets), 3)
    zones = random_zones(np.random.default_rng(s_zones), n_zones, targets)
    for a in (targets, *(z["polygon"] for z in zones)):
        a.flags.writeable = False
    return targets, tuple((z["name"], z["polygon"]) for z in zones)


def realize(scn) -> Layout:
    """The layout of a loaded scenario (``uavstudy.scenario.UavScenario``), scaled by its ``area_scale``.
    A random layout's arrays are read-only (shared with later calls); its zones list and dicts are its own."""
    n = int(scn.n_uavs)
    if scn.layout == "random":
        seed = int(scn.layout_seed)
        targets, area_zones = _random_area(seed, len(scn.targets), len(scn.zones))
        zones = [{"name": name, "polygon": polygon} for name, polygon in area_zones]
        order = tuple(int(k) for k in np.random.default_rng(np.random.SeedSequence(seed).spawn(3)[2]).permutation(n))
        layout_id = f"random-{seed}"
    else:
        targets, zones, order, layout_id = scn.targets_enu(), scn.zones_enu(), tuple(range(n)), "fixed"
    f = float(scn.area_scale)
    if f != 1.0:
        targets = targets * f
        zones = [{"name": z["name"], "polygon": z["polygon"] * f} for z in zones]
    return Layout(targets, zones, order, layout_id)
