"""Restricted zones: their geometry, the segment tests a UAV makes each step, and the paths planned around them.

Two ways of going around a zone, chosen by the strategy's ``zone_planning`` (see uavsim/strategy.py):

* planned legs (``ZoneMap.plan``, ``ZonePlanner``): the shortest path keeping a clearance from every zone in a
  visibility graph of the zones' vertices offset outward by that clearance;
* the paper's reactive detour (``ZoneMap.detour``): the same kind of graph around the zones offset by the avoid
  margin, searched only when a look-ahead segment hits a zone.

``zone_record`` packs a zone for the compiled step (uavsim/_strategy_ext.c), which only ever proves a segment
clear of every zone and leaves every other case to ``ZoneMap.blocked``.
"""
from __future__ import annotations

import heapq
import math
import sys

from . import params as P
from .assignment import as_points, parse_points


def parse_zones(text: str) -> list[list[tuple[float, float]]]:
    """Parse polygons "x,y;x,y;x,y|x,y;..." into lists of vertices."""
    return [pts for pts in (parse_points(p) for p in (text or "").split("|")) if len(pts) >= 3]


def as_zones(value) -> list[list[tuple[float, float]]]:
    """Zones given as the String form ("x,y;...|...") or as a sequence of vertex sequences."""
    if isinstance(value, str):
        return parse_zones(value)
    return [as_points(polygon) for polygon in value]


def _segment_point_distance(ax, ay, bx, by, px, py) -> float:
    """Distance from point p to the segment a-b."""
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    if dd <= 0.0:
        return math.hypot(px - ax, py - ay)
    u = ((px - ax) * dx + (py - ay) * dy) / dd
    u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
    return math.hypot(px - ax - u * dx, py - ay - u * dy)


def _first_unreferenced(maps: list):
    """The first of ``maps`` that nothing but the list refers to, or None."""
    for i in range(len(maps)):
        if sys.getrefcount(maps[i]) == 2:       # the list's reference and getrefcount's argument
            return maps[i]
    return None


def _zone_key(zones, margin) -> tuple:
    """The zones and margin by their exact bits (``float.hex``: -0.0 and 0.0 stay apart), as a cache key."""
    return (float(margin).hex(), tuple(tuple((float(x).hex(), float(y).hex()) for x, y in z) for z in zones))


