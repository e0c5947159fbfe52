"""The claims of several study directories in one table (make claims writes results/claims/claims.md with it).

python tools/claims_table.py OUT.md STUDY_DIR [STUDY_DIR ...]
"""

from __future__ import annotations

import sys
from pathlib import Path

from harmony_cli.provenance import Made, made_of, record
from harmony_cli.study.claims import summary_lines
from harmony_cli.study.table import TABLE


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__.strip())
        return 2
    out, studies = Path(sys.argv[1]), [Path(p) for p in sys.argv[2:]]
    out.write_text("\n".join(summary_lines(studies)) + "\n")
    made = [made_of(study / TABLE) for study in studies]
    if all(m is not None for m in made):  # a claim from an unrecorded study is not recorded either
        record([out], Made.joined(m for m in made if m is not None))
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
