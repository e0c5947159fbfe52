"""Suggesting what a misspelt name meant: the three closest valid names, not the whole list."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def closest(name: str, choices: Iterable[str], n: int = 3) -> str:
    """'closest: a, b, c' (or the first few choices when none is close)."""
    options = sorted(set(choices))
    matches = difflib.get_close_matches(name, options, n=n, cutoff=0.4) or options[:n]
    more = f" (of {len(options)})" if len(options) > n else ""
    return f"closest{more}: {', '.join(matches) or '(none)'}"
