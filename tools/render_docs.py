"""Fill the docs' include blocks from the committed result files, so the tables in docs/ are the measured ones.

    python tools/render_docs.py [--check] [FILE.md ...]      (default: docs/*.md)

A block is
    <!-- include: results/paper/table1.md -->
    ...anything...
    <!-- end include -->
and becomes the file's text (paths relative to the repository root; a leading "# Title" line becomes a bold
caption). `--check` changes nothing and exits 1 if any block is out of date (make lint runs it).
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLOCK = re.compile(r"(<!-- include: (?P<path>\S+) -->\n)(?P<body>.*?)(<!-- end include -->)", re.S)


def included(path: str) -> str:
    text = (ROOT / path).read_text().strip("\n")
    first, _, rest = text.partition("\n")
    if first.startswith("# "):
        text = f"**{first[2:].strip()}**\n{rest}"
    return text.strip("\n") + "\n"


def render(text: str) -> str:
    return BLOCK.sub(lambda m: m.group(1) + included(m.group("path")) + m.group(4), text)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true")
    parser.add_argument("files", nargs="*", type=Path)
    args = parser.parse_args()
    stale = []
    for path in args.files or sorted((ROOT / "docs").glob("*.md")):
        text = path.read_text()
        new = render(text)
        if new != text:
            stale.append(path)
            if not args.check:
                path.write_text(new)
    for path in stale:
        print(f"{path}: {'out of date with the result files it includes' if args.check else 'updated'}")
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
