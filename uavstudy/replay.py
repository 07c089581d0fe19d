"""``replay.html``: a UAV run seen again, in one self-contained page (no network, no library: the page's own
JavaScript draws on a canvas).

Written beside ``map.png`` by every UAV run (``uavstudy.outputs``) and for an existing run folder by
``cosim-master replay RUN_FOLDER`` (through the ``uav`` scenario kind's ``write_replay``).  The page shows the
area in local metres (zones, targets with who photographed them and when, base, pads, scale), every UAV at the
chosen time with its recent trail, a time slider with play/pause, speed 1x-100x and steps to the previous/next
event, the events list (collisions, zone incursions, photos, mission events, ground-station commands; a click
jumps there) and, for the UAV clicked, its phase, mission state, speed, altitude and battery over time.

What the page holds (the one reference for docs/replay.md):

* events: every row of events.csv and every photo of photos.csv, times exact (as written there);
* tracks: trajectory.csv's rows, positions rounded to 1 cm, speed to 1 cm/s, battery to 0.01 %, times to 1 ms;
  all rows while the run has at most ``SAMPLE_BUDGET`` of them (every shipped mission), else every k-th row of
  each UAV with k = ceil(rows / SAMPLE_BUDGET), plus each UAV's first and last row and every row where its phase
  or mission state changes (so a 256-UAV hour keeps ~5 s trails, and every state change is where it happened).
  Between two kept rows the page interpolates linearly.  Series are stored as integer differences (a cruising
  UAV's rows are a few digits each), which keeps a 256-UAV mission under 10 MB.
"""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from master.errors import ScenarioError

REPLAY_FILE = "replay.html"
TEMPLATE = Path(__file__).with_name("replay_page.html")
#: rows of trajectory.csv kept in full; beyond it every k-th (module docstring)
SAMPLE_BUDGET = 400_000
#: the data's place in the template
DATA_MARK = "/*REPLAY_DATA*/null"

#: quantisation of the series: value * scale, rounded to an integer
SCALES = {"t": 1000.0, "x": 100.0, "y": 100.0, "z": 100.0, "speed": 100.0, "soc": 10000.0}


@dataclass
class Scene:
    """What the page draws besides the tracks: the area, the fleet and the run's identity."""
    scenario: str
    strategy: str
    origin: tuple
    targets: list                     # [[x, y], ...] ENU m, map order
    zones: list                       # [{"name", "polygon": [[x, y], ...]}]
    uavs: list                        # [{"name", "home": [x, y], "vehicle": "sitl" | "point-mass" | None}]
    extra: dict = field(default_factory=dict)


def vehicle_of(source: str | None) -> str | None:
    """'sitl' or 'point-mass' from the FMU a UAV's dynamics component loads (None: not known)."""
    if not source:
        return None
    from .build import SITL_FMU
    return "sitl" if Path(str(source)).name == SITL_FMU else "point-mass"


def scene_from_config(cfg, sources: dict | None) -> Scene:
    """The scene of a monitor configuration; ``sources``: component -> FMU source (the SSD's), for the vehicle."""
    from .names import DYNAMICS, component
    sources = sources or {}
    return Scene(
        scenario=cfg.scenario, strategy=cfg.strategy, origin=tuple(float(v) for v in cfg.origin),
        targets=np.asarray(cfg.targets, dtype=float).reshape(-1, 2).tolist(),
        zones=[{"name": z["name"], "polygon": np.asarray(z["polygon"], dtype=float).tolist()} for z in cfg.zones],
        uavs=[{"name": u.name, "home": [float(u.home[0]), float(u.home[1])],
               "vehicle": vehicle_of(sources.get(component(u.name, DYNAMICS)))} for u in cfg.uavs])


