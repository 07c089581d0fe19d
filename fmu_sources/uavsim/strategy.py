"""Mission logic of one UAV: target assignment, Strategy A / B, photos, battery rules, zone fly-around.

Target assignment (targets are numbered 0..n-1 in the order they are given = defined on the map):

* ``equal`` (default): contiguous blocks in map order, sizes as equal as possible (the first
  n mod N UAVs get one extra): UAV i gets targets [start_i, start_i + size_i).  With 24 targets and
  1..4 UAVs every UAV gets 24/N targets ("divided equally for each drone", the paper).
* ``roundrobin``: target k goes to UAV k mod N.
* ``spatial``: angular sectors around the base, the ENU origin (0, 0) common to all UAVs: targets
  sorted by the bearing atan2(y, x) in [0, 2 pi) (ties: distance, then index) and split into
  contiguous blocks as in ``equal``; deterministic, no random initialisation.  The centre is the
  same in every UAV's strategy instance (not the UAV's own pad), so the split is a partition.

Visiting order: Strategy A visits its targets in ascending global index (map order).  Strategy B,
each time it needs a new target, scores every remaining target by its horizontal distance from
the current position and takes the lowest score (ties: lowest index).

Battery rules (the paper): consumed >= return_threshold (0.8) -> abandon the mission and return to
base; consumed >= land_threshold (0.95) -> land immediately where the UAV is.

Restricted zones, ``zone_planning`` true (default): every leg (to a target, or home to the pad) is
planned when it starts (i.e. whenever the goal changes): the shortest path from the position to the
goal in a visibility graph whose nodes are the vertices of the zones offset outward by the margin
m = ``plan_margin`` + ``lane_spacing`` * uav_index (plan_margin 20 m = V^2/(2 A), the braking
distance at cruise speed; 5 m lanes, so that UAVs going round the same corner do not converge on
one vertex; mitred) and whose edges keep at least m from every zone.  An edge that starts or ends
at a point with a smaller clearance c (the UAV itself, a target close to a zone) needs only min(m, 0.9 c),
so such a target is approached along the shortest free path with a reduced margin; if there is
no path the margin is halved (down to 1/16) before giving up (then straight to the goal).  The path
vertices are flown as intermediate waypoints (accepted within arrival_radius).  Last-resort safety
net (wind drift): each step the segment from the position along the velocity (groundspeed >
0.5 m/s) of length min(lookahead + v^2/(2 brake_accel), distance to the waypoint) is tested
against the zones; on a hit the UAV brakes (setpoint = where it is) until its groundspeed is below
0.5 m/s, then re-plans from there.  The leg is also re-planned when the straight line to the next
waypoint crosses a zone.

Restricted zones, ``zone_planning`` false (the paper's late detection, collision-prone): every step
two segments of length ``lookahead`` from the current position are tested against the zone
polygons: one along the current flight direction (the velocity direction, when the groundspeed
exceeds 0.5 m/s) and one toward the current goal (the commanded leg).  On a hit the UAV plans a
fly-around: the shortest path from its position to the goal in the visibility graph whose nodes are
the vertices of every zone offset outward by ``avoid_margin`` (mitred buffer), and whose edges
keep at least avoid_margin/2 from every zone (an edge from the UAV's position, or to a goal, that
lies closer than that only has to avoid the zone itself).  Going around the side where the path is shorter is thus
automatic.  The detour vertices are flown as intermediate waypoints (accepted within
arrival_radius); while detouring, a re-plan happens only if the leg to the next detour vertex is
itself blocked.  If no path exists (e.g. the UAV is already inside a zone) it flies straight on.

mission_state codes:
  0 PREFLIGHT      waiting for the vehicle (phase 0), cmd = 1 (takeoff request)
  1 TAKEOFF        climbing (phase 1), cmd = 1
  2 TRANSIT        flying to the current target, cmd = 2
  3 RETURN_DONE    all assigned targets visited, flying back to base, cmd = 2
  4 RETURN_LOW     consumed >= return_threshold, mission abandoned, flying to base, cmd = 2
  5 LAND_BASE      over the base, landing, cmd = 3
  6 LAND_NOW       consumed >= land_threshold away from base: immediate landing, cmd = 3
  7 LANDED_BASE    on the ground at the base (final)
  8 LANDED_AWAY    on the ground away from the base (final; forced landing)
  9 RETURN_CMD     a ground station commanded the return to base (``command``), cmd = 2
 10 LAND_CMD       a ground station commanded a landing where the UAV is (``command``), cmd = 3

Ground-station commands (``Strategy.command``; the FMU's Integer input ``command``: 0 none, 1 return to
base, 2 land) are taken when the input changes; the strategy stays the one owner of the mission logic:
a return is accepted while flying a mission leg (TRANSIT, RETURN_DONE), a landing while airborne and
not landing yet; otherwise the command is ignored (the ground station sees the state unchanged).
"""
from __future__ import annotations

