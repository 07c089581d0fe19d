"""What replay.html costs: its size and the time to write it, per run folder, as a table.

    python bench/bench_replay.py RUN_DIR [RUN_DIR ...]      # finished UAV runs (each keeps trajectory.csv)
    python bench/bench_replay.py RUN_DIR --scenario X.ssp   # when run.json's scenario path no longer finds it

Columns: UAVs, trajectory.csv rows, the run's wall time (run.json), the time the run spends writing the page
(``replay_document`` + ``write_replay`` on the trajectory table it already holds, best of 3: what
``uavstudy.outputs.write_run_replay`` adds to a run), its share of the run's wall time, the page's size with the
rows it keeps, the size when the sampling rule thins the same run to a third (as a run three times longer would be
thinned: the page of such a fleet stays near ``SAMPLE_BUDGET`` rows), the time ``cosim-master replay`` takes from
the folder's files (CSV reading included) and, where Playwright and Chromium are installed, the time headless
Chromium takes to open the page until it has drawn.
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _best(fn, n=3):
    best = math.inf
    for _ in range(n):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def _open_time(page: Path) -> float | None:
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        return None
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    if not Path(chromium).is_file():
        return None
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu", "--disable-quic"])
        pg = b.new_context(offline=True, viewport={"width": 1400, "height": 860}).new_page()
        t = time.perf_counter()
        pg.goto(page.as_uri())
        pg.wait_for_function("window.replay !== undefined")
        took = time.perf_counter() - t
        b.close()
    return took


def measure(run_dir: Path, scenario: Path | None) -> dict:
    import pandas as pd

    from uavstudy.replay import (REPLAY_FILE, SAMPLE_BUDGET, _read_csv, _scenario_of, replay_document,
                                 replay_run_folder, scene_from_ssp, write_replay)
    meta = json.loads((run_dir / "run.json").read_text())
    summary = json.loads((run_dir / "summary.json").read_text())
    traj = pd.read_csv(run_dir / "trajectory.csv", keep_default_na=False, na_values=[""])
    scene = scene_from_ssp(_scenario_of(run_dir, meta, scenario))
    events, photos = _read_csv(run_dir / "events.csv"), _read_csv(run_dir / "photos.csv")
    outcomes = {u["uav"]: u["outcome"] for u in summary["uavs"]}
    with tempfile.TemporaryDirectory() as tmp:
        page = Path(tmp) / REPLAY_FILE

        def write(budget=SAMPLE_BUDGET):
            write_replay(page, replay_document(scene, traj, events, photos, outcomes, summary["total"], budget))
        in_run = _best(write)
        size = page.stat().st_size
        write(max(1, len(traj) // 3))
        thinned = page.stat().st_size
        write()
        opened = _open_time(page)
    copy = Path(tempfile.mkdtemp()) / run_dir.name
    shutil.copytree(run_dir, copy, ignore=shutil.ignore_patterns("results.*"))
    cli = _best(lambda: replay_run_folder(copy, scenario or _scenario_of(run_dir, meta, None)), n=1)
    shutil.rmtree(copy.parent)
    return {"run": run_dir.name, "uavs": len(scene.uavs), "rows": len(traj), "run_s": meta.get("wall_time_s"),
            "in_run_s": in_run, "size": size, "thinned": thinned, "cli_s": cli, "open_s": opened}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="finished UAV run folders")
    ap.add_argument("--scenario", type=Path, default=None, help="the SSP the runs flew (default: run.json's)")
    a = ap.parse_args(argv)
    rows = [measure(r, a.scenario) for r in a.runs]
    head = ("| run | UAVs | rows | run wall s | replay in the run s | share | replay.html | thinned to 1/3 "
            "| cosim-master replay s | Chromium opens s |")
    print(head)
    print("|---" * (head.count("|") - 1) + "|")
    for r in rows:
        share = f"{100 * r['in_run_s'] / r['run_s']:.1f} %" if r["run_s"] else "-"
        opened = f"{r['open_s']:.2f}" if r["open_s"] is not None else "-"
        print(f"| {r['run']} | {r['uavs']} | {r['rows']} | {r['run_s']:.1f} | {r['in_run_s']:.3f} | {share} "
              f"| {r['size'] / 1e6:.2f} MB | {r['thinned'] / 1e6:.2f} MB | {r['cli_s']:.2f} | {opened} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
