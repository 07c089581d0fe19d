"""docs/replay.png: replay.html of the shipped 4-UAV zones mission, strategy A, at its second collision.

    python bench/replay_screenshot.py             # flies ssp/paper_zones_4uav_A.ssp (2 s), writes docs/replay.png

The page is opened in headless Chromium (Debian's, driven by Playwright) offline, the collision is clicked in the
events list (which selects the UAV and jumps to the time) and the map is zoomed twice about the UAV.
"""
from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> int:
    from playwright.sync_api import sync_playwright

    from master.runner import run
    out = Path(tempfile.mkdtemp()) / "run"
    run(ROOT / "ssp" / "paper_zones_4uav_A.ssp", output=out)
    chromium = shutil.which("chromium") or "/usr/bin/chromium"
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu", "--disable-quic"])
        page = b.new_context(offline=True, viewport={"width": 1360, "height": 800}).new_page()
        page.goto((out / "replay.html").as_uri())
        page.locator(".ev.collision").nth(1).click()
        state = page.evaluate("replay.state('uav2')")
        x, y = page.evaluate(f"replay.screen({state['x']}, {state['y']})")
        box = page.locator("#map").bounding_box()
        page.mouse.move(box["x"] + x, box["y"] + y)
        for _ in range(2):
            page.mouse.wheel(0, -300)
        page.mouse.move(box["x"] + 5, box["y"] + box["height"] - 5)      # no tooltip in the picture
        page.wait_for_timeout(200)
        page.screenshot(path=str(ROOT / "docs" / "replay.png"))
        b.close()
    shutil.rmtree(out.parent)
    print(f"wrote {ROOT / 'docs' / 'replay.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