class ZoneMap:
    """Restricted zones (shapely polygons): segment tests and the paper's reactive detours.

    ``ZoneMap(zones, margin)`` reuses a map of the same zones (to the bit) and margin that no one holds any
    more: a campaign worker flies the same areas run after run, and a map's polygons, detour graph and planners
    (``planner``: a visibility graph per clearance) are functions of the zones and margin alone, built when
    first needed and never changed after.  A map in use is never handed out again (the strategies of one run
    each build their own), so no two strategies query one map's prepared geometries at once (threaded steps);
    the FMU state of a strategy (a deep copy) keeps its map."""

    _BUILT: dict[tuple, list] = {}       # zones and margin -> the maps built for them
    _MAX_BUILT = 64                       # zone sets kept
    _MAX_MAPS = 64                        # maps kept per zone set (a fleet's strategies each hold one)

    def __new__(cls, zones=None, margin: float = P.AVOID_MARGIN):
        if zones is None:       # a copy or an unpickled map: its attributes follow
            return super().__new__(cls)
        zones = [list(z) for z in zones]
        key = (cls, _zone_key(zones, margin))
        maps = ZoneMap._BUILT.get(key)
        if maps is None:
            if len(ZoneMap._BUILT) >= ZoneMap._MAX_BUILT:
                ZoneMap._BUILT.clear()
            maps = ZoneMap._BUILT[key] = []
        free = _first_unreferenced(maps)
        if free is not None:
            return free
        built = super().__new__(cls)
        built._build(zones, margin)
        if len(maps) < ZoneMap._MAX_MAPS:
            maps.append(built)
        return built

    def __init__(self, zones=None, margin: float = P.AVOID_MARGIN):
        pass            # built (or reused) by __new__

    def __deepcopy__(self, memo):
        return self     # never changed after it is built (its prepared geometries could not be copied anyway)

    def _build(self, zones, margin):
        import shapely
        from shapely.geometry import Polygon
        from shapely.prepared import prep
        self.polys = [Polygon(z).buffer(0) for z in zones]
        self.margin = margin
        self._inner = [p.buffer(-1e-6) for p in self.polys]
        self._prep = [prep(p) for p in self._inner]
        # bounding circles (centre, radius) of the zones: a cheap pure-Python pre-filter, so the
        # per-step tests call shapely only near a zone
        self._circles = []
        for p in self.polys:
            c = p.centroid
            r = max((math.hypot(x - c.x, y - c.y) for x, y in shapely.get_coordinates(p).tolist()),
                    default=0.0)
            self._circles.append((c.x, c.y, r + 1e-6))
        # the squares about those circles: a segment whose bounding box misses a square misses its circle and
        # zone, which four comparisons tell (the circle's distance test is a function call)
        self._tests = [(cx - r, cy - r, cx + r, cy + r, cx, cy, r) for cx, cy, r in self._circles]
        self._all = [(-math.inf, -math.inf, math.inf, math.inf, cx, cy, r) for cx, cy, r in self._circles]
        # the box about all those squares: most segments a UAV tests lie outside it, which four comparisons tell
        # without the loop over the zones
        self._box = (min(t[0] for t in self._tests), min(t[1] for t in self._tests),
                     max(t[2] for t in self._tests), max(t[3] for t in self._tests)) if self._tests else None
        self._detour_graph_built = None  # lazily built visibility graph of the paper's reactive detour
        self._planners: dict[float, ZonePlanner] = {}

    def __bool__(self):
        return bool(self.polys)

    def records(self) -> list[float]:
        """Every zone's record for the compiled fast path (``zone_record``), made once per map (its polygons never
        change): each strategy that flies these zones again would make the same list."""
        made = self.__dict__.get("_records")
        if made is None:
            made = self._records = [v for poly in self.polys for v in zone_record(poly)]
        return made

    def blocked(self, a, b) -> int:
        """Index of the first zone whose interior the segment a-b crosses, or -1."""
        ax, ay = float(a[0]), float(a[1])
        bx, by = float(b[0]), float(b[1])
        geom = None
        if ax - ax + ay - ay + bx - bx + by - by == 0.0:       # finite end points: the squares first
            lox, hix = (ax, bx) if ax <= bx else (bx, ax)
            loy, hiy = (ay, by) if ay <= by else (by, ay)
            box = self._box
            if box is None or hix < box[0] or lox > box[2] or hiy < box[1] or loy > box[3]:
                return -1
            tests = self._tests
        else:                 # (a NaN or infinite end point goes through the distance test as it always did)
            lox = hix = loy = hiy = 0.0
            tests = self._all
        for i, (x0, y0, x1, y1, cx, cy, r) in enumerate(tests):
            if hix < x0 or lox > x1 or hiy < y0 or loy > y1 or _segment_point_distance(ax, ay, bx, by, cx, cy) > r:
                continue                      # the segment cannot reach this zone
            if geom is None:
                from shapely.geometry import LineString, Point
                geom = Point(ax, ay) if math.hypot(bx - ax, by - ay) < 1e-9 else LineString([(ax, ay), (bx, by)])
            if self._prep[i].intersects(geom):
                return i
        return -1

    def inside(self, a) -> bool:
        from shapely.geometry import Point
        pt = Point(a)
        return any(pp.contains(pt) for pp in self._prep)

    # ------------------------------------------------------------------ planning (zone_planning)
    def planner(self, margin: float) -> "ZonePlanner":
        key = round(float(margin), 9)
        if key not in self._planners:
            self._planners[key] = ZonePlanner(self.polys, key)
        return self._planners[key]

    def plan(self, start, goal, margin: float, levels: int = 5) -> list[tuple[float, float]] | None:
        """Planned path start -> goal keeping ``margin`` (see ZonePlanner.plan); if there is none,
        the margin is halved up to ``levels - 1`` times.  None when no margin gives a path."""
        m = float(margin)
        for _ in range(max(1, levels)):
            path = self.planner(m).plan(start, goal)
            if path is not None:
                return path
            m *= 0.5
        return None

    # ------------------------------------------------------------------ the paper's reactive detour
    def _detour_graph(self):
        if self._detour_graph_built is None:
            from shapely.prepared import prep
            # planning obstacles: zones inflated by half the margin, so detour legs keep clearance
            infl = [prep(p.buffer(0.5 * self.margin)) for p in self.polys]
            nodes = []
            for p in self.polys:
                off = p.buffer(self.margin, join_style=2, mitre_limit=3.0)
                geoms = getattr(off, "geoms", [off])
                for g in geoms:
                    nodes.extend(list(g.exterior.coords)[:-1])
            self._detour_graph_built = (infl, nodes)
        return self._detour_graph_built

    def _edge_free(self, a, b, a_near: bool, b_near: bool) -> bool:
        """Planning test: the edge must avoid the inflated zones, except that an end point already
        within the inflation (the UAV's position, a target close to a zone) is only required to
        avoid the zone itself."""
        from shapely.geometry import LineString
        if self.blocked(a, b) >= 0:
            return False
        if a_near or b_near:
            return True
        line = LineString([a, b])
        return not any(pp.intersects(line) for pp in self._detour_graph()[0])

    def _near(self, a) -> bool:
        from shapely.geometry import Point
        pt = Point(a)
        return any(pp.intersects(pt) for pp in self._detour_graph()[0])

    def detour(self, start, goal) -> list[tuple[float, float]] | None:
        """The paper's reactive fly-around (zone_planning false): shortest visibility-graph path
        start -> goal around the zones offset by ``margin`` (list of waypoints after start, ending
        with goal), or None when there is none."""
        if self.blocked(start, goal) < 0:
            return [tuple(goal)]
        nodes = [tuple(start), tuple(goal)] + [n for n in self._detour_graph()[1] if not self.inside(n)]
        nn = len(nodes)
        near = [self._near(n) for n in nodes]
        dist = [math.inf] * nn
        prev = [-1] * nn
        dist[0] = 0.0
        heap = [(0.0, 0)]
        done = [False] * nn
        while heap:
            d, u = heapq.heappop(heap)
            if done[u]:
                continue
            done[u] = True
            if u == 1:
                break
            for v in range(1, nn):
                if done[v]:
                    continue
                w = math.hypot(nodes[v][0] - nodes[u][0], nodes[v][1] - nodes[u][1])
                if d + w >= dist[v]:
                    continue
                if not self._edge_free(nodes[u], nodes[v], near[u], near[v]):
                    continue
                dist[v] = d + w
                prev[v] = u
                heapq.heappush(heap, (dist[v], v))
        if not math.isfinite(dist[1]):
            return None
        path, u = [], 1
        while u != 0:
            path.append(nodes[u])
            u = prev[u]
        return path[::-1]


