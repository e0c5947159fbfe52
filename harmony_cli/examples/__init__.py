"""The scenarios and studies harmony ships: the paper's experiments, the catalogue robots' tasks, the smoke scenes
and the studies over them. A checkout reaches them as `scenarios/` and `studies/` (links here); an installed
package copies them out with `harmony examples DIR`."""

from __future__ import annotations

from importlib.resources import files
from importlib.resources.abc import Traversable
from pathlib import Path

SHIPPED = ("scenarios", "studies")  # the folders copied out, side by side (a study names ../scenarios/...)


def copy_examples(target: Path) -> list[Path]:
    """Every shipped file copied under `target` (created; it must not hold anything yet), folders as shipped;
    returns the files written. Raises FileExistsError when `target` is a file or a folder with something in it."""
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise FileExistsError(target)
    written: list[Path] = []
    root = files(__name__)
    for name in SHIPPED:
        written += _copy_tree(root / name, target / name)
    return written


def _copy_tree(source: Traversable, target: Path) -> list[Path]:
    """`source`'s .yaml files and folders under `target`, in name order."""
    written: list[Path] = []
    for entry in sorted(source.iterdir(), key=lambda e: e.name):
        if entry.is_dir():
            written += _copy_tree(entry, target / entry.name)
        elif entry.name.endswith(".yaml"):
            target.mkdir(parents=True, exist_ok=True)
            (target / entry.name).write_bytes(entry.read_bytes())
            written.append(target / entry.name)
    return written
