"""`harmony view`: a short run replayed in headless Chromium (the robot drawn where its base was, moved by the
timeline), its self-contained export opened offline, its video rendered after the fact, replay.npz, bad input."""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest
import yaml
from browser import page, project, require_chromium, shot
from conftest import SMOKE, assert_exit_follows_outcome
from typer.testing import CliRunner

from harmony_cli.cli import app

runner = CliRunner()
# the smoke S made fast: the base drives ~0.5 m in the run's 1 s, enough to move it on screen
FAST = ["--set", "reference.duration=1.2", "--set", "reference.length=0.6", "--set", "reference.lateral=0.1"]
BASE_HEIGHT = 0.3  # [m] the EVA base box's centre above the floor


@pytest.fixture(scope="module")
def fast_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("view") / "run"
    result = runner.invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", *FAST])
    assert_exit_follows_outcome(result, out)
    return out


def robot_pixels(image: np.ndarray) -> np.ndarray:
    """Pixels darker than the white floor and its light grid (the robot's body and its shadow), in the 3-D view
    (left of the control panel, below the software-WebGL notice)."""
    mask = image.max(axis=2) < 170
    mask[:150], mask[:, 560:] = False, False
    return mask


def near(mask: np.ndarray, pixel: np.ndarray, radius: float = 25.0) -> float:
    """The fraction of `mask` within `radius` pixels of `pixel`."""
    yy, xx = np.mgrid[: mask.shape[0], : mask.shape[1]]
    return float(mask[(xx - pixel[0]) ** 2 + (yy - pixel[1]) ** 2 < radius**2].mean())


def centroid(image: np.ndarray) -> np.ndarray:
    """The robot's drawn pixels' mean (x, y)."""
    return np.argwhere(robot_pixels(image))[:, ::-1].mean(0)


def base_pixel(run, i: int, camera) -> np.ndarray:
    steps = run.steps
    return project([steps["q_base_x"].iloc[i], steps["q_base_y"].iloc[i], BASE_HEIGHT], *camera)


def settled(browser, path, ready, seconds: float = 40.0) -> np.ndarray:
    """Screenshots until `ready(image)` (the page loads meshes and fades them in at its own pace), at most
    `seconds`; the last one."""
    deadline = time.monotonic() + seconds
    image = shot(browser, path)
    while not ready(image) and time.monotonic() < deadline:
        browser.wait_for_timeout(250)
        image = shot(browser, path)
    return image


def test_served_page_draws_the_robot_at_its_base_and_the_timeline_moves_it(fast_run, tmp_path):
    """The served page draws the robot where the log puts its base, and moving the timeline moves it there."""
    require_chromium()
    from harmony_cli.view.replay import Replay, camera_for
    from harmony_cli.view.run_data import load_runs

    runs = load_runs([fast_run])
    replay, camera, last = Replay(runs, port=8123), camera_for(runs[0]), len(runs[0].times) - 1
    start, end = base_pixel(runs[0], 0, camera), base_pixel(runs[0], last, camera)
    try:
        with page() as browser:
            browser.goto(replay.url)
            browser.wait_for_selector("canvas", timeout=60_000)
            first = settled(browser, tmp_path / "first.png", lambda image: near(robot_pixels(image), start) > 0.5)
            replay.slider.value = last
            # ready when drawn near the end and moved: the two spots are close enough that a frame from before the
            # page redraws may already count as near the end
            moved = settled(
                browser,
                tmp_path / "last.png",
                lambda image: (
                    near(robot_pixels(image), end) > 0.5
                    and np.linalg.norm(centroid(image) - centroid(first)) > np.linalg.norm(end - start) / 3
                ),
            )
    finally:
        replay.close()
    assert first.std() > 20, "blank page"
    assert near(robot_pixels(first), start) > 0.5 and near(robot_pixels(moved), end) > 0.5
    shift = centroid(moved) - centroid(first)
    expected = end - start
    assert shift @ expected > 0.8 * np.linalg.norm(shift) * np.linalg.norm(expected), (shift, expected)
    assert np.linalg.norm(shift) > np.linalg.norm(expected) / 3, (shift, expected)