class ZonePlanner:
    """Shortest paths keeping a clearance ``margin`` from the zones (visibility graph).

    Nodes: the vertices of every zone offset outward by ``margin`` (mitred, mitre limit 2), minus
    those closer than the margin to another zone.  Node-to-node edges must keep the full margin
    (the edges between neighbouring offset vertices of one zone run at exactly the margin, so the
    test allows ``TOL``).  An edge from the start or to the goal, whose clearance c may be below the
    margin, must keep min(margin, ENDPOINT_FACTOR c): a UAV close to a zone moves away from it, and
    a target close to a zone is approached with the clearance it has.  Node-node edges are computed
    once; a query adds the start's and goal's edges and runs Dijkstra.
    """
    TOL = 0.99
    ENDPOINT_FACTOR = 0.9

    def __init__(self, polys, margin: float):
        import numpy as np
        import shapely
        from shapely.ops import unary_union
        self.margin = float(margin)
        self.union = unary_union(polys) if polys else None
        if self.union is not None:
            shapely.prepare(self.union)
        raw = []
        for p in polys:
            off = p.buffer(self.margin, join_style="mitre", mitre_limit=2.0)
            for g in getattr(off, "geoms", [off]):
                raw.extend(g.exterior.coords[:-1])
        nodes: list[tuple[float, float]] = []
        if raw:
            arr = np.asarray(raw, dtype=float)
            clr = shapely.distance(shapely.points(arr), self.union)
            seen = set()
            for (x, y), c in zip(arr.tolist(), clr.tolist()):
                key = (round(x, 6), round(y, 6))
                if c >= self.margin * self.TOL and key not in seen:
                    seen.add(key)
                    nodes.append((x, y))
        self.nodes = nodes
        self._arr = np.asarray(nodes, dtype=float).reshape(-1, 2)
        n = len(nodes)
        self.adj: list[list[tuple[int, float]]] = [[] for _ in range(n)]
        if n >= 2:
            ii, jj = np.triu_indices(n, 1)
            segs = np.stack([self._arr[ii], self._arr[jj]], axis=1)
            ok = shapely.distance(shapely.linestrings(segs), self.union) >= self.margin * self.TOL
            for i, j in zip(ii[ok].tolist(), jj[ok].tolist()):
                w = math.hypot(nodes[i][0] - nodes[j][0], nodes[i][1] - nodes[j][1])
                self.adj[i].append((j, w))
                self.adj[j].append((i, w))

    def clearance(self, pt) -> float:
        """Distance from pt to the nearest zone (0 inside or on the boundary)."""
        if self.union is None:
            return math.inf
        from shapely.geometry import Point
        return float(self.union.distance(Point(float(pt[0]), float(pt[1]))))

    def _seg_clearance(self, a, b) -> float:
        from shapely.geometry import LineString
        return float(self.union.distance(LineString([a, b])))

    def _edges_from(self, pt, need: float) -> list[tuple[int, float]]:
        """(node, length) of the nodes visible from pt with clearance >= need."""
        import numpy as np
        import shapely
        n = len(self.nodes)
        if n == 0:
            return []
        segs = np.empty((n, 2, 2))
        segs[:, 0, 0], segs[:, 0, 1] = pt[0], pt[1]
        segs[:, 1, :] = self._arr
        ok = shapely.distance(shapely.linestrings(segs), self.union) >= need * self.TOL
        return [(j, math.hypot(self.nodes[j][0] - pt[0], self.nodes[j][1] - pt[1]))
                for j in np.flatnonzero(ok).tolist()]

    def plan(self, start, goal) -> list[tuple[float, float]] | None:
        """Shortest path start -> goal as the waypoints after start (ending with goal), or None when
        there is none (or the start or goal is inside a zone)."""
        start = (float(start[0]), float(start[1]))
        goal = (float(goal[0]), float(goal[1]))
        if self.union is None:
            return [goal]
        cs, cg = self.clearance(start), self.clearance(goal)
        if cs <= 0.0 or cg <= 0.0:
            return None
        ms = min(self.margin, self.ENDPOINT_FACTOR * cs)
        mg = min(self.margin, self.ENDPOINT_FACTOR * cg)
        if math.hypot(goal[0] - start[0], goal[1] - start[1]) < 1e-9 or \
                self._seg_clearance(start, goal) >= min(ms, mg) * self.TOL:
            return [goal]
        n = len(self.nodes)
        to_goal = dict(self._edges_from(goal, mg))
        if not to_goal:
            return None
        # Dijkstra: nodes 0..n-1, start = n, goal = n + 1
        S, G = n, n + 1
        dist = [math.inf] * (n + 2)
        prev = [-1] * (n + 2)
        dist[S] = 0.0
        heap = [(0.0, S)]
        while heap:
            d, u = heapq.heappop(heap)
            if d > dist[u]:
                continue
            if u == G:
                break
            if u == S:
                edges = self._edges_from(start, ms)
            else:
                edges = self.adj[u]
                if u in to_goal:
                    edges = edges + [(G, to_goal[u])]
            for v, w in edges:
                nd = d + w
                if nd < dist[v]:
                    dist[v] = nd
                    prev[v] = u
                    heapq.heappush(heap, (nd, v))
        if not math.isfinite(dist[G]):
            return None
        path, u = [goal], prev[G]
        while u != S:
            path.append(self.nodes[u])
            u = prev[u]
        return path[::-1]


def zone_record(poly) -> list[float]:
    """A zone for the compiled fast path (uavsim/_strategy_ext.c): its bounding box, its edge count and the edges
    (x0, y0, x1, y1) of all its rings, which it uses to tell that a segment stays clear of the zone.  An empty zone
    (which blocks nothing) gets a box nothing meets; a geometry other than (multi)polygons, edge count -1 (the
    box only)."""
    if poly.is_empty:
        return [math.inf, math.inf, -math.inf, -math.inf, 0.0]
    rings = []
    for part in getattr(poly, "geoms", [poly]):
        if part.geom_type != "Polygon":
            return [*poly.bounds, -1.0]
        rings.append(part.exterior.coords)
        rings.extend(hole.coords for hole in part.interiors)
    edges = [(x0, y0, x1, y1) for ring in rings for (x0, y0), (x1, y1) in zip(ring, ring[1:])
             if (x0, y0) != (x1, y1)]
    return [*poly.bounds, float(len(edges)), *(v for e in edges for v in e)]