# ------------------------------------------------------------------------------------------ encoding
def _deltas(values: np.ndarray, scale: float) -> list:
    """Integer differences of round(values * scale); a NaN is null and leaves the running value as it was."""
    q = np.round(np.asarray(values, dtype=float) * scale)
    ok = np.isfinite(q)
    if ok.all():
        return np.diff(q.astype(np.int64), prepend=0).tolist()
    if not ok.any():
        return []
    out, prev = [], 0
    for v, good in zip(q.tolist(), ok.tolist()):
        if good:
            out.append(int(v) - prev)
            prev = int(v)
        else:
            out.append(None)
    return out


def _changes(codes: np.ndarray) -> list:
    """[[row, code], ...] at the first row and every row whose code differs from the row before (-1: no value)."""
    if not codes.size:
        return []
    starts = np.flatnonzero(np.concatenate(([True], codes[1:] != codes[:-1])))
    return np.stack([starts, codes[starts]], axis=1).tolist()


def _kept_rows(n: int, stride: int, *change_series) -> np.ndarray:
    """Rows kept of a UAV's n rows: every stride-th, the last, and every row where a series changes."""
    if stride <= 1 or n <= 2:
        return np.arange(n)
    keep = np.zeros(n, dtype=bool)
    keep[::stride] = True
    keep[-1] = True
    for a in change_series:
        a = np.asarray(a)
        keep[1:] |= a[1:] != a[:-1]
    return np.flatnonzero(keep)


def _codes(traj, column: str) -> tuple[np.ndarray, list]:
    """The column's names as integer codes (-1: empty) and the names, in the order they first appear."""
    import pandas as pd
    if column not in traj:
        return np.full(len(traj), -1, dtype=np.int64), []
    codes, names = pd.factorize(traj[column].to_numpy(object), use_na_sentinel=True)
    return codes.astype(np.int64), [str(v) for v in names]


def encode_tracks(traj, names: list[str], budget: int = SAMPLE_BUDGET) -> tuple[list, dict, int]:
    """The page's tracks from a trajectory table (trajectory.csv's columns and row order), in the order of
    ``names``; the phase and mission-state names the tracks' codes index; the stride used."""
    import pandas as pd
    stride = max(1, math.ceil(len(traj) / budget)) if budget else 1
    phase, phases = _codes(traj, "phase")
    state, states = _codes(traj, "mission_state")
    uav_code, uavs = pd.factorize(traj["uav"].to_numpy(object)) if len(traj) else (np.zeros(0, np.int64), [])
    order = np.argsort(uav_code, kind="stable")           # each UAV's rows together, in the table's order
    bounds = np.searchsorted(uav_code[order], np.arange(len(uavs) + 1))
    where = {str(u): order[bounds[k]:bounds[k + 1]] for k, u in enumerate(uavs)}
    columns = {col: (traj["time" if col == "t" else col].to_numpy(float)
                     if ("time" if col == "t" else col) in traj else np.full(len(traj), np.nan))
               for col in ("t", "x", "y", "z", "speed", "soc")}
    status = traj["status"].to_numpy(object) if "status" in traj else None
    tracks = []
    for name in names:
        idx = where.get(name)
        if idx is None or not idx.size:
            tracks.append(None)
            continue
        idx = idx[_kept_rows(idx.size, stride, phase[idx], state[idx])]
        tr = {"n": int(idx.size)}
        for col, values in columns.items():
            tr[col] = _deltas(values[idx], SCALES[col])
        tr["phase"] = _changes(phase[idx])
        tr["state"] = _changes(state[idx])
        if status is not None:
            tr["removed"] = bool(status[idx[-1]] == "removed")
        tracks.append(tr)
    return tracks, {"phases": phases, "states": states}, stride


