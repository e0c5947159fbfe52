"""Third-party output (C-level prints of URDF parsers and PyBullet, and Python-level ones such as urdf_parser_py's)
captured as lines for run.log, so the console shows only harmony's own progress and summary."""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
import sys
import tempfile
from collections.abc import Iterator


@contextlib.contextmanager
def captured_output() -> Iterator[list[str]]:
    """Redirect file descriptors 1 and 2, and sys.stdout/sys.stderr (which an embedding host, e.g. a test runner,
    may have pointed elsewhere), for the block; the list it yields holds their non-empty lines after."""
    lines: list[str] = []
    _flush_all()
    saved = [os.dup(1), os.dup(2)]
    python_level = io.StringIO()
    with tempfile.TemporaryFile(mode="w+b") as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            with contextlib.redirect_stdout(python_level), contextlib.redirect_stderr(python_level):
                yield lines
        finally:
            _flush_all()
            for fd, copy in zip((1, 2), saved, strict=True):
                os.dup2(copy, fd)
                os.close(copy)
            sink.seek(0)
            text = sink.read().decode(errors="replace") + python_level.getvalue()
            lines.extend(line.rstrip() for line in text.splitlines() if line.strip())


def _flush_all() -> None:
    """Python's buffers and C stdio's (a C library prints into a buffer that a pipe flushes only at exit)."""
    sys.stdout.flush()
    sys.stderr.flush()
    ctypes.CDLL(None).fflush(None)
