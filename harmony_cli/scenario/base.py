"""The base of every scenario model: unknown keys rejected, values frozen."""

from __future__ import annotations

from collections import Counter

from pydantic import BaseModel, ConfigDict, PositiveFloat


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


Vector3 = tuple[float, float, float]
Size3 = tuple[PositiveFloat, PositiveFloat, PositiveFloat]  # extents [m]: a size of 0 or less is a typo


def unique(names: list[str], what: str) -> None:
    """ValueError naming the first name given twice (names are keys: logs, targets, pushes refer to them)."""
    twice = [name for name, n in Counter(names).items() if n > 1]
    if twice:
        raise ValueError(f"{what} {twice[0]!r} is given {names.count(twice[0])} times; names must be unique")
