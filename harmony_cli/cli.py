"""The `harmony` command line: thin wrappers over library functions."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from pydantic import ValidationError
from rich.console import Console

from harmony_cli.scenario import Scenario, ScenarioError, load_scenario, robot_warnings

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Whole-body Bezier MPC experiments for dual-arm mobile manipulators, from YAML.",
)
err = Console(stderr=True)

SET_HELP = "Override a scenario field, e.g. --set mpc.knots=6 (repeatable)."


def _fail(message: str) -> None:
    err.print(f"[red]error:[/red] {message}", highlight=False, soft_wrap=True)
    raise typer.Exit(2)


def _warn(lines: list[str]) -> None:
    for line in lines:
        err.print(f"[yellow]warning:[/yellow] {line}", highlight=False, soft_wrap=True)


@app.command()
def run(
    scenario: Path,
    set: list[str] = typer.Option([], "--set", help=SET_HELP),
    out: Path | None = typer.Option(None, help="Run directory (default results/runs/<name>-<time>)"),
    quiet: bool = typer.Option(False, help="No progress bar"),
    video: bool = typer.Option(False, "--video", help="Also record video.mp4 in the run directory (headless)"),
    video_path: Path | None = typer.Option(None, "--video-file", help="Record to this .mp4 or .gif instead"),
    twin: bool = typer.Option(
        True,
        "--push-free-twin/--no-push-free-twin",
        help="With pushes: first run the scenario without them (into <out>/push_free) and "
        "measure push displacements from it",
    ),
):
    """Run one scenario closed loop in PyBullet and write a run directory."""
    from harmony_cli.experiment.pipeline import RunFailed
    from harmony_cli.experiment.run import run_scenario
    from harmony_cli.mpc.registry import SolverUnavailable
    from harmony_cli.report.text import run_lines

    try:
        if video_path is not None and video_path.suffix.lower() not in (".mp4", ".gif"):
            _fail(f"--video-file: {str(video_path)!r} must end in .mp4 or .gif")
        _warn(robot_warnings(load_scenario(scenario, set), scenario.parent))
        target = video_path or (True if video else None)
        run_dir = run_scenario(scenario, set, out, progress=not quiet, video=target, push_free_twin=twin)
    except (ScenarioError, SolverUnavailable) as exc:
        _fail(str(exc))
    except RunFailed as exc:
        err.print(f"[red]run failed:[/red] {exc}", highlight=False, soft_wrap=True)
        raise typer.Exit(1) from None
    for line in run_lines(run_dir, json.loads((run_dir / "summary.json").read_text())):
        typer.echo(line)


@app.command()
def compare(
    scenario: Path,
    grid: list[str] = typer.Option(..., "--grid", help="key=v1,v2 (repeatable)"),
    set: list[str] = typer.Option([], "--set", help=SET_HELP),
    jobs: int = typer.Option(1, help="Runs at once (solve times are only comparable at 1)"),
    out: Path | None = typer.Option(None, help="Output directory (default results/compare/<name>)"),
    name: str = typer.Option("table", help="Table file name stem"),
    main_solver: str | None = typer.Option(None, help="Solver of the main table (default: first)"),
):
    """Run an ablation grid and write Table-1 style tables (md, csv, tex) and Fig. 4 plots."""
    from harmony_cli.experiment.sweep import expand_grid, run_grid
    from harmony_cli.report.tables import compare_report

    try:
        base = load_scenario(scenario, set)
        _warn(robot_warnings(base, scenario.parent))
        for point in expand_grid(grid):
            load_scenario(scenario, list(set) + point)  # every grid point is valid before anything runs
    except ScenarioError as exc:
        _fail(str(exc))
    out = out or Path("results/compare") / base.name
    dirs = run_grid(scenario, grid, set, out, jobs)
    keys = [g.split("=", 1)[0] for g in grid]
    for path in compare_report(dirs, out, name, main_solver, keys):
        typer.echo(path)


@app.command()
def validate(files: list[Path]):
    """Validate scenario files; one line per bad file, exit code 2 if any is bad."""
    bad = 0
    for f in files:
        try:
            loaded = load_scenario(f)
            typer.echo(f"{f}: ok")
            _warn(robot_warnings(loaded, f.parent))
        except ScenarioError as exc:
            err.print(f"[red]error:[/red] {exc}", highlight=False, soft_wrap=True)
            bad += 1
    if bad:
        raise typer.Exit(2)


robots_app = typer.Typer(
    no_args_is_help=False, invoke_without_command=True, help="Robot presets: list them, or show one (`show NAME`)."
)
app.add_typer(robots_app, name="robots")


@robots_app.callback()
def robots(context: typer.Context):
    """List the robot presets (`robot: {preset: NAME}`) and where their URDF comes from."""
    if context.invoked_subcommand is not None:
        return
    from harmony_cli.robot.presets import PRESETS_DIR, available_presets

    for name in available_presets():
        first = (PRESETS_DIR / f"{name}.yaml").read_text().splitlines()[0].lstrip("# ")
        typer.echo(f"{name:<12} {first}")


@robots_app.command("show")
def robots_show(name: str):
    """Joints, limits, hand frames, wrist sensors, what preparing the URDF changed and the gravity check."""
    from harmony_cli.names import closest
    from harmony_cli.report.robot_text import robot_lines
    from harmony_cli.robot.model import load_robot
    from harmony_cli.robot.presets import available_presets
    from harmony_cli.scenario import RobotSpec

    if name not in available_presets():
        _fail(f"robots show: {name!r} is not a robot preset; {closest(name, available_presets())}")
    try:
        spec = RobotSpec.model_validate({"preset": name})
        robot = load_robot(spec, Path.cwd())
    except ValidationError as exc:
        _fail(f"robots show {name}: {exc.errors()[0]['msg']}")
    except ValueError as exc:
        _fail(f"robots show {name}: {exc}")
    for line in robot_lines(name, robot):
        typer.echo(line)


@app.command()
def schema():
    """Print the scenario JSON schema (for editors)."""
    typer.echo(json.dumps(Scenario.model_json_schema(), indent=2))


@app.command()
def experiments(
    runs: list[Path] = typer.Argument(..., help="Run directories of task scenarios"),
    out: Path = typer.Option(Path("results/paper")),
    name: str = typer.Option("experiments"),
):
    """Results table (md, csv) of two-stage task runs, with their top-down plots and a video frame each."""
    from harmony_cli.report.experiments import experiments_report

    missing = [str(r) for r in runs if not (r / "summary.json").exists()]
    if missing:
        _fail(f"not run directories (no summary.json): {', '.join(missing)}")
    for path in experiments_report(list(runs), out, name):
        typer.echo(path)


@app.command()
def paths(
    runs: list[Path] = typer.Argument(..., help="Run directories of one scene (e.g. with and without motion)"),
    out: Path = typer.Option(..., help="Image file (.png)"),
    title: str = typer.Option("", help="Figure title (default: the first run's scenario name)"),
):
    """Top-down paths of several runs of one scene overlaid: base, hands, box and each run's moving obstacles."""
    import pandas as pd

    from harmony_cli.report.scene_plots import plot_paths_compared

    missing = [str(r) for r in runs if not (r / "steps.csv").exists()]
    if missing:
        _fail(f"not run directories (no steps.csv): {', '.join(missing)}")
    try:
        loaded = {r.name: (pd.read_csv(r / "steps.csv"), load_scenario(r / "scenario.resolved.yaml")) for r in runs}
    except ScenarioError as exc:
        _fail(str(exc))
    out.parent.mkdir(parents=True, exist_ok=True)
    typer.echo(plot_paths_compared(out, loaded, title))


@app.command()
def bench(
    scenario: Path = typer.Option(Path("scenarios/paper/table1_s_shape.yaml")),
    knots: list[int] = typer.Option([6, 26]),
    solver: list[str] = typer.Option(["ipopt", "gauss_newton", "rti"]),
    steps: int = typer.Option(250, help="Control steps per configuration"),
    start: float = typer.Option(8.0, help="Reference time of the first step [s]"),
    out: Path | None = typer.Option(Path("results/bench/bench.json")),
    loop: Path | None = typer.Option(
        Path("scenarios/paper/pick_and_carry.yaml"),
        help="Two-stage task scenario whose full loop is timed ('' to skip)",
    ),
):
    """Whole-body MPC solve time: both transcriptions x K x solver modes, side by side, with ratios; then the
    full loop (planner + whole-body MPC) of a task scenario, closed loop in PyBullet."""
    from harmony_cli.experiment.bench import run_bench, run_loop_bench
    from harmony_cli.mpc.registry import SolverUnavailable

    try:
        run_bench(scenario, list(knots), list(solver), steps, start, out)
        if loop and str(loop):
            run_loop_bench(loop, out.with_name("loop.json") if out else None)
    except (ScenarioError, SolverUnavailable) as exc:
        _fail(str(exc))
