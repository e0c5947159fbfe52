"""Headless Chromium (Debian's /usr/bin/chromium, driven by Playwright) for the replay tests: screenshots of a
page, and where a world point lands in them. Absent Chromium skips the test, unless HARMONY_REQUIRE_BROWSER is
set (CI), where it fails."""

from __future__ import annotations

import os
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

CHROMIUM = "/usr/bin/chromium"
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--use-angle=swiftshader",  # WebGL in software: no GPU here
    "--enable-unsafe-swiftshader",
]
SIZE = (900, 600)


def require_chromium() -> None:
    """Skip without Chromium or Playwright, with the reason; fail instead when HARMONY_REQUIRE_BROWSER is set."""
    missing = [what for what, ok in ((CHROMIUM, Path(CHROMIUM).exists()), ("playwright", _has_playwright())) if not ok]
    if missing:
        reason = f"{' and '.join(missing)} missing (apt-get install chromium; pip install -e '.[test]')"
        if os.environ.get("HARMONY_REQUIRE_BROWSER"):
            pytest.fail(reason)
        pytest.skip(reason)


def _has_playwright() -> bool:
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return False
    return True


@contextmanager
def page(offline: bool = False):
    """A Playwright page of headless Chromium (a fresh profile; `offline`: no network, not even localhost)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS, headless=True)
        context = browser.new_context(viewport={"width": SIZE[0], "height": SIZE[1]}, offline=offline)
        try:
            yield context.new_page()
        finally:
            browser.close()


def shot(page, path: Path) -> np.ndarray:
    """A screenshot as an (h, w, 3) array (also saved to `path`)."""
    import imageio.v3 as iio

    page.screenshot(path=str(path))
    return iio.imread(path)[..., :3]


def project(point, position, look_at, size=SIZE, fov_deg: float = 75.0) -> np.ndarray:
    """Pixel (x, y) of a world point for a camera at `position` looking at `look_at`, z up (three.js's
    perspective: vertical field of view, the canvas filling the page)."""
    forward = np.asarray(look_at, float) - np.asarray(position, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point, float) - np.asarray(position, float)
    x, y, z = d @ right, d @ up, d @ forward
    f = (size[1] / 2) / np.tan(np.deg2rad(fov_deg) / 2)
    return np.array([size[0] / 2 + f * x / z, size[1] / 2 - f * y / z])
