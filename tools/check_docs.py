"""Docs for readers, not a diary (make lint): in README.md and docs/*.md no heading carries a date, no line names a
study's sample or draw by its number, and a commit hash appears only on a line that says what was measured at it
("measured at commit ..."). The blocks that render_docs.py fills from result files are theirs and not checked.

    python tools/check_docs.py
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INCLUDED = re.compile(r"<!-- include: \S+ -->\n.*?<!-- end include -->", re.S)
DATED_HEADING = re.compile(r"^#+ .*\b20\d\d-\d\d-\d\d")
SAMPLE = re.compile(r"\b(?:samples?|draws?) \d+(?:, \d+)*\b(?! (?:of|draws|samples|runs|x))", re.I)
HASH = re.compile(r"\b(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b")
MEASURED = re.compile(r"measured", re.I)


def problems(path: Path) -> list[str]:
    text = INCLUDED.sub(lambda m: "\n" * m.group(0).count("\n"), path.read_text())
    found = []
    for number, line in enumerate(text.splitlines(), 1):
        where = f"{path.relative_to(ROOT)}:{number}"
        if DATED_HEADING.search(line):
            found.append(f"{where}: a dated heading (the date belongs to git history): {line.strip()[:80]}")
        if match := SAMPLE.search(line):
            found.append(f"{where}: names a study's {match.group(0)!r} (development draws stay out of docs)")
        if (match := HASH.search(line)) and not MEASURED.search(line):
            found.append(f"{where}: commit {match.group(0)} on a line that does not say what was measured at it")
    return found


def main() -> int:
    found = [line for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))] for line in problems(path)]
    for line in found:
        print(line)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
