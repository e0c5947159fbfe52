"""Every committed result file was made by the code as it is: its provenance entry (harmony_cli/provenance.py)
names the code version of the source today. A result whose code changed since, or that has no entry, fails with
the command that makes it again.

python tools/check_results.py [RESULTS_DIR]
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from harmony_cli.provenance import FILE, code_version, made_of

# the command that writes each directory of results (longest prefix first)
REMAKE = {
    "results/paper": "make reproduce-paper",
    "results/bench": "make bench",
    "results/engines": "make engines",
    "results/robots_unedited": "make robots-unedited",
    "results/claims": "make claims",
    "results/studies/pick_and_carry_random/dev": "make study",
    "results/studies/pick_and_carry_random/validation": "make study-validation",
}


def committed(root: Path) -> list[Path]:
    """The files git tracks under `root` (its provenance.json files aside)."""
    listed = subprocess.run(["git", "ls-files", "--", str(root)], capture_output=True, text=True, check=True)
    return [Path(line) for line in listed.stdout.splitlines() if Path(line).name != FILE]


def remake(directory: Path) -> str:
    matches = [prefix for prefix in REMAKE if directory.is_relative_to(prefix)]
    return REMAKE[max(matches, key=len)] if matches else "the command that wrote it"


def problems(files: list[Path], version: str) -> list[str]:
    """One line per directory with files not made by `version`: how many, by what, and the command to run."""
    stale: dict[Path, list[str]] = {}
    for path in files:
        made = made_of(path)
        found = "no provenance entry" if made is None else f"code {made.code_version}"
        if made is None or made.code_version != version:
            stale.setdefault(path.parent, []).append(found)
    return [
        f"{directory}: {len(found)} committed result file(s) made by {', '.join(sorted(set(found)))}, not by the "
        f"code as it is ({version}); run `{remake(directory)}`"
        for directory, found in sorted(stale.items())
    ]


def main() -> int:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("results")
    lines = problems(committed(root), code_version())
    for line in lines:
        print(line)
    if len(lines) > 1:
        print("`make results` makes all of them again, one target after another (it resumes after a stop)")
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
