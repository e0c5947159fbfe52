"""What the command line prints to the terminal: user text literally (no markup, control characters escaped), and
one line per error."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.text import Text

err = Console(stderr=True)


def literal(text: str) -> str:
    """User-provided text as it can be shown on one terminal line: control characters (escape sequences, line
    breaks) escaped; rich markup is never interpreted (see `say`)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def say(label: str, style: str, message: str) -> None:
    err.print(Text.assemble((label, style), " ", literal(message)), highlight=False, soft_wrap=True)


def fail(message: str) -> None:
    say("error:", "red", message)
    raise typer.Exit(2)


def warn(lines: list[str]) -> None:
    for line in lines:
        say("warning:", "yellow", line)
