"""`harmony run`: one scenario, closed loop, into a self-describing run directory (with its push-free twin first
when the scenario has pushes)."""

from __future__ import annotations

from pathlib import Path

from harmony_cli.experiment.pipeline import execute
from harmony_cli.experiment.run_dir import default_run_dir, write_inputs
from harmony_cli.scenario import load_scenario


def run_scenario(
    path: str | Path,
    overrides: list[str] | tuple[str, ...] = (),
    out: Path | None = None,
    progress: bool = True,
    concurrency: int = 1,
    video: Path | bool | None = None,
    push_free_twin: bool = True,
    plots: str = "all",
) -> Path:
    """Run one scenario closed loop; always leaves steps.csv, summary.json (status) and run.log in `out`;
    `video` (a .mp4 or .gif path, or True for out/video.mp4) records it, rendered headless. A scenario with pushes
    first runs its push-free twin into out/push_free (`push_free_twin=False`: displacements from the reference).
    `plots`: all, failed (only when the run did not succeed) or none."""
    path = Path(path)
    scenario = load_scenario(path, list(overrides))
    out = Path(out) if out else default_run_dir(scenario.name)
    write_inputs(out, path, list(overrides), scenario)
    twin, twin_info = None, None
    if scenario.pushes and push_free_twin:
        from harmony_cli.experiment.twin import run_push_free_twin  # pandas: only for a scenario with pushes

        twin, twin_info = run_push_free_twin(path, list(overrides), scenario, out / "push_free", progress, concurrency)
    return execute(
        scenario,
        path.parent,
        out,
        progress,
        concurrency,
        out / "video.mp4" if video is True else (video or None),
        twin,
        twin_info,
        plots,
    )
