"""Who touched what and when, from a run's per-step table: the robot with a table or an obstacle, the box with an
obstacle. A step touches when the simulator reported a contact point (`contact_<who>_<name>_m`, the deepest contact
distance, empty without one; sim/touches.py) or when the closest-point distance is <= 0
(`clearance_<who>_<name>_m`). Both are read: the contact points are taken after every physics step, the closest
points once per control step, and each can see a touch the other misses."""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
import pandas as pd

WHO = ("robot", "box")
PREFIXES = ("contact_", "clearance_")


def _pair(column: str) -> tuple[str, str] | None:
    """(who, body name) of a contact or clearance column; None for any other column."""
    for prefix in PREFIXES:
        for who in WHO:
            head = f"{prefix}{who}_"
            if column.startswith(head) and column.endswith("_m") and len(column) > len(head) + 2:
                return who, column[len(head) : -2]
    return None


def touching_steps(steps: pd.DataFrame) -> dict[tuple[str, str], pd.Series]:
    """Per (who, body name): the steps at which it touched (a contact point or a closest-point distance <= 0)."""
    out: dict[tuple[str, str], pd.Series] = {}
    for column in steps.columns:
        pair = _pair(column)
        if pair is not None:
            touching = steps[column] <= 0.0  # NaN (no contact point) is not a touch
            out[pair] = out[pair] | touching if pair in out else touching
    return out


def touches(steps: pd.DataFrame, tables: Collection[str]) -> list[dict]:
    """Every (who, body) that touched, the earliest first: `who` (robot or box), `body` ("table <name>" or
    "obstacle <name>"), `first_s` and `phase` of its first touching step, `deepest_m` (the smallest contact or
    closest-point distance, <= 0) and `steps` (how many steps touched)."""
    found = []
    for (who, name), rows in touching_steps(steps).items():
        if not rows.any():
            continue
        columns = [c for c in (f"contact_{who}_{name}_m", f"clearance_{who}_{name}_m") if c in steps]
        first = steps[rows].iloc[0]
        found.append(
            {
                "who": who,
                "body": f"{'table' if name in tables else 'obstacle'} {name}",
                "first_s": float(first["t"]),
                "phase": str(first["phase"]) if "phase" in steps else None,
                "deepest_m": float(np.nanmin(steps.loc[rows, columns].to_numpy(float))),
                "steps": int(rows.sum()),
            }
        )
    return sorted(found, key=lambda touch: touch["first_s"])
