"""Mission outputs of the UAV study, written by the UAV monitor's ``finish`` into the run folder.

* ``trajectory.csv`` -- one row per UAV per recorded time (results.parquet): time, uav, lat, lon, alt,
  x, y, z (ENU m about the base), speed (ground speed, m/s), soc, consumed, phase and mission_state (by
  name, as events.csv), photo_count, status (``active``; a removed UAV ends with one ``removed`` row at the time and place
  it was taken out).  Without the recorded columns the monitor's own track (every master step,
  thinned to ~1 s) is used.
* ``photos.csv`` -- uav, target (global index in map order), time, x, y, lat, lon: one row per photo
  (increments of the strategy's photo_count with its last_photo_* outputs, seen every master step).
* ``summary.csv`` / ``summary.json`` -- per UAV and in total: targets assigned and visited, photos,
  distance flown (3D and horizontal, integrated every master step), flight time, energy used,
  remaining battery, outcome.  One meaning per column: the total row shares a column with the UAV rows
  only where it means the same for the fleet; its counts, sums and means have their own columns
  (docs/uav_monitor.md lists every column).
* ``replay.html`` -- the run seen again in a browser, offline (uavstudy.replay).
* ``map.png`` -- local ENU map: base and pads, targets (visited / not visited), zones, UAV paths with
  time marks and direction arrows, collision and landing markers, scale bar, legend; title with
  scenario, strategy, the time the mission ended and the results.  Beyond ``MAX_UAV_LEGEND`` UAVs it is a
  fleet's map: tracks and pads coloured by outcome, a legend by outcome with its number of UAVs.  For strategy
  C, the links at a moment (who heard whom within one broadcast period: ``uavstudy.comm_monitor``) as thin
  lines between where the UAVs were then, solid when both heard each other, dotted when one way only.

Outcome of a UAV (first that applies):

``uav_collision`` / ``zone_collision``
    removed by the monitor (contact with another UAV / entry into a restricted zone);
``forced_landing``
    the strategy landed it away from the base (95 % consumed) or it is on the ground away from its pad;
``no_targets``
    back on its pad with no target assigned (more UAVs than targets): neither a success nor a failure;
``success``
    every assigned target photographed, landed within ``homeTolerance`` (5 m) of its pad, and more than
    ``successBattery`` (5 %) of the battery left -- the paper's definition;
``battery_return``
    landed at its pad after abandoning the mission at 80 % consumed (targets left);
``commanded_return``
    landed at its pad with targets left after a ground station sent it home (uavstudy.mavlink);
``incomplete`` / ``low_battery``
    landed at its pad with targets left (other causes) / with 5 % battery or less;
``timeout``
    the run reached its stop time before the UAV landed;
``run_error`` / ``run_interrupted``
    the run failed / was interrupted before the UAV finished.

Every file is written as far as data exist, also when the run failed; a failure of one output is
recorded in the summary (``output_errors``) and does not stop the others.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from master.results import csv_column_cells, write_csv_cells

from .geodetic import to_geodetic
from .names import (FINAL_STATES, MISSION_EVENTS, NO_TARGETS, PHASE_LANDED, PHASE_NAMES, TOTAL_ROW,
                    TRAJECTORY_ROLES, UAV_COLLISION, ZONE_COLLISION)


def _f(v, default=math.nan):
    try:
        v = float(v)
    except (TypeError, ValueError):
        return default
    return v


def _int_or(v, default=None):
    try:
        return int(v)
    except (TypeError, ValueError):
        return default


def _clean(o):
    """JSON-safe copy (NaN -> None, numpy scalars -> Python)."""
    if isinstance(o, dict):
        return {k: _clean(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_clean(v) for v in o]
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o


# ------------------------------------------------------------------------------- summary
def uav_outcome(*, attached: bool, run_outcome: str, rec, landed: bool, at_home: bool, assigned: float,
                all_visited: bool, battery_ok: bool) -> str:
    """The outcome of one UAV: the first that applies in the order of the module docstring."""
    if not attached:
        return "run_error" if run_outcome != "interrupted" else "run_interrupted"
    if rec.removed:
        return rec.removed_reason
    if rec.forced_landing or (landed and rec.took_off and not at_home):
        return "forced_landing"
    if at_home and rec.took_off:
        if assigned == 0:       # it only took off and came back: neither a success nor a failed mission
            return NO_TARGETS
        if all_visited and battery_ok:
            return "success"
        if not all_visited:
            if rec.return_low:
                return "battery_return"
            return "commanded_return" if rec.return_commanded else "incomplete"
        return "low_battery"
    if run_outcome == "completed":
        return "timeout"
    return "run_interrupted" if run_outcome == "interrupted" else "run_error"


def finished_time(rec) -> float | None:
    """When the UAV was done for good: its removal, or the strategy registering its landing; None while it
    was still on its mission (or the strategy's state is not known)."""
    if rec.removed_time is not None:
        return rec.removed_time
    landings = [t for t, state in rec.mission_states if state in FINAL_STATES]
    return landings[-1] if landings else None


def uav_summaries(mon, run_outcome: str) -> list[dict]:
    cfg = mon.cfg
    out = []
    attached = mon.ctx is not None
    for spec, rec in zip(cfg.uavs, mon.records):
        last = rec.last
        x, y, z = _f(last.get("x")), _f(last.get("y")), _f(last.get("z"))
        if rec.removed and rec.removed_pos is not None:
            x, y, z = rec.removed_pos
        phase = _f(last.get("phase"))
        state = _f(last.get("missionState"))
        soc = _f(last.get("soc"))
        consumed = _f(last.get("consumed"))
        if math.isnan(soc) and not math.isnan(consumed):
            soc = 1.0 - consumed
        assigned = _f(last.get("targetsAssigned"))
        if math.isnan(assigned) and spec.assigned is not None:
            assigned = float(len(spec.assigned))
        visited_targets = sorted({p["target"] for p in rec.photos if p["target"] >= 0})
        visited = _f(last.get("targetsVisited"))
        if math.isnan(visited):
            visited = float(len(visited_targets)) if attached else math.nan
        photos = len(rec.photos) + sum(p.get("missed_before", 0) for p in rec.photos)
        pc = _f(last.get("photoCount"))
        if not math.isnan(pc):
            photos = max(photos, int(pc))
        energy = _f(last.get("energy"))
        d_home = math.hypot(x - spec.home[0], y - spec.home[1]) if not math.isnan(x) else math.nan
        landed = phase == PHASE_LANDED
        reason = uav_outcome(attached=attached, run_outcome=run_outcome, rec=rec, landed=landed,
                             at_home=landed and d_home <= cfg.home_tolerance, assigned=assigned,
                             all_visited=not math.isnan(assigned) and not math.isnan(visited) and visited >= assigned,
                             battery_ok=not math.isnan(soc) and soc > cfg.success_battery)
        states = [MISSION_EVENTS.get(s, str(s)) for _, s in rec.mission_states]
        out.append({
            "uav": spec.name, "index": spec.index, "outcome": reason, "success": reason == "success",
            "targets_assigned": None if math.isnan(assigned) else int(assigned),
            "targets_visited": None if math.isnan(visited) else int(visited),
            "visited_targets": visited_targets,
            "assigned_targets": spec.assigned,
            "photos": photos,
            "distance_m": rec.distance, "distance_xy_m": rec.distance_xy,
            "flight_time_s": rec.flight_time,
            "energy_used_J": energy, "energy_used_Wh": energy / 3600.0,
            "remaining_battery_pct": 100.0 * soc, "consumed_pct": 100.0 * consumed,
            "final_x": x, "final_y": y, "final_z": z,
            "home_x": spec.home[0], "home_y": spec.home[1], "distance_to_home_m": d_home,
            "final_phase": None if math.isnan(phase) else int(phase),
            "final_mission_state": None if math.isnan(state) else MISSION_EVENTS.get(int(state)),
            "returned_low_battery": rec.return_low, "forced_landing": rec.forced_landing,
            "finished_time": finished_time(rec),
            "removed_time": rec.removed_time, "removed_by": rec.removed_by,
            "mission_states": states,
        })
    return out


def _sum(uavs: list[dict], key: str) -> float:
    """The sum of a per-UAV quantity over the UAVs that have it (NaN if none has)."""
    vals = [u[key] for u in uavs if u[key] is not None and math.isfinite(u[key])]
    return float(sum(vals)) if vals else math.nan


def _mission_end_time(uavs: list[dict]) -> float | None:
    """When the last UAV landed or was removed; None if one was still on its mission when the run ended."""
    times = [u["finished_time"] for u in uavs]
    return max(times) if times and None not in times else None


def _targets_assigned(uavs: list[dict]) -> int | None:
    """Distinct targets given to some UAV (a target given to two counts once, as in targets_visited)."""
    lists = [u["assigned_targets"] for u in uavs]
    return len({k for lst in lists for k in lst}) if lists and None not in lists else None


def total_summary(mon, uavs: list[dict], run_outcome: str) -> dict:
    """The run's totals.  A key that also names a per-UAV value (success, targets_assigned, targets_visited)
    means the same for the whole fleet; sums, means and counts of UAVs carry their own names, so that the
    total row of summary.csv and of the campaign table never mixes two meanings in one column."""
    reasons: dict[str, int] = {}
    for u in uavs:
        reasons[u["outcome"]] = reasons.get(u["outcome"], 0) + 1
    socs = [u["remaining_battery_pct"] for u in uavs if math.isfinite(u["remaining_battery_pct"])]
    n_uav_removed = sum(1 for r in mon.records if r.removed_reason == UAV_COLLISION)
    n_success = reasons.get("success", 0)
    return {
        "scenario": mon.cfg.scenario, "strategy": mon.cfg.strategy, "assignment": mon.cfg.assignment,
        "scenario_seed": _int_or(mon.cfg.seed), "wind_probability": _f(mon.cfg.wind_probability, None),
        "settings": dict(mon.cfg.settings),
        "run_outcome": run_outcome, "end_time": mon.last_time, "mission_end_time": _mission_end_time(uavs),
        "uavs": len(uavs), "uavs_successful": n_success,
        "success": bool(uavs) and n_success == len(uavs),
        "success_rate": n_success / len(uavs) if uavs else math.nan,
        "outcomes": reasons,
        "uav_collisions": n_uav_removed // 2,
        "zone_collisions": sum(1 for r in mon.records if r.removed_reason == ZONE_COLLISION),
        "forced_landings": sum(1 for u in uavs if u["forced_landing"]),
        "targets_total": int(len(mon.cfg.targets)),
        "targets_assigned": _targets_assigned(uavs),
        "targets_visited": len({t for u in uavs for t in u["visited_targets"]}),
        "photos_sum": int(sum(u["photos"] for u in uavs)),
        "distance_m_sum": _sum(uavs, "distance_m"), "distance_xy_m_sum": _sum(uavs, "distance_xy_m"),
        "flight_time_s_sum": _sum(uavs, "flight_time_s"), "energy_used_Wh_sum": _sum(uavs, "energy_used_Wh"),
        "remaining_battery_pct_mean": float(np.mean(socs)) if socs else math.nan,
    }


# ------------------------------------------------------------------------------- tables
def _read_results(out_dir: Path, mon=None):
    """The recorded series the outputs use (only their columns: a large fleet records thousands)."""
    from master.results import read_results, result_columns, results_path
    if not results_path(out_dir).is_file():
        return None
    try:
        columns = None
        if mon is not None:
            wanted = {"time"} | {q for spec in mon.cfg.uavs for q in spec.vars.values()}
            columns = [c for c in result_columns(out_dir) if c in wanted]
        return read_results(out_dir, columns)
    except Exception:   # noqa: BLE001 - a truncated file after a crash
        return None


def trajectory_frame(mon, df):
    """The trajectory table (see module docstring) as a pandas DataFrame."""
    import pandas as pd
    cfg = mon.cfg
    cols = ["time", "uav", "lat", "lon", "alt", "x", "y", "z", "speed", "soc", "consumed", "phase",
            "mission_state", "photo_count", "status"]
    parts = []
    for k, (spec, rec) in enumerate(zip(cfg.uavs, mon.records)):
        v = spec.vars
        if df is not None and all(v.get(r) in df.columns for r in ("x", "y", "z")):
            t = df["time"].to_numpy(float)
            data = {"x": df[v["x"]].to_numpy(float), "y": df[v["y"]].to_numpy(float),
                    "z": df[v["z"]].to_numpy(float)}
            for c, role in TRAJECTORY_ROLES.items():
                q = v.get(role)
                data[c] = df[q].to_numpy(float) if q in df.columns else np.full(t.size, np.nan)
        elif mon.track_t:
            tt = np.asarray(mon.track_t)
            keep = _thin(tt, 1.0)
            t = tt[keep]
            p = np.stack(mon.track_p)[keep, k]
            data = {"x": p[:, 0], "y": p[:, 1], "z": p[:, 2],
                    "phase": np.stack(mon.track_phase)[keep, k].astype(float)}
            for c in ("speed", "soc", "consumed", "mission_state", "photo_count"):
                data[c] = np.full(t.size, np.nan)
        else:
            continue
        if np.all(np.isnan(data["speed"])) and t.size > 1:
            d = np.hypot(np.diff(data["x"]), np.diff(data["y"])) / np.maximum(np.diff(t), 1e-12)
            data["speed"] = np.concatenate(([0.0], d))
        status = np.full(t.size, "active", dtype=object)
        if rec.removed and rec.removed_time is not None:
            keep = t < rec.removed_time - 1e-9
            t = t[keep]
            data = {c: a[keep] for c, a in data.items()}
            status = status[keep]
            # last row: where and when it was taken out, with its last known state
            t = np.append(t, round(rec.removed_time, 9))
            x, y, z = rec.removed_pos
            last = rec.last
            extra = {"x": x, "y": y, "z": z, "speed": _f(last.get("speed")), "soc": _f(last.get("soc")),
                     "consumed": _f(last.get("consumed")), "phase": _f(last.get("phase")),
                     "mission_state": _f(last.get("missionState")), "photo_count": _f(last.get("photoCount"))}
            data = {c: np.append(a, extra[c]) for c, a in data.items()}
            status = np.append(status, "removed")
        lat, lon, alt = to_geodetic(cfg.origin, data["x"], data["y"], data["z"])
        frame = pd.DataFrame({"time": t, "uav": spec.name, "lat": np.atleast_1d(lat), "lon": np.atleast_1d(lon),
                              "alt": np.atleast_1d(alt), **{c: data[c] for c in ("x", "y", "z", "speed", "soc",
                                                                                  "consumed", "phase",
                                                                                  "mission_state",
                                                                                  "photo_count")},
                              "status": status})
        parts.append(frame)
    if not parts:
        return pd.DataFrame(columns=cols)
    out = pd.concat(parts, ignore_index=True)
    parts.clear()       # a large fleet's pieces are as large as the table: gone before the sort copies it
    if not out["photo_count"].isna().all():
        out["photo_count"] = out["photo_count"].astype("Int64")
    # names, as events.csv and summary.json give them, rather than the FMUs' integer codes
    out["phase"] = _code_names(out["phase"], PHASE_NAMES)
    out["mission_state"] = _code_names(out["mission_state"], MISSION_EVENTS)
    return out.sort_values(["time", "uav"], kind="stable", ignore_index=True)[cols]


def _code_names(codes, names: dict):
    """The name of each code (an unknown code as its number, a missing one as empty)."""
    def name(v):
        if v is None or not math.isfinite(v):
            return None
        return names.get(int(v), str(int(v)))
    return codes.astype(float).map(name).astype(object)


def _thin(t: np.ndarray, interval: float) -> np.ndarray:
    """Indices of t spaced by at least ``interval`` (first and last always kept)."""
    keep, last = [], -math.inf
    for i, v in enumerate(t):
        if v - last >= interval - 1e-9:
            keep.append(i)
            last = v
    if keep[-1] != t.size - 1:
        keep.append(t.size - 1)
    return np.asarray(keep, dtype=np.intp)


def photos_frame(mon, df):
    import pandas as pd
    cfg = mon.cfg
    rows = []
    for spec, rec in zip(cfg.uavs, mon.records):
        photos = rec.photos
        if mon.ctx is None and df is not None:
            photos = _photos_from_results(spec, df)
        for p in photos:
            rows.append({"uav": spec.name, "target": p["target"], "time": p["time"], "x": p["x"], "y": p["y"],
                         "z": p.get("z", math.nan)})
    frame = pd.DataFrame(rows, columns=["uav", "target", "time", "x", "y", "z"])
    if len(frame):
        z = frame["z"].fillna(0.0).to_numpy(float)
        lat, lon, _ = to_geodetic(cfg.origin, frame["x"].to_numpy(float), frame["y"].to_numpy(float), z)
        frame["lat"], frame["lon"] = np.atleast_1d(lat), np.atleast_1d(lon)
    else:
        frame["lat"], frame["lon"] = [], []
    frame = frame.drop(columns=["z"])
    return frame.sort_values(["time", "uav"], kind="stable", ignore_index=True)


def _photos_from_results(spec, df) -> list[dict]:
    """Photos from the recorded photo_count increments and last_photo_* outputs (record resolution)."""
    v = spec.vars
    q = v.get("photoCount")
    if q not in df.columns:
        return []
    pc = df[q].to_numpy(float)
    out = []
    prev = 0.0
    for i in range(len(pc)):
        if pc[i] > prev:
            row = df.iloc[i]
            out.append({"target": int(row[v["lastPhotoTarget"]]) if v.get("lastPhotoTarget") in df.columns else -1,
                        "time": float(row[v["lastPhotoTime"]]) if v.get("lastPhotoTime") in df.columns
                        else float(row["time"]),
                        "x": float(row[v["lastPhotoX"]]) if v.get("lastPhotoX") in df.columns else float(row[v["x"]]),
                        "y": float(row[v["lastPhotoY"]]) if v.get("lastPhotoY") in df.columns else float(row[v["y"]]),
                        "z": float(row[v["z"]]) if v.get("z") in df.columns else math.nan})
            if pc[i] - prev > 1:
                out[-1]["missed_before"] = int(pc[i] - prev - 1)
        prev = pc[i]
    return out


#: summary.csv: the per-UAV columns (on the total row: the same meaning for the whole fleet, or empty) ...
SUMMARY_COLUMNS = ["uav", "outcome", "success", "targets_assigned", "targets_visited", "photos", "distance_m",
                   "distance_xy_m", "flight_time_s", "energy_used_Wh", "remaining_battery_pct", "consumed_pct",
                   "final_x", "final_y", "final_z", "distance_to_home_m", "removed_time", "removed_by"]
#: ... then the columns only the total row fills (counts of UAVs, sums and means over them)
TOTAL_COLUMNS = ["uavs", "uavs_successful", "targets_total", "photos_sum", "distance_m_sum", "distance_xy_m_sum",
                 "flight_time_s_sum", "energy_used_Wh_sum", "remaining_battery_pct_mean"]

COUNT_COLUMNS = ["targets_assigned", "targets_visited", "photos", "uavs", "uavs_successful", "targets_total",
                 "photos_sum"]


def summary_frame(uavs: list[dict], total: dict):
    import pandas as pd
    columns = SUMMARY_COLUMNS + TOTAL_COLUMNS
    rows = [{c: u.get(c) for c in SUMMARY_COLUMNS} for u in uavs]
    rows.append({**{c: total.get(c) for c in columns}, "uav": TOTAL_ROW})
    frame = pd.DataFrame(rows, columns=columns)
    for c in COUNT_COLUMNS:     # counts stay integers next to the empty cells of the other rows
        frame[c] = frame[c].astype("Int64")
    return frame


# ------------------------------------------------------------------------------- the two CSVs without pandas
# A campaign run writes photos.csv and summary.csv of a few rows each, and building the pandas frames for them
# cost more than the rest of the run's outputs: master.results' pandas twin writes pandas' bytes for them, or
# declines (nothing written) and the frame is built as before
# (tests/master/campaign/test_campaign_outputs_csv.py compares both on thousands of random tables).
_column_cells = csv_column_cells
_write_csv = write_csv_cells


def write_summary_csv(uavs: list[dict], total: dict, path: Path) -> bool:
    """summary.csv as ``summary_frame(uavs, total).to_csv(path, index=False)`` writes it; False (nothing
    written) when the values are not all of the plain kinds the twin covers."""
    columns = SUMMARY_COLUMNS + TOTAL_COLUMNS
    rows = [{c: u.get(c) for c in SUMMARY_COLUMNS} for u in uavs]
    rows.append({**{c: total.get(c) for c in columns}, "uav": TOTAL_ROW})
    cells = []
    for c in columns:
        col = _column_cells([r.get(c) for r in rows], as_int64=c in COUNT_COLUMNS)
        if col is None:
            return False
        cells.append(col)
    _write_csv(path, columns, cells)
    return True


def write_photos_csv(mon, path: Path) -> bool:
    """photos.csv as ``photos_frame(mon, None).to_csv(path, index=False)`` writes it from the monitor's own
    photo records; False (nothing written) for values the twin does not cover."""
    cfg = mon.cfg
    rows = [(spec.name, p["target"], p["time"], p["x"], p["y"], p.get("z", math.nan))
            for spec, rec in zip(cfg.uavs, mon.records) for p in rec.photos]
    columns = ["uav", "target", "time", "x", "y", "lat", "lon"]
    if not rows:
        _write_csv(path, columns, [[] for _ in columns])
        return True
    if any(type(r[2]) is not float or r[2] != r[2] or type(r[0]) is not str for r in rows) or \
            any(type(v) not in (int, float) for r in rows for v in r[3:6]):
        return False            # NaN times sort last in pandas; other kinds take the frame
    cells = [_column_cells([r[k] for r in rows]) for k in range(5)]
    if any(c is None for c in cells):
        return False
    z = np.array([0.0 if v != v else float(v) for v in (r[5] for r in rows)], dtype=float)
    lat, lon, _ = to_geodetic(cfg.origin, np.array([float(r[3]) for r in rows]), np.array([float(r[4]) for r in rows]), z)
    cells += [_column_cells(np.atleast_1d(lat).tolist()), _column_cells(np.atleast_1d(lon).tolist())]
    order = sorted(range(len(rows)), key=lambda i: (rows[i][2], rows[i][0]))     # stable, as pandas' lexsort
    _write_csv(path, columns, [[col[i] for i in order] for col in cells])
    return True


# ------------------------------------------------------------------------------- map
def _nice(length: float) -> float:
    if not length > 0:
        return 1.0
    e = 10 ** math.floor(math.log10(length))
    for m in (5, 2, 1):
        if m * e <= length:
            return m * e
    return e


MAX_TARGET_LABELS = 64      # more targets than a scenario file takes (the strategy FMU's 64) are not numbered
TIME_MARK_INTERVAL = 60.0   # s between two time marks on a track (an arrow half-way shows the direction)
MAX_TRACK_POINTS = 6000     # a track drawn with more points is thinned (a long mission of a large fleet)


def uav_styles(n: int) -> list[tuple]:
    """(colour, line style) of each UAV's track: tab10 up to 10 UAVs, tab20 up to 20 (C0..C9 would repeat
    after 10), beyond that the 20 colours again with dashed, then dotted lines."""
    from matplotlib import colormaps
    cmap = colormaps["tab10" if n <= 10 else "tab20"]
    dashes = ("-", "--", ":", "-.")
    return [(cmap(k % cmap.N), dashes[(k // cmap.N) % len(dashes)]) for k in range(n)]


def _track(mon, k: int, rec, name: str, traj):
    """(times, (T, 2) east-north positions) of one UAV up to its removal; None without any track."""
    if mon.track_p:
        # this UAV's column only: a slice of the whole fleet's stacked track kept that array alive as long as the
        # map held the UAV's line, one per UAV (256 UAVs: +1.1 GB and 5 s of copies)
        t, xy = np.asarray(mon.track_t), np.stack([p[k, :2] for p in mon.track_p])
    elif traj is not None and len(traj):
        sub = traj[traj["uav"] == name]
        t, xy = sub["time"].to_numpy(float), sub[["x", "y"]].to_numpy(float)
    else:
        return None
    if rec.removed_time is not None:
        keep = t <= rec.removed_time + 1e-9
        t, xy = t[keep], xy[keep]
    return (t, xy) if len(t) else None


def _flight_window(t, xy):
    """(first, last) time the UAV moved, None if it never did (time marks on a parked UAV would pile up)."""
    moved = np.flatnonzero(np.hypot(*np.diff(xy, axis=0).T) > 1e-6)
    return (t[moved[0]], t[moved[-1] + 1]) if moved.size else None


def _flight_marks(ax, t, xy, color) -> None:
    """Dots at every multiple of TIME_MARK_INTERVAL s while the UAV flies, and an arrow half-way between
    two of them pointing the way it flew (the same times for every UAV, so tracks can be compared)."""
    window = _flight_window(t, xy)
    if window is None:
        return
    first, last = window
    step = TIME_MARK_INTERVAL
    marks = np.arange(math.ceil(first / step) * step, last + 1e-9, step)
    if marks.size:
        ax.scatter(np.interp(marks, t, xy[:, 0]), np.interp(marks, t, xy[:, 1]), s=16, color=color,
                   edgecolors="black", linewidths=0.6, zorder=4)
    for tm in np.arange(math.floor(first / step) * step + step / 2, last, step):
        if tm - 1.0 < first:
            continue
        x0, x1 = np.interp([tm - 1.0, tm + 1.0], t, xy[:, 0])
        y0, y1 = np.interp([tm - 1.0, tm + 1.0], t, xy[:, 1])
        if math.hypot(x1 - x0, y1 - y0) > 1e-6:
            ax.annotate("", xy=(x1, y1), xytext=(x0, y0), zorder=4,
                        arrowprops={"arrowstyle": "-|>", "color": color, "lw": 1.2, "mutation_scale": 13})


def _draw_zones(ax, zones, handles) -> None:
    from matplotlib.patches import Polygon
    for z in zones:
        ax.add_patch(Polygon(z["polygon"], closed=True, facecolor="tab:blue", alpha=0.35, edgecolor="navy", lw=1.2))
        # named at its centre (zones do not overlap, so neither do their names), on a pale box above the
        # tracks and below the targets
        ax.annotate(z["name"], np.asarray(z["polygon"]).mean(axis=0), fontsize=6.5, color="navy", ha="center",
                    va="center", zorder=3.5, bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none",
                                                 "alpha": 0.7})
    if zones:
        handles.append(Polygon([[0, 0]], facecolor="tab:blue", alpha=0.35, edgecolor="navy", label="restricted zone"))


def _draw_targets(ax, targets, visited: set, handles) -> None:
    from matplotlib.lines import Line2D
    tg = np.asarray(targets).reshape(-1, 2)
    if not len(tg):
        return
    vis = np.array([k in visited for k in range(len(tg))], dtype=bool)
    many = len(tg) > MAX_TARGET_LABELS      # hundreds of targets: smaller, and not numbered (replay.html names them)
    size = 22 if many else 70
    if vis.any():
        ax.scatter(tg[vis, 0], tg[vis, 1], s=size, c="gold", edgecolors="darkgoldenrod", zorder=4)
    if (~vis).any():
        ax.scatter(tg[~vis, 0], tg[~vis, 1], s=size, facecolors="none", edgecolors="gray", linewidths=1.5,
                   marker="o", zorder=4)
        ax.scatter(tg[~vis, 0], tg[~vis, 1], s=size * 0.43, c="gray", marker="x", zorder=4)
    for k, (x, y) in enumerate([] if many else tg):
        ax.annotate(str(k), (x, y), xytext=(4, 4), textcoords="offset points", fontsize=6, color="dimgray",
                    zorder=4.5)     # above the zone names' boxes
    handles.append(Line2D([], [], ls="", marker="o", ms=8, mfc="gold", mec="darkgoldenrod",
                          label=f"target visited ({int(vis.sum())})"))
    handles.append(Line2D([], [], ls="", marker="x", ms=7, color="gray",
                          label=f"target not visited ({int((~vis).sum())})"))


#: beyond this many UAVs the map is a fleet's: tracks coloured by outcome, a legend by outcome, no per-UAV time
#: marks (replay.html has every UAV's detail); up to it, a colour and a legend entry per UAV
MAX_UAV_LEGEND = 10
#: outcome -> track colour on a fleet's map (an outcome not listed is drawn grey)
OUTCOME_COLOURS = {"success": "tab:green", "battery_return": "tab:orange", "commanded_return": "tab:purple",
                   "incomplete": "tab:olive", "low_battery": "gold", "forced_landing": "darkorange",
                   UAV_COLLISION: "red", ZONE_COLLISION: "darkred", NO_TARGETS: "tab:gray", "timeout": "tab:blue",
                   "run_error": "black", "run_interrupted": "black"}


def _draw_fleet_tracks(ax, mon, uavs: list[dict], traj, handles) -> None:
    """A large fleet: every track thin and coloured by its UAV's outcome, each pad a dot of that colour (the
    UAVs that never left their pads, e.g. without targets, are a ring of dots, not a blob), one legend entry per
    outcome with its number of UAVs."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    counts: dict[str, int] = {}
    lines, colours = [], []
    for k, (spec, rec, u) in enumerate(zip(mon.cfg.uavs, mon.records, uavs)):
        outcome = u["outcome"]
        counts[outcome] = counts.get(outcome, 0) + 1
        colour = OUTCOME_COLOURS.get(outcome, "tab:gray")
        track = _track(mon, k, rec, spec.name, traj)
        if track is not None:
            xy = track[1]
            step = max(1, math.ceil(len(xy) / max(50, MAX_TRACK_POINTS // max(1, len(uavs) // 10))))
            lines.append(xy[::step])
            colours.append(colour)
        ax.scatter([spec.home[0]], [spec.home[1]], s=6, marker="o", color=colour, edgecolors="none", zorder=5.5)
    ax.add_collection(LineCollection(lines, colors=colours, linewidths=0.8, alpha=0.7, zorder=3))
    for outcome in sorted(counts, key=lambda o: (-counts[o], o)):
        n = counts[outcome]
        handles.append(Line2D([], [], color=OUTCOME_COLOURS.get(outcome, "tab:gray"), lw=2, marker="o", ms=4,
                              label=f"{outcome}: {n} UAV{'s' if n != 1 else ''}"))
    ax.text(0.0, -0.11, "tracks and pads coloured by their UAV's outcome; every UAV on its own, in time: replay.html",
            transform=ax.transAxes, ha="left", va="top", fontsize=7, color="dimgray")


def _draw_tracks(ax, mon, uavs: list[dict], traj, handles) -> None:
    from matplotlib.lines import Line2D
    if len(uavs) > MAX_UAV_LEGEND:
        _draw_fleet_tracks(ax, mon, uavs, traj, handles)
        return
    for k, ((color, dash), spec, rec, u) in enumerate(zip(uav_styles(len(uavs)), mon.cfg.uavs, mon.records, uavs)):
        track = _track(mon, k, rec, spec.name, traj)
        if track is not None:
            t, xy = track
            step = max(1, math.ceil(len(xy) / MAX_TRACK_POINTS))
            ax.plot(xy[::step, 0], xy[::step, 1], color=color, ls=dash, lw=1.3, alpha=0.9, zorder=3)
            _flight_marks(ax, t, xy, color)
        ax.scatter([spec.home[0]], [spec.home[1]], s=25, marker="o", color=color, edgecolors="black", zorder=5.5)
        handles.append(Line2D([], [], color=color, ls=dash, lw=2, label=f"{spec.name}: {u['outcome']}"))
    handles.append(Line2D([], [], ls="", marker="o", ms=4, mfc="white", mec="black",
                          label=f"every {TIME_MARK_INTERVAL:g} s of flight (arrow: direction)"))


#: end-of-mission marker kind -> scatter style and legend entry; landings are hollow so that the base and the
#: pads beneath them stay visible
END_MARKERS = {
    "uav": ({"s": 260, "marker": "*", "c": "red", "edgecolors": "black", "zorder": 7}, "UAV-UAV collision"),
    "zone": ({"s": 160, "marker": "X", "c": "darkred", "edgecolors": "white", "zorder": 7}, "zone collision"),
    "landed": ({"s": 110, "marker": "^", "facecolors": "none", "edgecolors": "green", "linewidths": 1.8,
                "zorder": 6}, "landed at base"),
    "forced": ({"s": 130, "marker": "v", "facecolors": "none", "edgecolors": "darkorange", "linewidths": 2.0,
                "zorder": 6}, "forced landing"),
}


def _end_marker(rec, u):
    """(kind, x, y) of where a UAV's mission ended, None while it was still on it."""
    if rec.removed_pos is not None:
        return ("uav" if rec.removed_reason == UAV_COLLISION else "zone"), *rec.removed_pos[:2]
    if u["final_phase"] == PHASE_LANDED and rec.took_off:
        return ("forced" if u["outcome"] == "forced_landing" else "landed"), u["final_x"], u["final_y"]
    return None


def _draw_end_markers(ax, mon, uavs: list[dict], handles) -> None:
    """Where each mission ended; a fleet's map leaves out the landings at the base (its pads' colour says it)."""
    from matplotlib.lines import Line2D
    kinds = set()
    fleet = len(uavs) > MAX_UAV_LEGEND
    for rec, u in zip(mon.records, uavs):
        end = _end_marker(rec, u)
        if end is not None:
            kind, x, y = end
            if fleet and kind == "landed":
                continue
            style = END_MARKERS[kind][0]
            ax.scatter([x], [y], **(dict(style, s=style["s"] * 0.45) if fleet else style))
            kinds.add(kind)
    for kind, (style, label) in END_MARKERS.items():
        if kind in kinds:
            face = style.get("c", "none")
            handles.append(Line2D([], [], ls="", marker=style["marker"], ms=math.sqrt(style["s"]) * 0.8, mfc=face,
                                  mec=style["edgecolors"], mew=style.get("linewidths", 1.0), label=label))


def link_segments(links: dict | None, absent=()) -> list[tuple]:
    """The links of a moment (``comm_monitor.CommMonitor.links``) as map segments: ``(uav a, uav b, both ways,
    (xa, ya), (xb, yb))`` per pair that heard each other in at least one direction, a < b by name, without the
    UAVs in ``absent`` (removed by then)."""
    if not links:
        return []
    heard = {(r, s) for r, s in links["links"] if r not in absent and s not in absent and r != s}
    pos = links["positions"]
    out = []
    for a, b in sorted({tuple(sorted(p)) for p in heard}):
        out.append((a, b, (a, b) in heard and (b, a) in heard, tuple(pos[a][:2]), tuple(pos[b][:2])))
    return out


def _draw_links(ax, mon, handles) -> list[tuple]:
    """Strategy C's links at their moment, thin grey lines (gid ``comm_links``: solid both ways, dotted one way);
    returns the segments drawn."""
    from matplotlib.lines import Line2D

    from .comm_monitor import links_of
    links = links_of(getattr(mon, "ctx", None))
    if not links:
        return []
    t = links["time"]
    absent = {spec.name for spec, rec in zip(mon.cfg.uavs, mon.records)
              if rec.removed_time is not None and rec.removed_time <= t}
    segments = link_segments(links, absent)
    _add_links(ax, segments, 0.7)
    why = {"linksAt": "", "takeover": ", the first takeover", "drop": ", the first drop",
           "give_way": ", the first give-way"}.get(links["why"], "")
    handles.append(Line2D([], [], color="dimgray", lw=0.7,
                          label=f"heard each other at t={t:.1f} s{why} (dotted: one way)"))
    return segments


def _add_links(ax, segments, width: float) -> None:
    from matplotlib.collections import LineCollection
    for both, style in ((True, "solid"), (False, (0, (1, 2)))):
        chosen = [[pa, pb] for _, _, two, pa, pb in segments if two == both]
        if chosen:
            ax.add_collection(LineCollection(chosen, colors="dimgray", linewidths=width, linestyles=style,
                                             alpha=0.9, zorder=4, gid="comm_links" if both else "comm_links_one_way"))


def _links_inset(ax, segments) -> None:
    """Links within a small part of the map (at the ring of pads, where the first give-ways are) again in an inset
    zoomed on them, each UAV named."""
    pts = np.array([p for *_, pa, pb in segments for p in (pa, pb)], dtype=float)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if max(hi - lo) > 0.08 * max(x1 - x0, y1 - y0):
        return
    inset = ax.inset_axes([0.02, 0.70, 0.28, 0.28])
    _add_links(inset, segments, 1.0)
    named = {}
    for a, b, _, pa, pb in segments:
        named[a], named[b] = pa, pb
    for name, (x, y) in named.items():
        inset.plot([x], [y], "o", ms=3, color="black")
        inset.annotate(name, (x, y), xytext=(2, 2), textcoords="offset points", fontsize=6)
    half = max(max(hi - lo) / 2.0, 5.0) * 1.3
    mid = (lo + hi) / 2.0
    inset.set_xlim(mid[0] - half, mid[0] + half)
    inset.set_ylim(mid[1] - half, mid[1] + half)
    inset.set_aspect("equal")
    inset.tick_params(labelsize=6)
    inset.set_title("links (zoom)", fontsize=7)
    ax.indicate_inset_zoom(inset, edgecolor="dimgray")


def _draw_frame(ax, origin) -> None:
    """Axes, grid, scale bar (lower right, framed, so it never hides the base) and the frame's origin."""
    from matplotlib.font_manager import FontProperties
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.06)
    ax.autoscale_view()
    ax.set_xlabel("east [m]")
    ax.set_ylabel("north [m]")
    ax.grid(True, alpha=0.25)
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    L = _nice(max(x1 - x0, y1 - y0) / 6.0)
    ax.add_artist(AnchoredSizeBar(ax.transData, L, f"{L:g} m" if L < 1000 else f"{L / 1000:g} km",
                                  "lower right", pad=0.5, borderpad=0.6, sep=4, frameon=True, size_vertical=0,
                                  fontproperties=FontProperties(size=9)))
    lat0, lon0, _ = origin
    ax.text(0.0, -0.08, f"local east-north-up metres about the base {lat0:.6f}, {lon0:.6f} (WGS84)",
            transform=ax.transAxes, ha="left", va="top", fontsize=7, color="dimgray")


def map_title(cfg, total: dict) -> str:
    """Scenario and fleet; when the mission ended (the last landing or removal, which is not the end of a run
    that idled on to its stop time); the results."""
    n = total["uavs"]
    end = total["mission_end_time"]
    when = (f"mission ended at t={end:.1f} s (every UAV landed or removed)" if end is not None else
            f"mission unfinished when the run stopped at t={_f(total['end_time']):.1f} s")
    return (f"{cfg.scenario or 'UAV mission'} - strategy {cfg.strategy or '?'}, {n} UAV{'s' if n != 1 else ''}, "
            f"run {total['run_outcome']}\n{when}\n{total['uavs_successful']}/{n} UAVs successful, "
            f"{total['targets_visited']}/{total['targets_total']} targets photographed\n{_collisions(total)}")


def _collisions(total: dict) -> str:
    """Events and the UAVs they cost, each said as what it counts: a UAV-UAV collision takes out two UAVs."""
    lost = (total.get("outcomes") or {}).get(UAV_COLLISION, 0)
    zones = total["zone_collisions"]
    return (f"{total['uav_collisions']} UAV-UAV collision{'s' if total['uav_collisions'] != 1 else ''} "
            f"({lost} UAV{'s' if lost != 1 else ''} lost), {zones} zone incursion{'s' if zones != 1 else ''}")


def draw_map(mon, uavs: list[dict], total: dict, path: Path, traj=None) -> Path:
    map_figure(mon, uavs, total, traj).savefig(path)
    return path


def map_figure(mon, uavs: list[dict], total: dict, traj=None):
    """The figure of map.png."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    cfg = mon.cfg
    fig = Figure(figsize=(9.5, 9.0), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    handles = []
    _draw_zones(ax, cfg.zones, handles)
    _draw_targets(ax, cfg.targets, {t for u in uavs for t in u["visited_targets"]}, handles)
    # the base is a hollow square on top of everything: the pads, landings and collisions around it show
    # through it, and it stays visible under them
    ax.scatter([0.0], [0.0], s=220, marker="s", facecolors="none", edgecolors="black", linewidths=2.2, zorder=8)
    handles.append(Line2D([], [], ls="", marker="s", ms=10, mfc="none", mec="black", mew=2.2, label="base"))
    _draw_tracks(ax, mon, uavs, traj, handles)
    segments = _draw_links(ax, mon, handles)
    _draw_end_markers(ax, mon, uavs, handles)
    _draw_frame(ax, cfg.origin)
    if segments:
        _links_inset(ax, segments)
    # up to MAX_UAV_LEGEND UAVs the legend names every UAV (no labels on the map, where the pads' ring is too small for
    # them), beyond it every outcome; a long one is split into columns rather than running off the figure
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False,
              ncol=math.ceil(len(handles) / 40))
    ax.set_title(map_title(cfg, total), fontsize=10)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------------- replay
def _component_sources(mon) -> dict:
    """component -> the FMU it loads, from the run's plan (empty when the monitor ran without one)."""
    model = getattr(getattr(getattr(mon.ctx, "rt", None), "plan", None), "model", None)
    comps = getattr(model, "components", None) or {}
    return {name: getattr(c, "source", None) for name, c in comps.items()}


def write_run_replay(out_dir: Path, mon, uavs: list[dict], total: dict, traj) -> Path:
    """replay.html from what the run has in memory: the same page ``cosim-master replay`` writes from the run
    folder's files (uavstudy.replay)."""
    from .replay import REPLAY_FILE, replay_document, scene_from_config, write_replay
    events = getattr(mon.ctx, "events", None) or []
    photos = [{"uav": spec.name, "target": p["target"], "time": p["time"], "x": p["x"], "y": p["y"]}
              for spec, rec in zip(mon.cfg.uavs, mon.records) for p in rec.photos]
    doc = replay_document(scene_from_config(mon.cfg, _component_sources(mon)), traj, events, photos,
                          {u["uav"]: u["outcome"] for u in uavs}, _clean(total))
    return write_replay(out_dir / REPLAY_FILE, doc)


# ------------------------------------------------------------------------------- entry point
def write_outputs(out_dir, mon, run_outcome: str, products: str = "all") -> dict:
    """Write the mission outputs into out_dir (None: nothing written) and return the run.json summary.

    products="summary" (campaigns) writes photos.csv, summary.csv and summary.json only: no trajectory.csv,
    no map.png, which are the costly ones."""
    errors = []
    uavs = uav_summaries(mon, run_outcome)
    total = total_summary(mon, uavs, run_outcome)
    result = {"total": total, "uavs": {u["uav"]: u["outcome"] for u in uavs}}
    if out_dir is None or not Path(out_dir).is_dir():
        return _clean(result)
    out_dir = Path(out_dir)
    full = products != "summary"
    df = _read_results(out_dir, mon) if full else None
    traj = None
    try:
        if full:
            traj = trajectory_frame(mon, df)
            traj.to_csv(out_dir / "trajectory.csv", index=False)
    except Exception as exc:   # noqa: BLE001 - one failed output must not stop the others
        errors.append(f"trajectory.csv: {type(exc).__name__}: {exc}")
    try:
        if df is not None or mon.ctx is None or not write_photos_csv(mon, out_dir / "photos.csv"):
            photos_frame(mon, df).to_csv(out_dir / "photos.csv", index=False)
    except Exception as exc:   # noqa: BLE001
        errors.append(f"photos.csv: {type(exc).__name__}: {exc}")
    df = None       # the recorded columns are not needed further (a large fleet's are tens of MB)
    try:
        if not write_summary_csv(uavs, total, out_dir / "summary.csv"):
            summary_frame(uavs, total).to_csv(out_dir / "summary.csv", index=False)
    except Exception as exc:   # noqa: BLE001
        errors.append(f"summary.csv: {type(exc).__name__}: {exc}")
    try:
        if full:
            draw_map(mon, uavs, total, out_dir / "map.png", traj)
    except Exception as exc:   # noqa: BLE001
        errors.append(f"map.png: {type(exc).__name__}: {exc}")
    try:
        if full and traj is not None:
            write_run_replay(out_dir, mon, uavs, total, traj)
    except Exception as exc:   # noqa: BLE001
        errors.append(f"replay.html: {type(exc).__name__}: {exc}")
    if errors:
        result["output_errors"] = errors
    try:
        doc = {"total": total, "uavs": uavs, "zones": [z["name"] for z in mon.cfg.zones]}
        if errors:
            doc["output_errors"] = errors
        tmp = out_dir / "summary.json.tmp"
        tmp.write_text(json.dumps(_clean(doc), indent=2))
        tmp.replace(out_dir / "summary.json")
    except Exception as exc:   # noqa: BLE001
        result.setdefault("output_errors", []).append(f"summary.json: {type(exc).__name__}: {exc}")
    return _clean(result)
