"""Scaling of the multi-UAV surveillance study: 1 to 256 UAVs, one-hour mission.

Usage::

    python bench/bench_uav_scaling.py                    # N = 1,4,16,64,256 at 1.0 s, N <= 16 also at 0.1 s
    python bench/bench_uav_scaling.py --sizes 1,4 --stop 600 --no-write      # quick look
    python bench/bench_uav_scaling.py --stop-256 900     # shorter mission for N >= 256, extrapolated
    python bench/bench_uav_scaling.py --sizes 256 --stop 600 --profile 40 --no-write   # what dominates

Scenario per fleet size N (``make_scenario``, built with ``uavstudy.build.build_ssp``): a disc-shaped
area about the base whose radius is 700 m (about the paper's 1.2 km square) up to 4 UAVs and grows as
(N/4)^(1/4) above (1.98 km for 256), so that every UAV can fly its sector and back on one charge; 2-6
targets per UAV (drawn per UAV, seeded by N) uniform in the area outside the landing-pad ring, listed
clockwise from north like the pads, so that ``equal`` assignment gives each UAV the sector in front of its
pad; four 90 m restricted squares on the diagonals beyond the pad ring (``--no-zones``: none); strategy B,
no wind, stop time 3600 s.  The UAV dynamics are step-size independent by design, so the main figure is at
a 1.0 s step; for N <= 16 the 0.1 s step (the paper's) is measured too.

Each (N, step) runs in its own subprocess (``--child``), which builds the SSP, runs it with
``master.runner.run`` (results.parquet written, no CSV, UAV monitor and its outputs included) and reports
one JSON line: FMU count, steps, wall time of the run, time of the step loop (``Execution._steps``
wrapped), the CPU time before the first step (setup) and after the last (outputs), time in the monitor's
``after_step`` (perf_counter around each call), peak RSS (VmHWM of /proc/self/status, whole run), VmRSS before
and after the loop, the size of the monitor's map track and the mission outcome.  The parent prints one table
and writes it with the machine description and the raw numbers to ``bench/results/uav_scaling_<date>.md``
(``--no-write``: print only).

Memory: the child resets its peak RSS (VmHWM, ``/proc/self/clear_refs``) at the start of each phase of
``PHASES`` (setup, FMU instantiation and initialization, the step loop, each recording flush and Parquet
write, the recording's finish, the UAV outputs, ...) and reads it at the end, so the table of the largest
fleet (printed and written after the main table) says which phase reaches the peak and how much each adds.

Fleets with more targets than the strategy FMU's indexed parameters hold (64; 64 UAVs and more here) give
their strategies the String form of the targets (``_string_form_beyond_limits``), which the FMU reads when
``n_targets`` is not given; ``uavstudy.build`` refuses such missions since the indexed encoding.

``--stop-256 S`` runs fleets of 256 and more for S s only and extrapolates their loop time linearly to
``--stop`` (start-up and outputs as measured); the table says so.  This is pessimistic: the first part of
the mission, with the whole fleet airborne, costs the most per step.  ``--block-rows R`` is an experiment
on the recorder (R-row blocks instead of its default).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

BASE = (-7.275, -35.965, 540.0)      # the paper area's base (ssp/scenarios/paper_area.yaml)
PAPER_RADIUS = 700.0                 # m, radius of the area up to 4 UAVs (~ the paper's 1.2 km square)
MISSION = 3600.0                     # s, one hour
SIZES = (1, 4, 16, 64, 256)
TARGETS_PER_UAV = (2, 6)             # inclusive range, drawn per UAV
ZONE_HALF = 45.0                     # m, half-side of a restricted square


def area_radius(n: int) -> float:
    """Radius (m) of the disc-shaped area for a fleet of n UAVs: the paper's up to 4 UAVs, then growing
    as (N/4)^(1/4) (1.98 km for 256), so that every UAV can still fly its sector and back on one charge."""
    return PAPER_RADIUS * max(1.0, n / 4.0) ** 0.25


def _zones_enu(n: int, radius: float) -> list[list[tuple[float, float]]]:
    """Four squares (ENU m) at 55 % of the radius on the diagonals, clear of the landing-pad ring."""
    from uavstudy.build import pad_positions
    ring = max(math.hypot(*p) for p in pad_positions(n))
    r = max(0.55 * radius, ring + 150.0)
    out = []
    for k in range(4):
        a = math.radians(45.0 + 90.0 * k)
        cx, cy = r * math.sin(a), r * math.cos(a)
        out.append([(cx - ZONE_HALF, cy - ZONE_HALF), (cx + ZONE_HALF, cy - ZONE_HALF),
                    (cx + ZONE_HALF, cy + ZONE_HALF), (cx - ZONE_HALF, cy + ZONE_HALF)])
    return out


def make_scenario(n: int, *, step: float = 1.0, stop_time: float = MISSION, zones: bool = True, seed: int = 1):
    """The UavScenario of the scaling study for n UAVs.

    Targets: 2-6 per UAV (drawn per UAV, seeded by n), uniform in the annulus between the landing-pad ring
    (+ 60 m, at least 80 m) and ``area_radius(n)``, at least 30 m from every zone, listed in clockwise
    order from north -- the order of the pads -- so that ``equal`` assignment (contiguous blocks) gives
    each UAV the targets of the sector in front of its own pad (a fleet flying out radially, as a real
    operator would split the area, instead of criss-crossing the ring)."""
    import shapely
    from uavstudy.build import pad_positions
    from uavstudy.scenario import UavScenario, WindConfig
    from uavsim.geodesy import geodetic_from_enu

    rng = np.random.default_rng(1000 + n)
    radius = area_radius(n)
    ring = max(math.hypot(*p) for p in pad_positions(n))
    r_in = max(80.0, ring + 60.0)
    zone_xy = _zones_enu(n, radius) if zones else []
    keep_out = [shapely.Polygon(p).buffer(30.0) for p in zone_xy]
    k_total = int(rng.integers(TARGETS_PER_UAV[0], TARGETS_PER_UAV[1] + 1, size=n).sum())
    pts = []
    while len(pts) < k_total:
        a = rng.uniform(0.0, 2.0 * math.pi)                     # clockwise from north
        r = math.sqrt(rng.uniform(r_in ** 2, radius ** 2))      # uniform in area
        x, y = r * math.sin(a), r * math.cos(a)
        if any(p.contains(shapely.Point(x, y)) for p in keep_out):
            continue
        pts.append((a, float(x), float(y)))
    pts.sort()
    lat0, lon0, alt0 = BASE

    def ll(x, y):
        la, lo, _ = geodetic_from_enu(x, y, 0.0, lat0, lon0, alt0)
        return (round(float(la), 7), round(float(lo), 7))

    return UavScenario(
        name=f"scaling_{n}uav", base=BASE, n_uavs=n, strategy="B", assignment="equal",
        targets=[ll(x, y) for _, x, y in pts],
        zones=[{"name": f"zone{k + 1}", "polygon": [ll(x, y) for x, y in p]} for k, p in enumerate(zone_xy)],
        wind=WindConfig(probability=0.0), seed=seed, step=step, stop_time=stop_time)


# ------------------------------------------------------------------------------------------ child
def _status_kb(field: str) -> int | None:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        pass
    return None


def _string_form_beyond_limits() -> None:
    """Large fleets have more targets than the strategy FMU's indexed parameters hold (64 since the indexed
    mission encoding): give those the String form (``targets``), which the FMU still reads when
    ``n_targets`` is not given; the zones stay indexed.  Missions that fit are built as before."""
    import uavstudy.build as build
    from uavsim import mission_encoding as M
    indexed = build._mission_parameters

    def mission(scn, targets, zones):
        if len(targets) <= M.MAX_TARGETS:
            return indexed(scn, targets, zones)
        values = indexed(scn, [], zones)
        del values["n_targets"]          # not given: the String form is read
        values["targets"] = build._pts(targets)
        return values
    build._mission_parameters = mission


class Phases:
    """Peak RSS per phase of a run: VmHWM is reset (``/proc/self/clear_refs`` 5) when a phase starts and
    read when it ends; a nested phase folds the peak so far into the phases around it first."""

    def __init__(self):
        self.open: list[str] = []
        self.peak: dict[str, int] = {}
        self.rss_in: dict[str, int] = {}
        self.rss_out: dict[str, int] = {}
        self.calls: dict[str, int] = {}
        self.can_reset = True

    def _fold(self) -> None:
        h = _status_kb("VmHWM") or 0
        for name in self.open:
            self.peak[name] = max(self.peak.get(name, 0), h)

    def _reset(self) -> None:
        if self.can_reset:
            try:
                Path("/proc/self/clear_refs").write_text("5")
            except OSError:
                self.can_reset = False

    def enter(self, name: str) -> None:
        self._fold()
        self.rss_in.setdefault(name, _status_kb("VmRSS") or 0)
        self._reset()
        self.open.append(name)

    def leave(self, name: str) -> None:
        self._fold()
        self.open.remove(name)
        self.rss_out[name] = _status_kb("VmRSS") or 0
        self.calls[name] = self.calls.get(name, 0) + 1

    def wrap(self, owner, attr: str, name: str) -> None:
        fn = getattr(owner, attr)

        def wrapped(*a, **kw):
            self.enter(name)
            try:
                return fn(*a, **kw)
            finally:
                self.leave(name)
        setattr(owner, attr, wrapped)

    def table(self) -> list[dict]:
        return [{"phase": k, "calls": self.calls.get(k, 0), "rss_before_mb": self.rss_in[k] / 1024,
                 "peak_mb": self.peak.get(k, 0) / 1024, "rss_after_mb": self.rss_out.get(k, 0) / 1024}
                for k in self.rss_in]


# the phases measured (owner module, class, method, name), in the order a run goes through them
PHASES = (("master.execution", "Execution", "setup", "setup (SSP, plan)"),
          ("master.runtime", "Runtime", "instantiate", "instantiate FMUs"),
          ("master.runtime", "Runtime", "initialize", "initialize FMUs"),
          ("master.execution", "Execution", "_steps", "step loop"),
          ("master.observers.recording", "Recording", "flush", "recording blocks (flush)"),
          ("master.sinks.parquet", "ParquetSink", "write", "parquet write"),
          ("master.sinks.parquet", "ParquetSink", "close", "parquet close"),
          ("master.observers.recording", "Recording", "finish", "recording finish"),
          ("uavstudy.outputs", None, "write_outputs", "UAV outputs"),
          ("master.runtime", "Runtime", "terminate", "terminate FMUs"))


def _install_phases(phases: Phases) -> None:
    import importlib
    for mod, cls, attr, name in PHASES:
        m = importlib.import_module(mod)
        owner = getattr(m, cls) if cls else m
        phases.wrap(owner, attr, name)
    import uavstudy.monitor as mon_mod        # imported the function by name
    import uavstudy.outputs as out_mod
    mon_mod.write_outputs = out_mod.write_outputs


def child(n: int, step: float, stop: float, zones: bool, profile: int, block_rows: int = 0) -> dict:
    """One (N, step) run in this process; returns the measurements (printed as SCALING-RESULT json)."""
    import master.runner as runner
    from master.execution import Execution
    _string_form_beyond_limits()
    phases = Phases()
    phases.enter("whole process")       # the process's peak over everything below (phases reset VmHWM)
    _install_phases(phases)
    if block_rows:      # experiment: the recording's block length (rows held in memory before a flush)
        from master.observers.recording import Recording
        init = Recording.__init__

        def small_blocks(self, *a, **kw):
            kw["block_rows"] = block_rows
            init(self, *a, **kw)
        Recording.__init__ = small_blocks
    from uavstudy import monitor as uav_mod
    from uavstudy.build import build_ssp

    tmp = Path(tempfile.mkdtemp(prefix=f"uav_scaling_{n}_"))
    t = time.perf_counter()
    ssp = build_ssp(make_scenario(n, step=step, stop_time=stop, zones=zones), tmp / f"scaling_{n}.ssp")
    build_s = time.perf_counter() - t

    mon_time = [0.0, 0]
    after_step = uav_mod.UavMonitor.after_step

    def timed_after_step(self, k, t0, t1, _pc=time.perf_counter):
        c = _pc()
        after_step(self, k, t0, t1)
        mon_time[0] += _pc() - c
        mon_time[1] += 1
    uav_mod.UavMonitor.after_step = timed_after_step
    monitors = []
    attach = uav_mod.UavMonitor.attach

    def keep_attach(self, ctx, start):
        monitors.append(self)
        return attach(self, ctx, start)
    uav_mod.UavMonitor.attach = keep_attach

    loop = {}
    orig_loop = Execution._steps
    if orig_loop is not None:       # the step loop alone (recording included), and the memory around it
        def timed_loop(*a, **kw):
            loop["rss_start_kb"] = _status_kb("VmRSS")
            c, cpu = time.perf_counter(), time.process_time()
            loop.setdefault("cpu_at_start", cpu)
            try:
                return orig_loop(*a, **kw)
            finally:
                loop["s"] = time.perf_counter() - c
                loop["cpu_s"] = time.process_time() - cpu
                loop["cpu_at_end"] = time.process_time()
                loop["rss_end_kb"] = _status_kb("VmRSS")
        Execution._steps = timed_loop

    prof = None
    if profile:
        import cProfile
        prof = cProfile.Profile()
        prof.enable()
    t = time.perf_counter()
    rss_run0 = _status_kb("VmRSS")
    cpu0 = time.process_time()
    res = runner.run(ssp, output=tmp / "out", write_csv=False, raise_on_error=False)
    wall = time.perf_counter() - t
    cpu_end = time.process_time()
    if prof is not None:
        prof.disable()
        import io
        import pstats
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats("tottime").print_stats(profile)
        print(s.getvalue(), file=sys.stderr)
    phases.leave("whole process")
    meta = res.metadata
    track_mb = None
    if monitors:        # the monitor's map track: distinct arrays only (idle steps share one)
        m = monitors[0]
        arrays = {id(a): a.nbytes for a in list(m.track_p) + list(m.track_phase)}
        track_mb = (sum(arrays.values()) + 8 * 3 * len(m.track_t)) / 2 ** 20
    tot = meta.get("monitors", {}).get("org.cosim-master.uav-monitor", {}).get("total", {})
    out = {"n": n, "step": step, "stop": stop, "zones": zones, "fmus": len(meta.get("fmus") or {}) or None,
           "steps": meta.get("steps_done", meta.get("steps")),
           # the time simulated: the monitor ends the run once every UAV is down (endWhenAllLanded)
           "sim_s": meta.get("last_time", stop) - meta.get("start_time", 0.0), "wall_s": wall,
           "ended_early": (meta.get("ended_early") or {}).get("time"),
           "loop_s": loop.get("s"), "loop_cpu_s": loop.get("cpu_s"), "build_s": build_s,
           # CPU time of the process from opening the SSP to the first step (FMUs loaded, instantiated and
           # initialized, the step compiled), and from the last step to run.json (outputs)
           "setup_cpu_s": loop["cpu_at_start"] - cpu0 if "cpu_at_start" in loop else None,
           "after_cpu_s": cpu_end - loop["cpu_at_end"] if "cpu_at_end" in loop else None,
           "monitor_s": mon_time[0], "monitor_calls": mon_time[1],
           "hwm_kb": int(phases.peak["whole process"]), "rss_start_kb": loop.get("rss_start_kb"),
           "rss_end_kb": loop.get("rss_end_kb"), "track_mb": track_mb,
           "outcome": meta.get("outcome"), "error": meta.get("error"),
           "successes": tot.get("uavs_successful"), "uav_collisions": tot.get("uav_collisions"),
           "zone_collisions": tot.get("zone_collisions"), "targets": tot.get("targets_total"),
           "targets_visited": tot.get("targets_visited"), "rss_before_run_kb": rss_run0,
           "phases": phases.table()}
    import shutil
    shutil.rmtree(tmp, ignore_errors=True)
    return out


# ----------------------------------------------------------------------------------------- parent
def run_one(n, step, stop, zones, timeout, profile=0, block_rows=0) -> dict:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", str(n), "--step", repr(step),
           "--stop", repr(stop)] + ([] if zones else ["--no-zones"]) + (["--profile", str(profile)] if profile else [])
    cmd += ["--block-rows", str(block_rows)] if block_rows else []
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"n": n, "step": step, "stop": stop, "error": f"timeout after {timeout} s"}
    if profile:
        print(p.stderr, file=sys.stderr)
    for line in p.stdout.splitlines():
        if line.startswith("SCALING-RESULT "):
            return json.loads(line[len("SCALING-RESULT "):])
    return {"n": n, "step": step, "stop": stop, "error": (p.stderr.strip().splitlines() or ["no result"])[-1]}


def _machine() -> list[str]:
    lines = []
    try:
        lines += subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines()[:15]
    except OSError:
        lines.append(f"{os.cpu_count()} CPUs (lscpu not available)")
    lines.append(f"python {sys.version.split()[0]} ({platform.python_implementation()}), numpy {np.__version__}, "
                 f"{platform.platform()}")
    try:
        lines.append("load average (1, 5, 15 min): " + " ".join(f"{x:.2f}" for x in os.getloadavg()))
    except OSError:
        pass
    return lines


HEADER = ("| N | FMUs | step s | steps | sim s | wall s | RTF | setup CPU s | loop s | RTF loop | RTF loop CPU "
          "| after loop CPU s | peak RSS MB "
          "| RSS growth in loop MB | monitor track MB | monitor us/step | monitor share | outcome |")


def _row(r: dict, mission: float) -> str:
    if r.get("error") and r.get("wall_s") is None:
        return f"| {r['n']} | | {r['step']:g} | | {r['stop']:g} | | | | | | | | | | | | | {r['error']} |"
    # a run shortened by --stop-256 is extrapolated; one the monitor ended early (fleet down) is not
    scale = mission / r["stop"] if r["stop"] < mission - 1e-9 and not r.get("ended_early") else 1.0
    wall, loop = r["wall_s"], r["loop_s"]
    ext = ""
    if scale != 1.0:
        # extrapolate the loop linearly to the one-hour mission; start-up and outputs stay as measured
        ext = f" (measured {r['sim_s']:g} s, extrapolated to {r['sim_s'] * scale:g} s)"
        wall = wall - loop + loop * scale if loop is not None else wall * scale
        loop = loop * scale if loop is not None else None
    sim = r["sim_s"] * scale
    cpu = r.get("loop_cpu_s")
    rtf_cpu = "" if not cpu else f"{sim / (cpu * scale):.0f}x"
    growth = ((r["rss_end_kb"] - r["rss_start_kb"]) / 1024) if r.get("rss_end_kb") and r.get("rss_start_kb") else None
    mon_us = 1e6 * r["monitor_s"] / max(1, r["monitor_calls"])
    track = "" if r.get("track_mb") is None else f"{r['track_mb']:.1f}"
    share = r["monitor_s"] / r["loop_s"] if r.get("loop_s") else r["monitor_s"] / r["wall_s"]
    outcome = (f"{r['successes']}/{r['n']} success, {r['uav_collisions']} UAV coll., "
               f"{r['zone_collisions']} zone coll., {r['targets_visited']}/{r['targets']} targets"
               if r.get("successes") is not None else r.get("outcome"))
    if r.get("error"):
        outcome += f"; {r['error']}"
    return (f"| {r['n']} | {r['fmus']} | {r['step']:g} | {int(r['steps'] * scale)} | {sim:g} | {wall:.1f}{ext} | "
            f"{sim / wall:.0f}x | {_secs(r.get('setup_cpu_s'))} | {loop:.2f} | {sim / loop:.0f}x | {rtf_cpu} | "
            f"{_secs(r.get('after_cpu_s'))} | {r['hwm_kb'] / 1024:.0f} | "
            f"{'' if growth is None else f'{growth:.0f}'} | {track} | "
            f"{mon_us:.1f} | {100 * share:.1f} % | {outcome} |")


def _secs(x) -> str:
    return "" if x is None else f"{x:.2f}"


def phase_table(r: dict) -> str:
    """Memory per phase of one run (``Phases``): RSS when the phase began, its peak, RSS when it ended."""
    lines = [f"Memory by phase, N={r['n']}, step {r['step']:g} s (MB; a phase's peak includes what earlier "
             "phases left):", "", "| phase | calls | RSS before | peak | RSS after | peak - RSS before |",
             "|---|---|---|---|---|---|"]
    for p in r["phases"]:
        lines.append(f"| {p['phase']} | {p['calls']} | {p['rss_before_mb']:.0f} | {p['peak_mb']:.0f} | "
                     f"{p['rss_after_mb']:.0f} | {p['peak_mb'] - p['rss_before_mb']:+.0f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)), help="comma-separated fleet sizes")
    ap.add_argument("--step", type=float, default=1.0, help="main step size (s)")
    ap.add_argument("--fine-step", type=float, default=0.1, help="second step size for small fleets (s)")
    ap.add_argument("--fine-max", type=int, default=16, help="largest fleet also run at --fine-step (0: none)")
    ap.add_argument("--stop", type=float, default=MISSION, help="stop time (s) of every run")
    ap.add_argument("--stop-256", type=float, default=None, dest="stop_256",
                    help="shorter stop time for N >= 256 (wall time extrapolated to --stop)")
    ap.add_argument("--no-zones", action="store_true", help="scenarios without restricted zones")
    ap.add_argument("--timeout", type=float, default=1800.0, help="per run (s)")
    ap.add_argument("--no-write", action="store_true", help="print only, no bench/results file")
    ap.add_argument("--profile", type=int, default=0, metavar="K",
                    help="cProfile each run and print its top K functions by own time to stderr")
    ap.add_argument("--block-rows", type=int, default=0, metavar="R",
                    help="experiment: run the recorder with R-row blocks instead of its default")
    ap.add_argument("--repeat", type=int, default=1, metavar="R",
                    help="run each (N, step) R times and keep the run with the shortest loop (a shared machine)")
    ap.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    zones = not args.no_zones
    if args.child is not None:
        r = child(args.child, args.step, args.stop, zones, args.profile, args.block_rows)
        print("SCALING-RESULT " + json.dumps(r))
        return 0

    runs = []
    for n in map(int, args.sizes.split(",")):
        stop = args.stop_256 if (args.stop_256 and n >= 256) else args.stop
        runs.append((n, args.step, stop))
        if args.fine_max and n <= args.fine_max and args.fine_step != args.step:
            runs.append((n, args.fine_step, args.stop))
    rows, results = [], []
    t_all = time.perf_counter()
    for n, step, stop in runs:
        t = time.perf_counter()
        tries = [run_one(n, step, stop, zones, args.timeout, args.profile, args.block_rows)
                 for _ in range(max(1, args.repeat))]
        r = min(tries, key=lambda x: x.get("loop_s") or math.inf)
        if len(tries) > 1:
            r["loop_s_all"] = [x.get("loop_s") for x in tries]
            r["wall_s_all"] = [x.get("wall_s") for x in tries]
        results.append(r)
        rows.append(_row(r, args.stop))
        print(f"  N={n} step={step:g} stop={stop:g}: {time.perf_counter() - t:.0f} s", file=sys.stderr, flush=True)
    total = time.perf_counter() - t_all
    table = "\n".join([HEADER, "|" + "---|" * (HEADER.count("|") - 1)] + rows)
    print(table)
    largest = max((r for r in results if r.get("phases")), key=lambda r: (r["n"], -r["step"]), default=None)
    if largest is not None:
        table += "\n\n" + phase_table(largest)
        print("\n" + phase_table(largest))
    print(f"(benchmark wall {total:.0f} s; RTF = simulated s / wall s; RTF loop CPU = simulated s / CPU time of the "
          f"loop{'; best of %d runs by loop time' % args.repeat if args.repeat > 1 else ''})")
    if not args.no_write:
        _write(table, results, total, zones, args.stop)
    return 0


def _write(table: str, results: list, total: float, zones: bool, mission: float) -> None:
    date = _dt.date.today().isoformat()
    out = ROOT / "bench" / "results" / f"uav_scaling_{date}.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    text = [f"# UAV study scaling, {date}", "",
            "`python bench/bench_uav_scaling.py` (see its docstring): one-hour surveillance mission "
            f"({mission:g} s), scenario per fleet size from `make_scenario` (disc area of radius "
            "700 m x max(1, N/4)^(1/4), 2-6 targets per UAV, "
            + ("four 90 m restricted squares" if zones else "no zones")
            + ", strategy B, equal assignment of angle-sorted targets, no wind), each run in its own subprocess.",
            "",
            "- wall s: `master.runner.run` from opening the SSP to run.json (FMU loading, the loop, the UAV "
            "outputs: trajectory.csv, summary, map.png); results.parquet written, no CSV.",
            "- setup CPU s: CPU time of the run from opening the SSP to the first step (FMUs loaded, instantiated "
            "and initialized, the step compiled); after loop CPU s: from the last step to run.json (the outputs).",
            "- loop s: the step loop alone (`Execution._steps`, recording included); RTF loop = sim s / loop s; "
            "RTF loop CPU: the same over the process's CPU time in the loop (less sensitive to a busy machine).",
            "- `--repeat R`: each row is the run with the shortest loop of R (the others' times in the raw results).",
            "- peak RSS: VmHWM of the child process (whole run, outputs included); RSS growth in loop: VmRSS "
            "after the loop minus before it.",
            "- monitor us/step: mean time in the UAV monitor's `after_step` per master step (perf_counter around "
            "each call); share: of the loop time.",
            "", table, "", f"Benchmark wall time {total:.0f} s.", "", "## Machine", "", "```", *_machine(), "```", "",
            "## Raw results", "", "```json", json.dumps(results, indent=1), "```", ""]
    out.write_text("\n".join(text))
    print(f"wrote {out.relative_to(ROOT)}")


if __name__ == "__main__":
    sys.exit(main())