def _num(v):
    """A CSV cell or value as a float (None when empty or not a number)."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def encode_events(events: list[dict], photos: list[dict], index: dict) -> list:
    """[time, type, event, uav index (-1: none), other, x, y, detail] for every event and photo, by time (events
    before photos at equal times; events in their file's order, photos by UAV)."""
    rows = []
    for e in events:
        t = _num(e.get("time"))
        if t is None:
            continue
        other = e.get("other")
        rows.append((t, 0, 0, len(rows), [t, str(e.get("type") or ""), str(e.get("event") or ""),
                                       index.get(e.get("uav"), -1),
                                       "" if other is None or other != other else str(other),
                                       _num(e.get("x")), _num(e.get("y")), str(e.get("detail") or "")
                                       if e.get("detail") == e.get("detail") else ""]))
    for p in photos:
        t = _num(p.get("time"))
        if t is None:
            continue
        tgt = _num(p.get("target"))
        tgt = int(tgt) if tgt is not None else -1
        rows.append((t, 1, index.get(p.get("uav"), -1), len(rows), [t, "photo", "photo", index.get(p.get("uav"), -1),
                                       str(tgt) if tgt >= 0 else "", _num(p.get("x")), _num(p.get("y")),
                                       f"photo of target {tgt}" if tgt >= 0 else "photo (target unknown)"]))
    rows.sort(key=lambda r: r[:4])
    return [r[4] for r in rows]


def replay_document(scene: Scene, traj, events: list[dict], photos: list[dict], outcomes: dict, total: dict,
                    budget: int = SAMPLE_BUDGET) -> dict:
    """Everything the page shows, as the JSON it embeds."""
    names = [u["name"] for u in scene.uavs]
    index = {n: k for k, n in enumerate(names)}
    tracks, tables, stride = encode_tracks(traj, names, budget)
    rows = int(len(traj))
    rule = ("every recorded row of trajectory.csv" if stride == 1 else
            f"every {stride}th recorded row of each UAV (trajectory.csv has {rows} rows, more than "
            f"{budget}), plus its first and last row and every change of phase or mission state")
    return {
        "format": 1,
        "scenario": scene.scenario, "strategy": scene.strategy, "origin": list(scene.origin),
        "targets": scene.targets, "zones": scene.zones,
        "uavs": [{**u, "outcome": outcomes.get(u["name"])} for u in scene.uavs],
        "total": {k: total.get(k) for k in ("run_outcome", "end_time", "mission_end_time", "uavs",
                                             "uavs_successful", "targets_total", "targets_visited",
                                             "uav_collisions", "zone_collisions")},
        "scales": SCALES, "tracks": tracks, **tables,
        "sampling": {"stride": stride, "rows": rows, "rule": rule},
        "events": encode_events(events, photos, index),
    }


def _json(doc: dict) -> str:
    # the tracks are integers and None only (encode_tracks): a walk over their million items would cost more than
    # the rest of the page
    clean = {k: (v if k == "tracks" else _finite(v)) for k, v in doc.items()}
    text = json.dumps(clean, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    # inside <script>: "</" would end the element, and U+2028/9 are line ends to older parsers
    return text.replace("</", "<\\/").replace("\u2028", "\\u2028").replace("\u2029", "\\u2029")


def _finite(o):
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    if isinstance(o, np.generic):
        o = o.item()
    if isinstance(o, float) and not math.isfinite(o):
        return None
    return o


def write_replay(path: Path, doc: dict) -> Path:
    """The page with ``doc`` in it, written atomically."""
    page = TEMPLATE.read_text(encoding="utf-8")
    if DATA_MARK not in page:
        raise RuntimeError(f"{TEMPLATE.name} has no data mark {DATA_MARK!r}")
    title = f"{doc.get('scenario') or 'UAV mission'} - replay"
    page = page.replace("<title>UAV mission replay</title>",
                        f"<title>{_html_text(title)}</title>", 1).replace(DATA_MARK, _json(doc), 1)
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(page, encoding="utf-8")
    tmp.replace(path)
    return path


def _html_text(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


# ------------------------------------------------------------------------------------------ an existing run folder
def _read_csv(path: Path) -> list[dict]:
    if not path.is_file():
        return []
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _ssd_bytes(scenario: Path) -> bytes:
    """The SystemStructure.ssd of an .ssp archive, an unpacked SSP folder or an .ssd file."""
    import zipfile
    if scenario.is_dir():
        scenario = scenario / "SystemStructure.ssd"
    if zipfile.is_zipfile(scenario):
        with zipfile.ZipFile(scenario) as z:
            try:
                return z.read("SystemStructure.ssd")
            except KeyError:
                raise ScenarioError("archive has no SystemStructure.ssd", file=str(scenario)) from None
    return scenario.read_bytes()


def scene_from_ssp(scenario: Path) -> Scene:
    """The scene from the UAV monitor annotation of a UAV scenario's SSD (and its components' FMUs)."""
    from lxml import etree

    from .monitor_config import parse_config
    from .names import MONITOR_TYPE
    try:
        root = etree.fromstring(_ssd_bytes(scenario))
    except (OSError, etree.XMLSyntaxError) as exc:
        raise ScenarioError(f"cannot read the scenario: {exc}", file=str(scenario)) from None
    ann = next((a for a in root.iter("{*}Annotation") if a.get("type") == MONITOR_TYPE), None)
    if ann is None:
        raise ScenarioError(f"not a UAV scenario: its SSD has no {MONITOR_TYPE} annotation", file=str(scenario))
    cfg = parse_config(ann, str(scenario))
    sources = {c.get("name"): c.get("source") for c in root.iter("{*}Component")}
    return scene_from_config(cfg, sources)


def _scenario_of(run_dir: Path, meta: dict, given: Path | None) -> Path:
    """The SSP a run flew: the one given, else the one run.json names (as written: relative to where the run was
    started, so also tried from the run folder and each folder above it), else the run folder's own scenario.ssp
    (a campaign run that kept it)."""
    if given is not None:
        if not given.exists():
            raise ScenarioError("scenario not found", file=str(given), element="--scenario")
        return given
    named = meta.get("scenario")
    tried = []
    if named:
        p = Path(named)
        here = run_dir.resolve()
        tried = [p] if p.is_absolute() else [p, *(folder / p for folder in (here, *here.parents))]
    tried.append(run_dir / "scenario.ssp")
    for p in tried:
        if p.exists():
            return p
    raise ScenarioError(f"cannot find the scenario the run flew ({named or 'not named in run.json'}); "
                        "give it with --scenario FILE.ssp", file=str(run_dir / "run.json"))


def replay_run_folder(run_dir, scenario=None) -> Path:
    """Write ``replay.html`` into a finished UAV run folder from its files (trajectory.csv, events.csv,
    photos.csv, summary.json, run.json) and the SSP it flew."""
    import pandas as pd
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise ScenarioError("not a folder", file=str(run_dir))
    meta_path = run_dir / "run.json"
    try:
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise ScenarioError(f"not a run folder: cannot read run.json ({type(exc).__name__})",
                            file=str(run_dir)) from None
    traj_path = run_dir / "trajectory.csv"
    if not traj_path.is_file():
        raise ScenarioError("the run folder has no trajectory.csv (a campaign run that kept its summary only, "
                            "or not a UAV run)", file=str(run_dir))
    summary = {}
    if (run_dir / "summary.json").is_file():
        try:
            summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
        except ValueError:
            summary = {}
    scene = scene_from_ssp(_scenario_of(run_dir, meta, Path(scenario) if scenario else None))
    sources = {name: f.get("source") for name, f in (meta.get("fmus") or {}).items()}
    if any(u["vehicle"] is None for u in scene.uavs):
        from .names import DYNAMICS, component
        for u in scene.uavs:
            u["vehicle"] = u["vehicle"] or vehicle_of(sources.get(component(u["name"], DYNAMICS)))
    traj = pd.read_csv(traj_path, keep_default_na=False, na_values=[""])
    outcomes = {u.get("uav"): u.get("outcome") for u in summary.get("uavs") or []}
    total = dict(summary.get("total") or {})
    total.setdefault("run_outcome", meta.get("outcome"))
    doc = replay_document(scene, traj, _read_csv(run_dir / "events.csv"), _read_csv(run_dir / "photos.csv"),
                          outcomes, total)
    return write_replay(run_dir / REPLAY_FILE, doc)
