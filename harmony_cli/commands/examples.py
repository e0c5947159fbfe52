"""`harmony examples DIR`: the shipped scenarios and studies copied out of the installed package."""

from __future__ import annotations

from pathlib import Path

import typer

from harmony_cli.console import fail, literal
from harmony_cli.examples import SHIPPED, copy_examples


def examples(target: Path = typer.Argument(..., help="A new or empty folder to copy them into")):
    """Copy the scenarios and studies harmony ships (the paper's experiments, the catalogue robots' tasks, the
    smoke scenes, the studies) into TARGET, as TARGET/scenarios and TARGET/studies; then e.g.
    `harmony run TARGET/scenarios/paper/pick_and_carry.yaml`."""
    try:
        written = copy_examples(target)
    except FileExistsError:
        fail(f"{target}: already holds something; give a new or empty folder for the examples")
        return
    folders = ", ".join(literal(str(target / name)) for name in SHIPPED)
    typer.echo(f"{len(written)} files in {folders}")
