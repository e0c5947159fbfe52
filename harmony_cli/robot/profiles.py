"""Robot profiles: a robot's defaults as a data file (harmony_cli/robot/profiles/<name>.yaml), so a scenario
names the robot and gives only what differs. Paths in a profile are relative to its file."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import yaml

PROFILES_DIR = Path(__file__).resolve().parent / "profiles"


def available_profiles() -> tuple[str, ...]:
    return tuple(sorted(p.stem for p in PROFILES_DIR.glob("*.yaml")))


@cache
def _read(name: str) -> dict:
    data = yaml.safe_load((PROFILES_DIR / f"{name}.yaml").read_text())
    data["urdf"] = str((PROFILES_DIR / data["urdf"]).resolve())
    if "package_paths" in data:
        data["package_paths"] = [str((PROFILES_DIR / p).resolve()) for p in data["package_paths"]]
    return data


def load_profile(name: str) -> dict:
    """A profile's fields (absolute paths); KeyError naming the valid profiles if there is none of that name."""
    if name not in available_profiles():
        raise KeyError(f"{name!r} is not a robot profile; choose one of: {', '.join(available_profiles())}")
    return dict(_read(name))
