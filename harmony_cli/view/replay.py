"""`harmony view`: runs of one scene replayed in a viser page, one timeline for all: a step slider, play / pause
and speed, the phase, and synced time series (loop time, pad forces, clearance). `export` writes the same replay
as one self-contained .html (viser's client with the recording inlined), for readers without harmony."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import numpy as np
import viser
import viser.uplot as uplot

from harmony_cli.sim.video import frame_every
from harmony_cli.view.run_data import RunData
from harmony_cli.view.scene import RunScene

SPEEDS = ("0.25x", "0.5x", "1x", "2x", "4x")
EXPORT_FPS = 10.0  # frames per simulated second in an exported replay
SERIES_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728")


def camera_for(run: RunData, step: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A 3/4 view (position, look-at) that frames the base's whole path, or the robot at `step`."""
    x, y = run.base_xy()
    if step is not None:
        x, y = x[step : step + 1], y[step : step + 1]
    centre = np.array([np.nanmean(x), np.nanmean(y), 0.6])
    reach = max(2.5, 1.2 * float(np.nanmax(np.hypot(x - centre[0], y - centre[1]))) + 2.0)
    return centre + reach * np.array([-0.8, -1.0, 0.7]), centre


class Replay:
    """A viser server showing `runs` (the first's timeline drives them all, by time); the camera frames the first
    run's whole path, or its robot at `step`."""

    def __init__(self, runs: list[RunData], port: int = 8080, host: str = "127.0.0.1", step: int | None = None):
        self.runs = runs
        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.server.scene.set_up_direction("+z")
        position, look_at = camera_for(runs[0], step)
        self.server.initial_camera.position, self.server.initial_camera.look_at = position, look_at
        self.server.scene.add_grid("/ground", width=20, height=20, cell_size=0.5, position=(0, 0, 0))
        self.scenes = [RunScene(self.server, run, k) for k, run in enumerate(runs)]
        self.times = runs[0].times
        self._gui()
        self.show(0)

    @property
    def url(self) -> str:
        return f"http://{self.server.get_host()}:{self.server.get_port()}"

    def _gui(self) -> None:
        gui, n = self.server.gui, len(self.times)
        names = "  \n".join(f"**run{k}**: {run.path.name}" for k, run in enumerate(self.runs))
        gui.add_markdown(names)
        self.phase = gui.add_markdown("")
        self.slider = gui.add_slider("step", min=0, max=n - 1, step=1, initial_value=0)
        self.playing = gui.add_checkbox("play", initial_value=False)
        self.speed = gui.add_dropdown("speed", SPEEDS, initial_value="1x")
        self.slider.on_update(lambda _: self.show(int(self.slider.value)))
        self.plots = [self._plot(title, columns) for title, columns in self._series().items()]

    def _series(self) -> dict[str, list[str]]:
        """Time series per plot (the first run's columns that exist)."""
        steps = self.runs[0].steps
        forces = [f"{h}_force_normal_N" for h in self.runs[0].hands]
        clearance = [c for c in steps.columns if c.startswith("clearance_robot_")][:3]
        series = {"loop [ms]": ["loop_ms"], "pad force [N]": forces, "clearance [m]": clearance}
        return {title: [c for c in columns if c in steps] for title, columns in series.items() if columns}

    def _plot(self, title: str, columns: list[str]) -> viser.GuiUplotHandle:
        steps = self.runs[0].steps
        data = (self.times, *(steps[c].to_numpy(dtype=float) for c in columns))
        series = (uplot.Series(label="t [s]"),) + tuple(
            uplot.Series(label=c, stroke=SERIES_COLOURS[j % len(SERIES_COLOURS)], width=1.5)
            for j, c in enumerate(columns)
        )
        scales = {"x": uplot.Scale(time=False)}  # seconds from the start, not dates
        return self.server.gui.add_uplot(data, series, title=title, scales=scales, aspect=2.0)

    def show(self, i: int) -> None:
        """Every run at the first run's time of step i; the phase, and the plots' cursor."""
        t = self.times[i]
        for scene in self.scenes:
            scene.show(min(int(np.searchsorted(scene.run.times, t - 1e-9)), len(scene.run.times) - 1))
        steps = self.runs[0].steps
        phase = steps["phase"].iloc[i] if "phase" in steps else ""
        self.phase.content = f"t = {t:.2f} s &nbsp; step {i}" + (f" &nbsp; phase **{phase}**" if phase else "")
        x, y = self.runs[0].base_xy()
        label = f"{t:.1f} s" + (f"  {phase}" if phase else "")  # in the scene too: an export keeps it
        self.server.scene.add_label("/phase", label, position=(float(x[i]), float(y[i]), 2.0))

    def play(self, stop: threading.Event) -> None:
        """Advance the slider while `play` is ticked, at the chosen speed, until `stop`."""
        dt = self.runs[0].control_dt
        while not stop.is_set():
            if self.playing.value:
                speed = float(self.speed.value.rstrip("x"))
                step = max(1, round(speed * 0.05 / dt))  # ~20 updates a second
                self.slider.value = (int(self.slider.value) + step) % len(self.times)  # type: ignore[misc]
            time.sleep(0.05)

    def export(self, path: Path, fps: float = EXPORT_FPS) -> Path:
        """One .html holding viser's client and the whole replay (every run, `fps` frames per simulated second)."""
        serializer = self.server.get_scene_serializer()
        dt = self.runs[0].control_dt
        every = frame_every(dt, fps)
        for i in range(0, len(self.times), every):
            self.show(i)
            serializer.insert_sleep(every * dt)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(serializer.as_html())
        return path

    def close(self) -> None:
        self.server.stop()
