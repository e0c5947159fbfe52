"""The `harmony` command line: thin wrappers over library functions."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click
import typer

import harmony_cli
from harmony_cli.commands.examples import examples
from harmony_cli.commands.robots import robots_app
from harmony_cli.commands.study import study
from harmony_cli.commands.upgrade import upgrade
from harmony_cli.commands.view import view
from harmony_cli.console import fail, literal, say, warn
from harmony_cli.scenario import Scenario, ScenarioError, load_scenario, robot_warnings

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Whole-body Bezier MPC experiments for dual-arm mobile manipulators, from YAML.",
)
SET_HELP = "Override a scenario field, e.g. --set mpc.knots=6 (repeatable)."


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"harmony {harmony_cli.__version__}")
        raise typer.Exit()


@app.callback()
def _options(
    version: bool = typer.Option(
        False, "--version", callback=_print_version, is_eager=True, help="Print harmony's version and exit."
    ),
) -> None:
    """The options before any command (`--version`)."""


def _click_errors() -> tuple[tuple[type[Exception], ...], tuple[type[BaseException], ...]]:
    """(usage errors, aborts) of click and of the click typer vendors (typer >= 0.29 raises its own)."""
    errors: list[type[Exception]] = [click.ClickException]
    aborts: list[type[BaseException]] = [click.Abort]
    try:
        from typer._click import exceptions as vendored

        errors.append(vendored.ClickException)
        aborts.append(getattr(vendored, "Abort"))  # noqa: B009 - absent from its stubs
    except (ImportError, AttributeError):
        pass
    return tuple(errors), tuple(aborts)


def main() -> None:
    """The `harmony` entry point: usage errors (unknown option, missing argument, bad value) as one line."""
    errors, aborts = _click_errors()
    try:
        code = app(standalone_mode=False)
    except errors as exc:
        ctx = getattr(exc, "ctx", None)
        if ctx is not None and type(exc).__name__ == "NoArgsIsHelpError":  # `harmony` alone: its help
            typer.echo(ctx.get_help())
            sys.exit(0)
        hint = f" (see `{ctx.command_path} --help`)" if ctx is not None else ""
        say("error:", "red", getattr(exc, "format_message", exc.__str__)() + hint)
        sys.exit(getattr(exc, "exit_code", 2))
    except aborts:  # Ctrl-C outside a run
        sys.exit(130)
    sys.exit(code if isinstance(code, int) else 0)


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
    """Run one scenario closed loop in its physics engine (sim.engine) and write a run directory."""
    from harmony_cli.experiment.interrupts import RunInterrupted
    from harmony_cli.experiment.pipeline import RunFailed
    from harmony_cli.experiment.run import run_scenario
    from harmony_cli.mpc.registry import SolverUnavailable

    try:
        if video_path is not None and video_path.suffix.lower() not in (".mp4", ".gif"):
            fail(f"--video-file: {str(video_path)!r} must end in .mp4 or .gif")
        notices: list[str] = []  # a file of an older schema: its deprecation notice
        loaded = load_scenario(scenario, set, notices)
        warn(notices + robot_warnings(loaded, scenario.parent))
        target = video_path or (True if video else None)
        run_dir = run_scenario(scenario, set, out, progress=not quiet, video=target, push_free_twin=twin)
    except (ScenarioError, SolverUnavailable) as exc:
        fail(str(exc))
    except RunFailed as exc:
        say("run failed:", "red", str(exc))
        raise typer.Exit(1) from None
    except OSError as exc:  # the run directory's inputs could not be written (e.g. a full disk): nothing ran
        say("run failed:", "red", f"could not write the run directory: {exc}")
        raise typer.Exit(1) from None
    except RunInterrupted as exc:  # the run wrote its results; say where they are
        say("interrupted:", "yellow", f"{exc.signal_name}; the steps so far, summary and plots are in {exc.run_dir}")
        raise typer.Exit(exc.exit_code) from None
    from harmony_cli.experiment.results import succeeded
    from harmony_cli.report.text import run_lines  # pandas: after the run, not before its first step

    summary = json.loads((run_dir / "summary.json").read_text())
    for line in run_lines(run_dir, summary):
        typer.echo(line)
    if not succeeded(summary):  # it ran, but what it was asked (the task, the reference) it did not do
        raise typer.Exit(1)


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
    from harmony_cli.experiment.interrupts import RunInterrupted
    from harmony_cli.experiment.sweep import expand_grid, failed_runs, run_grid
    from harmony_cli.report.tables import compare_report

    try:
        notices: list[str] = []
        base = load_scenario(scenario, set, notices)
        warn(notices + robot_warnings(base, scenario.parent))
        for point in expand_grid(grid):
            load_scenario(scenario, list(set) + point)  # every grid point is valid before anything runs
    except ScenarioError as exc:
        fail(str(exc))
    out = out or Path("results/compare") / base.name
    try:
        dirs = run_grid(scenario, grid, set, out, jobs)
    except RunInterrupted as exc:
        say("interrupted:", "yellow", f"{exc.signal_name}; the grid runs so far (done and interrupted) are in {out}")
        raise typer.Exit(exc.exit_code) from None
    keys = [g.split("=", 1)[0] for g in grid]
    for path in compare_report(dirs, out, name, main_solver, keys):
        typer.echo(path)
    failed = failed_runs(dirs)
    if failed:
        say("failed:", "red", f"{len(failed)} of {len(dirs)} grid runs: {'; '.join(failed)}")
        raise typer.Exit(1)


@app.command()
def validate(files: list[Path], set: list[str] = typer.Option([], "--set", help=SET_HELP)):
    """Validate scenario files (with the overrides `run` would get); one line per bad file, exit code 2 if any is
    bad."""
    bad = broken = 0
    for f in files:  # every file reported, whatever the others do
        notices: list[str] = []  # a file of an older schema: its deprecation notice, whatever else it says
        try:
            loaded = load_scenario(f, set, notices)
            typer.echo(literal(f"{f}: ok"))
            warn(notices + robot_warnings(loaded, f.parent))
        except ScenarioError as exc:
            warn(notices)
            say("error:", "red", str(exc))
            bad += 1
        except Exception as exc:  # noqa: BLE001 - a bug of harmony's, not the file's: say so and go on
            say("internal error:", "red", f"{f}: {type(exc).__name__}: {exc} (please report this)")
            broken += 1
    if bad or broken:
        raise typer.Exit(2 if bad else 1)


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
        fail(f"not run directories (no summary.json): {', '.join(missing)}")
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

    from harmony_cli.provenance import Made, record
    from harmony_cli.report.scene_plots import plot_paths_compared

    missing = [str(r) for r in runs if not (r / "steps.csv").exists()]
    if missing:
        fail(f"not run directories (no steps.csv): {', '.join(missing)}")
    try:
        loaded = {
            r.name: (pd.read_csv(r / "steps.csv"), load_scenario(r / "scenario.resolved.yaml", runnable=False))
            for r in runs
        }
    except ScenarioError as exc:
        fail(str(exc))
    out.parent.mkdir(parents=True, exist_ok=True)
    typer.echo(plot_paths_compared(out, loaded, title))
    record([out], Made.from_runs(runs))


EXPERIMENTS = ("pick_and_carry", "static_obstacles", "narrow_passage", "dynamic_obstacle")  # the paper's two-stage


@app.command()
def bench(
    scenario: Path = typer.Option(Path("scenarios/paper/table1_s_shape.yaml")),
    knots: list[int] = typer.Option([6, 26]),
    solver: list[str] = typer.Option(["ipopt", "gauss_newton", "rti"]),
    steps: int = typer.Option(250, help="Control steps per configuration"),
    start: float = typer.Option(8.0, help="Reference time of the first step [s]"),
    out: Path | None = typer.Option(Path("results/bench/bench.json")),
    loop: list[Path] = typer.Option(
        [Path(f"scenarios/paper/{name}.yaml") for name in EXPERIMENTS],
        help="Experiments timed closed loop, one after another (repeatable; '' to skip)",
    ),
    engine: list[str] = typer.Option(
        [], help="Physics engines the experiments run in, each in turn (repeatable; default: the scenario's)"
    ),
):
    """Whole-body MPC solve time: both transcriptions x K x solver modes, side by side, with ratios; then each
    experiment closed loop in each engine: its loop and each part of a step (median to max), wall time, real-time
    factor, beside the last bench's numbers from this machine."""
    from harmony_cli.experiment.bench import run_bench
    from harmony_cli.experiment.loop_bench import run_loop_bench
    from harmony_cli.mpc.registry import SolverUnavailable

    try:
        run_bench(scenario, list(knots), list(solver), steps, start, out)
        if Path() not in loop:  # `--loop ''` (read as the current directory) skips the closed-loop part
            run_loop_bench(list(loop), out.with_name("loop.json") if out else None, engines=list(engine) or None)
    except (ScenarioError, SolverUnavailable) as exc:
        fail(str(exc))


@app.command()
def summarise(run_dir: Path):
    """Rebuild a run directory's steps.csv, summary.json and plots from its steps.jsonl (a run killed hard)."""
    from harmony_cli.experiment.rebuild import rebuild_run_dir

    try:
        summary = rebuild_run_dir(run_dir)
    except (ScenarioError, OSError, ValueError) as exc:
        fail(str(exc))
    steps = summary.get("steps", 0)
    typer.echo(literal(f"{run_dir}: {summary['status']}, {steps} steps; steps.csv, summary.json and plots rebuilt"))


app.command()(examples)
app.command()(study)
app.command()(upgrade)
app.add_typer(robots_app, name="robots")
app.command()(view)
