"""Robot presets: a robot's defaults as a data file (harmony_cli/robot/presets/<name>.yaml), so a scenario names
the robot and gives only what differs. Paths in a preset are relative to its file, or `<distribution>:<path>`
inside an installed Python distribution that ships robot packages (example-robot-data)."""

from __future__ import annotations

import importlib.metadata
from functools import cache
from pathlib import Path

import yaml

PRESETS_DIR = Path(__file__).resolve().parent / "presets"
ROBOT_DISTRIBUTIONS = {"example-robot-data": "cmeel.prefix/share"}


class PresetUnavailable(LookupError):
    """A preset whose robot package is not installed."""


def available_presets() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in PRESETS_DIR.glob("*.yaml")))


def resolve_path(text: str, name: str) -> str:
    """A preset's path: `distribution:relative` inside an installed distribution, else relative to the preset."""
    try:
        inside = distribution_path(text)
    except PresetUnavailable as err:
        raise PresetUnavailable(f"preset {name!r} {err}") from None
    return str((PRESETS_DIR / text).resolve()) if inside is None else inside


def distribution_path(text: str) -> str | None:
    """The absolute path a `distribution:relative` path names inside an installed distribution that ships robot
    packages (ROBOT_DISTRIBUTIONS), or None for any other path; PresetUnavailable when it is not installed."""
    distribution, sep, inside = text.partition(":")
    if not sep or distribution not in ROBOT_DISTRIBUTIONS:
        return None
    try:
        dist = importlib.metadata.distribution(distribution)
    except importlib.metadata.PackageNotFoundError:
        raise PresetUnavailable(
            f"needs the Python package {distribution} (its URDFs): pip install {distribution}, or `make install`, "
            "which installs it"
        ) from None
    return str(Path(str(dist.locate_file(ROBOT_DISTRIBUTIONS[distribution]))) / inside)


@cache
def _read(name: str) -> dict:
    data = yaml.safe_load((PRESETS_DIR / f"{name}.yaml").read_text())
    data["urdf"] = resolve_path(data["urdf"], name)
    if "package_paths" in data:
        data["package_paths"] = [resolve_path(p, name) for p in data["package_paths"]]
    return data


def load_preset(name: str) -> dict:
    """A preset's fields (absolute paths); KeyError naming the valid presets if there is none of that name,
    PresetUnavailable if its robot package is not installed."""
    if name not in available_presets():
        raise KeyError(f"{name!r} is not a robot preset; choose one of: {', '.join(available_presets())}")
    return dict(_read(name))
