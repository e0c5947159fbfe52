"""`harmony upgrade FILE [FILE ...]`: scenario files of an older schema rewritten in place as the current one."""

from __future__ import annotations

from pathlib import Path

import typer

from harmony_cli.console import literal, say
from harmony_cli.scenario import ScenarioError
from harmony_cli.scenario.upgrade import upgrade_file


def upgrade(files: list[Path] = typer.Argument(..., help="Scenario files to rewrite in place")):
    """Rewrite scenario files of schema 1 in place as schema 2 (renamed fields in their new form, `schema: 2`
    stated), keeping their comments and layout; one line per file, exit code 2 if any could not be."""
    bad = 0
    for path in files:  # every file done or reported, whatever the others do
        try:
            typer.echo(literal(upgrade_file(path)))
        except ScenarioError as exc:
            say("error:", "red", str(exc))
            bad += 1
    if bad:
        raise typer.Exit(2)
