"""Which targets a UAV photographs, and in which order (the paper's Strategies A and B).

Targets are numbered 0..n-1 in the order they are given (defined on the map).

Assignment, the same computation in every UAV's strategy so that the N lists are a partition:

* ``equal`` (default): contiguous blocks in map order, sizes as equal as possible (the first
  n mod N UAVs get one extra): UAV i gets targets [start_i, start_i + size_i).  With 24 targets and
  1..4 UAVs every UAV gets 24/N targets ("divided equally for each drone", the paper).
* ``roundrobin``: target k goes to UAV k mod N.
* ``spatial``: angular sectors around the base, the ENU origin (0, 0) common to all UAVs: targets
  sorted by the bearing atan2(y, x) in [0, 2 pi) (ties: distance, then index) and split into
  contiguous blocks as in ``equal``; deterministic, no random initialisation.  The centre is the
  same in every UAV's strategy instance (not the UAV's own pad), so the split is a partition.

Visiting order (:func:`next_target`): Strategy A visits its targets in ascending global index (map
order).  Strategy B, each time it needs a new target, scores every remaining target by its horizontal
distance from the current position and takes the lowest score (ties: lowest index).
"""
from __future__ import annotations

import math


def parse_points(text: str) -> list[tuple[float, float]]:
    """Parse "x1,y1;x2,y2;..." into a list of (x, y)."""
    pts = []
    for item in (text or "").replace("\n", ";").split(";"):
        item = item.strip()
        if not item:
            continue
        a, b = item.split(",")[:2]
        pts.append((float(a), float(b)))
    return pts


def as_points(value) -> list[tuple[float, float]]:
    """Targets given as the String form ("x1,y1;...") or as a sequence of (x, y)."""
    if isinstance(value, str):
        return parse_points(value)
    return [(float(x), float(y)) for x, y in value]


def _contiguous_blocks(n: int, count: int) -> list[range]:
    """n items in ``count`` contiguous blocks of sizes as equal as possible (the first n mod count one larger)."""
    base, extra = divmod(n, count)
    out, start = [], 0
    for i in range(count):
        size = base + (1 if i < extra else 0)
        out.append(range(start, start + size))
        start += size
    return out


def assign_targets(targets, uav_index: int, uav_count: int, assignment: str = "equal",
                   home=None, *, center=(0.0, 0.0)) -> list[int]:
    """Global indices of the targets assigned to UAV ``uav_index`` (in ascending index order).

    ``spatial`` sectors are taken around ``center`` (the base, ENU origin), the same for every UAV,
    so that the N lists are a partition of the targets.  ``home`` (the UAV's own pad) is accepted
    for backward compatibility and ignored: sectors about each UAV's pad are not a partition."""
    n = len(targets)
    count = max(1, int(uav_count))
    i = int(uav_index)
    if not 0 <= i < count:
        raise ValueError(f"uav_index {i} outside 0..{count - 1}")
    mode = (assignment or "equal").strip().lower()
    if mode == "equal":
        return list(_contiguous_blocks(n, count)[i])
    if mode == "roundrobin":
        return [k for k in range(n) if k % count == i]
    if mode == "spatial":
        hx, hy = float(center[0]), float(center[1])

        def bearing_then_distance(k):
            x, y = targets[k]
            ang = math.atan2(y - hy, x - hx) % (2.0 * math.pi)
            return (ang, math.hypot(x - hx, y - hy), k)
        order = sorted(range(n), key=bearing_then_distance)
        return sorted(order[j] for j in _contiguous_blocks(n, count)[i])
    raise ValueError(f"unknown assignment {assignment!r} (equal, roundrobin, spatial)")


def next_target(kind: str, remaining: list[int], targets, x: float, y: float) -> int:
    """The target to fly to next from (x, y), or -1 when none remains: Strategy "A" the first remaining (map
    order), Strategy "B" the nearest remaining (ties: the lowest index)."""
    if not remaining:
        return -1
    if kind == "A":
        return remaining[0]
    return min(remaining, key=lambda k: (math.hypot(targets[k][0] - x, targets[k][1] - y), k))
