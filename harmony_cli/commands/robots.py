"""`harmony robots`: the robot presets, what harmony makes of one (`show NAME`), or of a scenario's robot section
(`--check FILE`)."""

from __future__ import annotations

from pathlib import Path

import typer
from pydantic import ValidationError

from harmony_cli.console import fail
from harmony_cli.scenario import ScenarioError

robots_app = typer.Typer(
    no_args_is_help=False,
    invoke_without_command=True,
    help="Robot presets: list them, show one (`show NAME`), or check a scenario's robot (`--check FILE`).",
)


@robots_app.callback()
def robots(
    context: typer.Context,
    check: Path | None = typer.Option(None, "--check", help="A scenario file: what harmony makes of its robot"),
):
    """List the robot presets (`robot: {preset: NAME}`) and where their URDF comes from; or, with --check FILE, what
    harmony makes of that scenario's robot section."""
    if context.invoked_subcommand is not None:
        return
    if check is not None:
        from harmony_cli.report.robot_text import scenario_robot_lines

        try:
            lines = scenario_robot_lines(check)
        except ScenarioError as exc:
            fail(str(exc))
        except ValueError as exc:
            fail(f"{check}: {exc}")
        for line in lines:
            typer.echo(line)
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
        fail(f"robots show: {name!r} is not a robot preset; {closest(name, available_presets())}")
    try:
        spec = RobotSpec.model_validate({"preset": name})
        robot = load_robot(spec, Path.cwd())
    except ValidationError as exc:
        fail(f"robots show {name}: {exc.errors()[0]['msg']}")
    except ValueError as exc:
        fail(f"robots show {name}: {exc}")
    for line in robot_lines(name, robot):
        typer.echo(line)