import heapq
import math
import sys
from dataclasses import dataclass, field

from . import params as P

PREFLIGHT, TAKEOFF, TRANSIT, RETURN_DONE, RETURN_LOW, LAND_BASE, LAND_NOW, LANDED_BASE, LANDED_AWAY = range(9)
RETURN_CMD, LAND_CMD = 9, 10
STATE_NAMES = ["PREFLIGHT", "TAKEOFF", "TRANSIT", "RETURN_DONE", "RETURN_LOW", "LAND_BASE",
               "LAND_NOW", "LANDED_BASE", "LANDED_AWAY", "RETURN_CMD", "LAND_CMD"]
#: values of the ``command`` input
COMMAND_NONE, COMMAND_RETURN, COMMAND_LAND = 0, 1, 2


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


def parse_zones(text: str) -> list[list[tuple[float, float]]]:
    """Parse polygons "x,y;x,y;x,y|x,y;..." into lists of vertices."""
    return [pts for pts in (parse_points(p) for p in (text or "").split("|")) if len(pts) >= 3]


def as_points(value) -> list[tuple[float, float]]:
    """Targets given as the String form ("x1,y1;...") or as a sequence of (x, y)."""
    if isinstance(value, str):
        return parse_points(value)
    return [(float(x), float(y)) for x, y in value]


def as_zones(value) -> list[list[tuple[float, float]]]:
    """Zones given as the String form ("x,y;...|...") or as a sequence of vertex sequences."""
    if isinstance(value, str):
        return parse_zones(value)
    return [as_points(polygon) for polygon in value]


def _blocks(n: int, count: int) -> list[range]:
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
        return list(_blocks(n, count)[i])
    if mode == "roundrobin":
        return [k for k in range(n) if k % count == i]
    if mode == "spatial":
        hx, hy = float(center[0]), float(center[1])

        def key(k):
            x, y = targets[k]
            ang = math.atan2(y - hy, x - hx) % (2.0 * math.pi)
            return (ang, math.hypot(x - hx, y - hy), k)
        order = sorted(range(n), key=key)
        return sorted(order[j] for j in _blocks(n, count)[i])
    raise ValueError(f"unknown assignment {assignment!r} (equal, roundrobin, spatial)")


# ---------------------------------------------------------------------- zone geometry
def _seg_point_dist(ax, ay, bx, by, px, py) -> float:
    """Distance from point p to the segment a-b."""
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    if dd <= 0.0:
        return math.hypot(px - ax, py - ay)
    u = ((px - ax) * dx + (py - ay) * dy) / dd
    u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
    return math.hypot(px - ax - u * dx, py - ay - u * dy)


def _unheld(maps: list):
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
        free = _unheld(maps)
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
        self._paper = None        # lazily built visibility graph of the paper's reactive detour
        self._planners: dict[float, ZonePlanner] = {}

    def __bool__(self):
        return bool(self.polys)

    def records(self) -> list[float]:
        """Every zone's record for the compiled fast path (``_zone_record``), made once per map (its polygons never
        change): each strategy that flies these zones again would make the same list."""
        made = self.__dict__.get("_records")
        if made is None:
            made = self._records = [v for poly in self.polys for v in _zone_record(poly)]
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
            if hix < x0 or lox > x1 or hiy < y0 or loy > y1 or _seg_point_dist(ax, ay, bx, by, cx, cy) > r:
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
    def _paper_graph(self):
        if self._paper is None:
            from shapely.prepared import prep
            # planning obstacles: zones inflated by half the margin, so detour legs keep clearance
            infl = [prep(p.buffer(0.5 * self.margin)) for p in self.polys]
            nodes = []
            for p in self.polys:
                off = p.buffer(self.margin, join_style=2, mitre_limit=3.0)
                geoms = getattr(off, "geoms", [off])
                for g in geoms:
                    nodes.extend(list(g.exterior.coords)[:-1])
            self._paper = (infl, nodes)
        return self._paper

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
        return not any(pp.intersects(line) for pp in self._paper_graph()[0])

    def _near(self, a) -> bool:
        from shapely.geometry import Point
        pt = Point(a)
        return any(pp.intersects(pt) for pp in self._paper_graph()[0])

    def detour(self, start, goal) -> list[tuple[float, float]] | None:
        """The paper's reactive fly-around (zone_planning false): shortest visibility-graph path
        start -> goal around the zones offset by ``margin`` (list of waypoints after start, ending
        with goal), or None when there is none."""
        if self.blocked(start, goal) < 0:
            return [tuple(goal)]
        nodes = [tuple(start), tuple(goal)] + [n for n in self._paper_graph()[1] if not self.inside(n)]
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


