"""Rewriting a scenario file of an older schema as the current one, in place: only the renamed fields' text changes
(scenario/yaml_edit.py), so its comments and layout stay; the file then states `schema: 2`."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from harmony_cli.scenario.errors import ScenarioError
from harmony_cli.scenario.schema import CURRENT, schema_edits, stated_schema
from harmony_cli.scenario.source import parse_yaml, read_text
from harmony_cli.scenario.yaml_edit import Edit, apply_to_data, apply_to_text


def upgraded_text(path: Path) -> tuple[str | None, list[str]]:
    """A scenario file's text at the current schema (None: it states that already) and each renamed field as
    `old -> new`. The rewritten text must parse to what loading the file gives, or it is refused (ScenarioError):
    a file the edits cannot follow as written (an alias or merge key in a renamed field's way) is changed by hand."""
    text = read_text(path, "scenario")
    raw = parse_yaml(text, path)
    if not isinstance(raw, dict):
        raise ScenarioError(f"{path}: expected a mapping at the top level, got {type(raw).__name__}")
    if stated_schema(raw, path) == CURRENT:
        return None, []
    edits, renamed = schema_edits(raw, path)
    edits = edits or [Edit("insert", ("schema",), CURRENT, first=True)]  # current already: it says so
    try:
        new = apply_to_text(text, edits)
        agrees = parse_yaml(new, path) == apply_to_data(raw, edits)
        why = "the rewritten text reads differently"
    except (ValueError, ScenarioError) as err:
        agrees, why = False, str(err)
    if not agrees:
        todo = "; ".join([*renamed, f"add schema: {CURRENT}"])
        raise ScenarioError(f"{path}: cannot be rewritten in place ({why}); change it by hand: {todo}")
    return new, renamed


def write_in_place(path: Path, text: str) -> None:
    """Replace a file's text at once (a temporary file beside it renamed over it), keeping its permissions: an
    interrupted write leaves the old file, not half of the new one."""
    target = path.resolve()
    handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w", encoding="utf-8", newline="") as out:
            out.write(text)
        shutil.copymode(target, temporary)
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def upgrade_file(path: Path) -> str:
    """Rewrite a scenario file at the current schema in place; the line saying what changed."""
    new, renamed = upgraded_text(path)
    if new is None:
        return f"{path}: schema {CURRENT} already; left as it is"
    try:
        write_in_place(path, new)
    except OSError as err:
        raise ScenarioError(f"{path}: cannot be rewritten: {err.strerror or err}") from None
    if not renamed:
        return f"{path}: schema {CURRENT} stated (no field of an older schema in it)"
    return f"{path}: upgraded to schema {CURRENT}: {'; '.join(renamed)}"