def test_a_run_logs_knots_plans_and_their_cost_in_replay_npz(fast_run):
    """A run writes replay.npz (q at every knot each step) and steps.csv says what logging it cost."""
    import pandas as pd

    steps = pd.read_csv(fast_run / "steps.csv")
    with np.load(fast_run / "replay.npz") as replay:
        assert replay["knot_q"].shape == (len(steps), 6, 18) and replay["knot_ref"].shape == (len(steps), 6, 2, 3)
        assert np.allclose(replay["knot_q"][:, 0, 0], steps["q_base_x"], atol=1e-4)  # knot 0 is the measured q
    assert (steps["previous_replay_ms"].iloc[1:] > 0).all()


@pytest.mark.slow
def test_exported_replay_opens_offline_from_a_copy(fast_run, tmp_path):
    """The exported .html, copied away from harmony, draws the robot in a browser with no network at all."""
    require_chromium()
    result = runner.invoke(app, ["view", str(fast_run), "--export", str(tmp_path / "replay.html"), "--port", "8124"])
    assert result.exit_code == 0, result.output
    alone = tmp_path / "elsewhere"
    alone.mkdir()
    shutil.copy(tmp_path / "replay.html", alone / "replay.html")
    requests: list[str] = []
    with page(offline=True) as browser:
        browser.on("request", lambda r: requests.append(r.url))
        browser.goto((alone / "replay.html").as_uri())
        browser.wait_for_selector("canvas", timeout=60_000)
        browser.wait_for_timeout(4_000)
        image = shot(browser, tmp_path / "export.png")
    assert all(url.startswith(("file:", "data:", "blob:")) for url in requests), requests
    assert image.std() > 20 and robot_pixels(image).sum() > 2_000


@pytest.mark.slow
def test_video_is_rendered_after_the_fact_from_the_logs(fast_run, tmp_path):
    """`--video` renders a run that recorded none: one frame per 0.1 s, the robot in view."""
    import imageio.v3 as iio

    result = runner.invoke(app, ["view", str(fast_run), "--video", str(tmp_path / "replay.gif")])
    assert result.exit_code == 0, result.output
    frames = iio.imread(tmp_path / "replay.gif", index=None)
    assert len(frames) == 10 and all(frame[..., :3].std() > 10 for frame in frames)


def test_a_directory_that_is_not_a_run_is_one_line_and_exit_2(tmp_path):
    """`harmony view` on a directory without steps.csv names it in one line, exit code 2."""
    result = runner.invoke(app, ["view", str(tmp_path), "--no-browser"])
    assert result.exit_code == 2 and str(tmp_path) in result.output and "Traceback" not in result.output
    assert "not a run directory" in result.output


def test_runs_of_different_scenes_are_refused(fast_run, tmp_path):
    """Overlaying runs of different scenes is refused in one line naming the odd run, exit code 2."""
    other = tmp_path / "other"
    shutil.copytree(fast_run, other)
    text = (other / "scenario.resolved.yaml").read_text()
    assert "tables: []" in text  # else the runs stay one scene and the page serves until stopped
    (other / "scenario.resolved.yaml").write_text(text.replace("tables: []", "tables: [{name: t, position: [3, 0]}]"))
    result = runner.invoke(app, ["view", str(fast_run), str(other), "--no-browser"])
    assert result.exit_code == 2 and str(other) in result.output and "not the scene of" in result.output


def test_a_mujoco_run_s_video_is_rendered_after_the_fact_in_mujoco(tmp_path):
    """`--video` of a MuJoCo run draws its logged states in MuJoCo: one frame per 0.1 s, the robot in view."""
    import imageio.v3 as iio

    out = tmp_path / "run"
    result = runner.invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", "--set", "sim.engine=mujoco", *FAST])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["view", str(out), "--video", str(tmp_path / "replay.gif")])
    assert result.exit_code == 0, result.output
    frames = iio.imread(tmp_path / "replay.gif", index=None)
    assert len(frames) == 10 and all(frame[..., :3].std() > 10 for frame in frames)
    assert np.abs(frames[-1].astype(int) - frames[0].astype(int)).max() > 50  # the robot moved between them


def test_a_video_of_a_run_whose_engine_this_python_lacks_is_refused_in_one_line(fast_run, tmp_path, monkeypatch):
    engine = yaml.safe_load((fast_run / "scenario.resolved.yaml").read_text())["sim"]["engine"]
    other = "mujoco" if engine == "pybullet" else "pybullet"
    monkeypatch.setattr("harmony_cli.commands.view.installed_engines", lambda: [other])
    result = runner.invoke(app, ["view", str(fast_run), "--video", str(tmp_path / "replay.gif")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert f"ran in {engine}, which this Python" in result.output and not (tmp_path / "replay.gif").exists()