# ---------------------------------------------------------------------- mission logic
@dataclass
class StrategyParams:
    strategy: str = "A"
    uav_index: int = 0
    uav_count: int = 1
    assignment: str = "equal"
    targets: str | list = ""                    # String form or [(x, y), ...]
    zones: str | list = ""                      # String form or [[(x, y), ...], ...]
    lookahead: float = P.LOOKAHEAD              # m
    home_x: float = 0.0                         # m
    home_y: float = 0.0                         # m
    cruise_altitude: float = P.CRUISE_ALTITUDE  # m
    return_threshold: float = P.RETURN_THRESHOLD  # 1
    land_threshold: float = P.LAND_THRESHOLD    # 1
    arrival_radius: float = P.ARRIVAL_RADIUS    # m
    avoid_margin: float = P.AVOID_MARGIN        # m (paper's reactive detour)
    zone_planning: bool = True                  # plan every leg around the zones
    plan_margin: float = P.PLAN_MARGIN          # m clearance of planned legs
    lane_spacing: float = P.LANE_SPACING        # m extra clearance per UAV index (lanes)
    brake_accel: float = P.WP_ACCEL             # m/s^2 deceleration for the safety-net look-ahead


class Strategy:
    def __init__(self, params: StrategyParams | None = None):
        self.p = params or StrategyParams()
        s = self.p.strategy.strip().upper()
        if s not in ("A", "B"):
            raise ValueError(f"strategy must be 'A' or 'B', got {self.p.strategy!r}")
        self.kind = s
        self.targets = as_points(self.p.targets)
        self.home = (float(self.p.home_x), float(self.p.home_y))
        self.assigned = assign_targets(self.targets, self.p.uav_index, self.p.uav_count,
                                       self.p.assignment, self.home)
        self.remaining = list(self.assigned)
        self.zones = ZoneMap(as_zones(self.p.zones), self.p.avoid_margin)
        self.state = PREFLIGHT
        self.cmd = 1
        self.sp = (self.home[0], self.home[1], float(self.p.cruise_altitude))
        self.current_target = -1
        self.visited: list[int] = []
        self.photo_count = 0
        self.last_photo_target = -1
        self.last_photo_time = 0.0
        self.last_photo_x = 0.0
        self.last_photo_y = 0.0
        self.photos: list[tuple[int, float, float, float]] = []   # (target, t, x, y)
        self.detour: list[tuple[float, float]] = []
        self.avoid_count = 0
        self.land_point = None
        # zone_planning state: planned path (waypoints ending with the goal), the goal it was
        # planned for, safety-net braking
        self.planning = bool(self.p.zone_planning)
        # each UAV plans on its own "lane": clearance plan_margin + lane_spacing * uav_index, so
        # UAVs detouring around the same zone corner do not converge on one waypoint
        self.margin = float(self.p.plan_margin) + float(self.p.lane_spacing) * max(0, int(self.p.uav_index))
        self.path: list[tuple[float, float]] = []
        self.path_goal = None
        self.plan_count = 0          # legs planned (with or without detour vertices)
        self.brake_count = 0         # safety-net activations
        self.braking = False
        self.brake_point = (0.0, 0.0)
        self._fast_consts = self._native_consts()

    def _native_consts(self) -> bytes | None:
        """The constants of the compiled fast path of the FMU's step (uavsim/_strategy_ext.c, layout C_*): arrival
        radius, land and return thresholds, look-ahead, brake deceleration (as _planned bounds it), cruise
        altitude, base, planning flag, zone count, then each zone's record (_zone_record).  None (no fast path)
        when a value is not a number."""
        from array import array
        p = self.p
        try:
            values = [p.arrival_radius, p.land_threshold, p.return_threshold, p.lookahead,
                      max(p.brake_accel, 1e-6), p.cruise_altitude, self.home[0], self.home[1],
                      1.0 if self.planning else 0.0, len(self.zones.polys)]
            records = self.zones.records()
            return array("d", [float(v) for v in values] + records).tobytes()
        except (AttributeError, TypeError, ValueError):
            return None

    # -------------------------------------------------------------- helpers
    @property
    def avoiding(self) -> bool:
        if self.planning:
            return self.braking or len(self.path) > 1
        return bool(self.detour)

    @property
    def targets_assigned(self) -> int:
        return len(self.assigned)

    @property
    def targets_visited(self) -> int:
        return len(self.visited)

    def outputs(self) -> tuple:
        """What an FMU publishes, in one call: cmd, setpoint x, y, z, state, targets assigned and visited,
        photo count, last photo target, current target, avoiding (0/1), avoid count, last photo time, x, y."""
        sp = self.sp
        if self.planning:
            avoiding = 1 if self.braking or len(self.path) > 1 else 0
        else:
            avoiding = 1 if self.detour else 0
        return (int(self.cmd), sp[0], sp[1], sp[2], int(self.state), len(self.assigned), len(self.visited),
                self.photo_count, self.last_photo_target, self.current_target, avoiding, self.avoid_count,
                self.last_photo_time, self.last_photo_x, self.last_photo_y)

    def _goal(self):
        if self.state == TRANSIT and self.current_target >= 0:
            return self.targets[self.current_target]
        return self.home

    def _pick_next(self, x, y):
        if not self.remaining:
            self.current_target = -1
            return
        if self.kind == "A":
            self.current_target = self.remaining[0]
        else:
            self.current_target = min(self.remaining, key=lambda k: (
                math.hypot(self.targets[k][0] - x, self.targets[k][1] - y), k))

    def _start_leg(self, x, y):
        self.detour = []
        if self.state == TRANSIT:
            self._pick_next(x, y)
            if self.current_target < 0:
                self.state = RETURN_DONE

    def _avoidance(self, x, y, vx, vy):
        """Zone handling; returns the horizontal waypoint to fly to."""
        goal = self._goal()
        if not self.zones:
            return goal
        if self.planning:
            return self._planned(x, y, vx, vy, goal)
        return self._reactive(x, y, vx, vy, goal)

    # ---- zone_planning true: plan each leg, safety net against drift
    def _replan(self, x, y, goal):
        self.path_goal = goal
        path = self.zones.plan((x, y), goal, self.margin)
        self.path = list(path) if path else [tuple(goal)]
        self.plan_count += 1
        if len(self.path) > 1:
            self.avoid_count += 1

    def _planned(self, x, y, vx, vy, goal):
        if goal != self.path_goal:                 # a new leg: plan it
            self.braking = False
            self._replan(x, y, goal)
        gs = math.hypot(vx, vy)
        if self.braking:
            if gs > 0.5:
                return self.brake_point
            self.braking = False                   # stopped: go around from here
            self._replan(x, y, goal)
        path, r = self.path, self.p.arrival_radius
        while len(path) > 1 and math.hypot(path[0][0] - x, path[0][1] - y) <= r:
            path.pop(0)
        wx, wy = path[0]
        if gs > 0.5:
            # last-resort safety net: where the UAV is going (along its velocity) within its
            # stopping distance plus the look-ahead, but not beyond the waypoint it stops at
            la = min(self.p.lookahead + gs * gs / (2.0 * max(self.p.brake_accel, 1e-6)),
                     math.hypot(wx - x, wy - y))
            if la > 1e-9 and self.zones.blocked((x, y), (x + la * vx / gs, y + la * vy / gs)) >= 0:
                self.braking = True
                self.brake_point = (float(x), float(y))
                self.brake_count += 1
                self.avoid_count += 1
                return self.brake_point
        if self.zones.blocked((x, y), (wx, wy)) >= 0:   # drifted: the way to the waypoint is blocked
            self._replan(x, y, goal)
        return self.path[0]

    # ---- zone_planning false: the paper's late detection
    def _reactive(self, x, y, vx, vy, goal):
        r = self.p.arrival_radius
        # advance along a detour
        while self.detour and len(self.detour) > 1 and \
                math.hypot(self.detour[0][0] - x, self.detour[0][1] - y) <= r:
            self.detour.pop(0)
        if self.detour and len(self.detour) == 1:
            self.detour = []          # only the goal is left: normal flight
        if self.detour:
            wp = self.detour[0]
            if self.zones.blocked((x, y), wp) >= 0:
                self._plan(x, y, goal)
            return self.detour[0] if self.detour else goal
        # look-ahead along the flight direction
        gs = math.hypot(vx, vy)
        if gs > 0.5:
            ux, uy = vx / gs, vy / gs
        else:
            dx, dy = goal[0] - x, goal[1] - y
            dd = math.hypot(dx, dy)
            if dd < 1e-9:
                return goal
            ux, uy = dx / dd, dy / dd
        la = self.p.lookahead
        if self.zones.blocked((x, y), (x + la * ux, y + la * uy)) >= 0 or \
                self.zones.blocked((x, y), self._towards(x, y, goal, la)) >= 0:
            self._plan(x, y, goal)
        return self.detour[0] if self.detour else goal

    @staticmethod
    def _towards(x, y, goal, dist):
        dx, dy = goal[0] - x, goal[1] - y
        dd = math.hypot(dx, dy)
        if dd <= dist or dd < 1e-9:
            return goal
        return (x + dist * dx / dd, y + dist * dy / dd)

    def _plan(self, x, y, goal):
        path = self.zones.detour((x, y), goal)
        if path is None or len(path) <= 1:
            self.detour = []
        else:
            self.detour = list(path)
            self.avoid_count += 1

    # -------------------------------------------------------------- ground-station commands
    def command(self, code: int, x: float, y: float, z: float) -> bool:
        """A command from outside (see the module docstring); True when it changed the mission state."""
        if code == COMMAND_RETURN and self.state in (TRANSIT, RETURN_DONE):
            self.state, self.current_target, self.detour = RETURN_CMD, -1, []
            return True
        if code == COMMAND_LAND and self.state in (TRANSIT, RETURN_DONE, RETURN_LOW, RETURN_CMD):
            self.state, self.detour, self.cmd, self.sp = LAND_CMD, [], 3, (x, y, z)
            return True
        return False

    # -------------------------------------------------------------- main step
    def step(self, t: float, x: float, y: float, z: float, vx: float, vy: float,
             phase: int, consumed: float) -> None:
        """Evaluate the mission logic on the inputs sampled at time t and set the outputs."""
        p = self.p
        phase = int(phase)
        airborne_states = (TRANSIT, RETURN_DONE, RETURN_LOW, RETURN_CMD)
        at_base = math.hypot(x - self.home[0], y - self.home[1]) <= p.arrival_radius

        # ---- terminal / landing states
        if self.state in (LAND_BASE, LAND_NOW, LAND_CMD):
            if phase == 4:
                self.state = LANDED_BASE if at_base else LANDED_AWAY
        if self.state in (LANDED_BASE, LANDED_AWAY):
            self.cmd = 3
            return
        if self.state in (LAND_BASE, LAND_NOW, LAND_CMD):
            self.cmd = 3
            return

        # ---- battery rules (only when airborne)
        if phase in (1, 2, 3):
            if consumed >= p.land_threshold:
                self.state = LAND_NOW if not at_base else LAND_BASE
                self.detour = []
                self.cmd = 3
                self.sp = (x, y, z)
                return
            if consumed >= p.return_threshold and self.state in (TAKEOFF, TRANSIT, RETURN_DONE):
                if self.state != RETURN_DONE:
                    self.state = RETURN_LOW
                    self.current_target = -1
                    self.detour = []

        # ---- takeoff
        if self.state == PREFLIGHT:
            self.cmd = 1
            if phase == 1:
                self.state = TAKEOFF
            elif phase == 2:
                self.state = TAKEOFF
            else:
                return
        if self.state == TAKEOFF:
            self.cmd = 1
            if phase != 2:
                return
            self.state = TRANSIT
            self._start_leg(x, y)
        if phase == 4 and self.state in airborne_states:
            # the vehicle landed on its own (should not happen): treat as final
            self.state = LANDED_BASE if at_base else LANDED_AWAY
            self.cmd = 3
            return

        # ---- target arrival and photos
        if self.state == TRANSIT:
            if self.current_target < 0:
                self._start_leg(x, y)
            tgt = self.current_target
            if tgt >= 0:
                tx, ty = self.targets[tgt]
                if math.hypot(tx - x, ty - y) <= p.arrival_radius:
                    self.photo_count += 1
                    self.last_photo_target = tgt
                    self.last_photo_time = float(t)
                    self.last_photo_x, self.last_photo_y = float(x), float(y)
                    self.photos.append((tgt, float(t), float(x), float(y)))
                    self.visited.append(tgt)
                    self.remaining.remove(tgt)
                    self._start_leg(x, y)

        # ---- return to base
        if self.state in (RETURN_DONE, RETURN_LOW, RETURN_CMD) and at_base:
            self.state = LAND_BASE
            self.detour = []
            self.cmd = 3
            self.sp = (x, y, z)
            return

        wx, wy = self._avoidance(x, y, vx, vy)
        self.cmd = 2
        self.sp = (float(wx), float(wy), float(p.cruise_altitude))


def _zone_record(poly) -> list[float]:
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
