"""Where harmony caches what it builds once (compiled C, prepared URDFs): $HARMONY_CACHE or ~/.cache/harmony."""

from __future__ import annotations

import os
from pathlib import Path

CACHE_DIR = Path(os.environ.get("HARMONY_CACHE", Path.home() / ".cache" / "harmony"))
