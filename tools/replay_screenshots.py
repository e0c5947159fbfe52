"""Screenshots of `harmony view` for the docs: serve run directories, move the timeline to a step, and save what
headless Chromium (Debian's, driven by Playwright) shows.

    .venv/bin/python tools/replay_screenshots.py OUT.png RUN_DIR [RUN_DIR ...] [--phase carry | --push | --step N]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

from harmony_cli.view.replay import Replay
from harmony_cli.view.run_data import load_runs

ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking"]
ARGS += ["--disable-component-update", "--disable-sync", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def pick_step(steps, phase: str | None, push: bool, step: int | None) -> int:
    """The step to show: given, the middle of a phase, or the middle of the first push."""
    if step is not None:
        return step
    if phase is not None:
        return int(np.median(np.flatnonzero(steps["phase"] == phase)))
    if push:
        pushed = steps[[c for c in steps.columns if c.startswith("push_") and c.endswith("_N")]].abs().sum(axis=1)
        return int(np.median(np.flatnonzero(pushed > 0)))
    return 0


def still(page, out: Path, seconds: float = 60.0) -> None:
    """Screenshots a second apart until two are the same (objects fade in at the page's pace), at most `seconds`."""
    last, deadline = b"", time.monotonic() + seconds
    while time.monotonic() < deadline:
        page.wait_for_timeout(1_000)
        image = page.screenshot(path=str(out))
        if image == last:
            return
        last = image


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("out", type=Path)
    parser.add_argument("runs", type=Path, nargs="+")
    parser.add_argument("--phase")
    parser.add_argument("--push", action="store_true")
    parser.add_argument("--step", type=int)
    args = parser.parse_args()
    runs = load_runs(args.runs)
    step = pick_step(runs[0].steps, args.phase, args.push, args.step)
    replay = Replay(runs, port=8130, step=step)
    replay.slider.value = step
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=ARGS, headless=True)
            page = browser.new_page(viewport={"width": 1200, "height": 750})
            page.goto(replay.url)
            page.wait_for_selector("canvas", timeout=60_000)
            page.add_style_tag(content='[class*="Notification"] { display: none !important; }')  # software WebGL
            still(page, args.out)
            browser.close()
    finally:
        replay.close()
    print(args.out)


if __name__ == "__main__":
    main()
