"""replay.html in a real browser: Debian's headless Chromium (installed by .ci/run), driven by Playwright, the page
opened from a file:// URL with the network off.  The run is the shipped 4-UAV zones mission, stopped at 60 s (its
first four photos fall between 53 and 60 s).  Skipped, with the reason, where Chromium or Playwright is missing."""
import math
import os
import shutil
from pathlib import Path

import pandas as pd
import pytest

from master.runner import run
from uavstudy.replay import REPLAY_FILE

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = os.environ.get("COSIM_MASTER_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]

sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright (the test extra) is not installed")
if not Path(CHROMIUM).is_file():
    pytest.skip(f"no Chromium at {CHROMIUM} (.ci/run installs Debian's chromium package)", allow_module_level=True)


@pytest.fixture(scope="module")
def mission(tmp_path_factory):
    return run(ROOT / "ssp" / "paper_zones_4uav_B.ssp", output=tmp_path_factory.mktemp("replay") / "run",
               stop_time=60.0).output_dir


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS)     # a fresh profile of its own each launch
        yield b
        b.close()


@pytest.fixture
def page(browser, mission):
    """The page, offline: every request is recorded, and any that is not the page itself is refused."""
    context = browser.new_context(offline=True, viewport={"width": 1280, "height": 800})
    requests, problems = [], []
    context.route("**/*", lambda route: (requests.append(route.request.url),
                                         route.continue_() if route.request.url.startswith("file://")
                                         else route.abort()))
    pg = context.new_page()
    pg.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type in ("error", "warning")
          else None)
    pg.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    url = (mission / REPLAY_FILE).as_uri()
    pg.goto(url)
    pg.wait_for_function("window.replay !== undefined")
    yield pg
    assert problems == []
    assert requests == [url]        # the page and nothing else
    context.close()


def test_slider_shows_the_positions_of_trajectory_csv(page, mission):
    traj = pd.read_csv(mission / "trajectory.csv")
    t = 42.0
    page.locator("#slider").fill(str(t))
    assert page.evaluate("replay.time()") == t
    assert page.locator("#time").inner_text().startswith("t = 42.0 s")
    rows = traj[traj["time"] == t]
    assert len(rows) == 4
    for r in rows.itertuples():
        s = page.evaluate(f"replay.state({r.uav!r})")
        # the page keeps positions to 1 cm, speeds to 1 cm/s and the battery to 0.01 % (uavstudy/replay.py)
        assert max(abs(s["x"] - r.x), abs(s["y"] - r.y), abs(s["z"] - r.z)) <= 0.005 + 1e-9, r.uav
        assert abs(s["speed"] - r.speed) <= 0.005 + 1e-9 and abs(s["soc"] - r.soc) <= 0.00005 + 1e-9
        assert (s["phase"], s["state"], s["removed"]) == (r.phase, r.mission_state, False)
    # half-way between two recorded rows the page is half-way between them
    page.locator("#slider").fill("42.5")
    nxt = traj[traj["time"] == 43.0].set_index("uav")
    for r in rows.itertuples():
        s = page.evaluate(f"replay.state({r.uav!r})")
        assert math.isclose(s["x"], (r.x + nxt.loc[r.uav, "x"]) / 2, abs_tol=0.006)


def test_clicking_an_event_jumps_to_its_time(page, mission):
    photos = pd.read_csv(mission / "photos.csv")
    first = photos.iloc[0]                  # uav4 photographs target 19 at t = 53.4 s
    row = page.locator(".ev.photo").first
    assert row.inner_text().startswith(f"{first.time:.1f} s")
    row.click()
    assert page.evaluate("replay.time()") == first.time
    assert float(page.locator("#slider").input_value()) == first.time
    assert "current" in row.get_attribute("class")
    assert page.evaluate("replay.selected()") == int(first.uav[3:]) - 1
    assert page.locator("#uavinfo").inner_text().split()[0] == first.uav
    # the next-event button goes on to the event after it
    events = pd.read_csv(mission / "events.csv")
    later = sorted([*events["time"][events["time"] > first.time], *photos["time"][photos["time"] > first.time]])
    page.locator("#next").click()
    assert page.evaluate("replay.time()") == later[0]


def test_clicking_a_uav_on_the_map_shows_its_state(page, mission):
    traj = pd.read_csv(mission / "trajectory.csv")
    page.evaluate("replay.setTime(30)")
    r = traj[(traj["time"] == 30.0) & (traj["uav"] == "uav2")].iloc[0]
    xy = page.evaluate(f"replay.screen({r.x}, {r.y})")
    box = page.locator("#map").bounding_box()
    page.mouse.click(box["x"] + xy[0], box["y"] + xy[1])
    assert page.evaluate("replay.selected()") == 1
    info = page.locator("#uavinfo").inner_text()
    assert "uav2" in info and f"{r.speed:.2f} m/s" in info and f"{100 * r.soc:.1f} %" in info
    assert r.mission_state in info and "point-mass" in info


def test_sitl_vehicles_are_marked(browser, mission, tmp_path):
    """The same run's page with uav2 said to be a SITL vehicle (as a run with ``vehicle: [point_mass, sitl, ...]``
    writes it): its label, its entry in the UAV list and its panel say so; the others stay point-mass."""
    import json
    import re

    from uavstudy.replay import write_replay
    text = (mission / REPLAY_FILE).read_text(encoding="utf-8")
    doc = json.loads(re.search(r'id="replay-data" type="application/json">(.*?)</script>', text, re.S).group(1)
                     .replace("<\\/", "</"))
    doc["uavs"][1]["vehicle"] = "sitl"
    page_path = write_replay(tmp_path / REPLAY_FILE, doc)
    pg = browser.new_context(offline=True).new_page()
    pg.goto(page_path.as_uri())
    options = pg.locator("#uavsel option").all_inner_texts()
    assert [o.split(" ")[0:2] for o in options[1:3]] == [["uav1", "\u2013"], ["uav2", "(SITL)"]]
    pg.evaluate("replay.select(1)")
    assert "ArduCopter SITL" in pg.locator("#uavinfo").inner_text()
    pg.evaluate("replay.select(0)")
    assert "point-mass model" in pg.locator("#uavinfo").inner_text()
    assert "1 SITL vehicle" in pg.locator("#subtitle").inner_text()
    pg.context.close()


def test_play_runs_time_forward_and_pause_stops_it(page):
    page.locator("#speed").select_option("100")
    page.locator("#play").click()
    page.wait_for_function("replay.time() > 20")          # 100x: a fraction of a second
    page.locator("#play").click()
    stopped = page.evaluate("replay.time()")
    assert page.locator("#play").inner_text() == "play"
    page.wait_for_timeout(300)
    assert page.evaluate("replay.time()") == stopped
