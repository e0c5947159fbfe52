"""Where harmony caches what it builds once (compiled C, prepared URDFs, small results worked out per robot):
$HARMONY_CACHE or ~/.cache/harmony."""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

CACHE_DIR = Path(os.environ.get("HARMONY_CACHE", Path.home() / ".cache" / "harmony"))


def cached_json(folder: str, key: bytes, compute: Callable[[], Any]) -> Any:
    """`compute()`'s JSON-able value, kept in CACHE_DIR/folder under the hash of `key` (whatever it depends on).
    A missing, unreadable or read-only cache only means computing it again."""
    path = CACHE_DIR / folder / f"{hashlib.sha256(key).hexdigest()[:24]}.json"
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        pass
    value = compute()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        with os.fdopen(fd, "w") as out:
            json.dump(value, out)  # floats round-trip exactly
        os.replace(tmp, path)  # atomic: a concurrent run reads the old file or the new one
    except OSError:
        pass
    return value
