"""Size limits (make lint): no module over 300 lines, no function over 60 (docstring included), a README (the
user guide; measurements live in docs/) of at most 300 lines, none of them over 120 characters, and a results page
(docs/results.md: each claim once, for readers) of at most 400 lines.

    python tools/check_sizes.py [harmony_cli]

Exceptions are listed in ALLOWED with the reason; anything else over a limit fails (exit 1), one line each.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

MODULE_LINES, FUNCTION_LINES, README_LINES, README_WIDTH, RESULTS_LINES = 300, 60, 300, 120, 400
README = Path(__file__).resolve().parents[1] / "README.md"
RESULTS = README.parent / "docs" / "results.md"
ALLOWED: dict[str, str] = {}  # "path" or "path:function" -> why it may be longer


def oversized(root: Path) -> list[str]:
    problems = []
    for path in sorted(root.rglob("*.py")):
        text = path.read_text()
        lines = len(text.splitlines())
        if lines > MODULE_LINES and str(path) not in ALLOWED:
            problems.append(f"{path}: {lines} lines (limit {MODULE_LINES})")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                length = node.end_lineno - node.lineno + 1
                if length > FUNCTION_LINES and f"{path}:{node.name}" not in ALLOWED:
                    problems.append(f"{path}:{node.lineno}: {node.name} is {length} lines (limit {FUNCTION_LINES})")
    return problems


def main() -> int:
    problems = oversized(Path(sys.argv[1] if len(sys.argv) > 1 else "harmony_cli"))
    readme = README.read_text().splitlines()
    if len(readme) > README_LINES:
        problems.append(f"{README}: {len(readme)} lines (limit {README_LINES}); measurements belong in docs/")
    results = len(RESULTS.read_text().splitlines())
    if results > RESULTS_LINES:
        problems.append(f"{RESULTS}: {results} lines (limit {RESULTS_LINES}); each claim once, the story in git")
    problems += [
        f"{README}:{number}: {len(line)} characters (limit {README_WIDTH})"
        for number, line in enumerate(readme, 1)
        if len(line) > README_WIDTH
    ]
    for line in problems:
        print(line)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
