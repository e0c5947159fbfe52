"""Copy result files with their provenance entries (the Makefile's copies of results into results/paper).

python tools/copy_results.py FILE [FILE ...] DIRECTORY
python tools/copy_results.py FILE TARGET_FILE
"""

from __future__ import annotations

import sys
from pathlib import Path

from harmony_cli.provenance import copy


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__.strip())
        return 2
    *sources, target = map(Path, sys.argv[1:])
    if len(sources) > 1 and not target.is_dir():
        print(f"copy_results: {target} is not a directory (several files are copied into one)")
        return 2
    for source in sources:
        print(copy(source, target))
    return 0


if __name__ == "__main__":
    sys.exit(main())
