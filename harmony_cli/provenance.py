"""Which code and which machine made a result. A run's meta.json carries its code version; every directory of
committed results holds `provenance.json`, one entry per result file, written by the command that wrote the file
from the runs it read (or from itself, for what it measures in process). `make lint` (tools/check_results.py)
fails on a committed result whose entry is missing or names another code version than the source's.

The code version is harmony's version and a hash of the source a run executes (Python files, robot presets): an
edit there changes it, one to the command line, the console or the study report does not. It is computed from the
files, not from git, so it is the same in a clone, an installed wheel or an uncommitted tree."""

from __future__ import annotations

import hashlib
import json
import platform
import shutil
import subprocess
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from datetime import date
from functools import cache
from pathlib import Path

import harmony_cli

FILE = "provenance.json"
# what prints or reports, not what runs; the shipped scenarios count through each run's resolved scenario
NOT_IN_A_RUN = ("cli.py", "console.py", "commands", "study/report.py", "examples")
UNKNOWN = "unknown"


@cache
def code_version() -> str:
    """`<version>+<12 hex digits>`: harmony's version and a hash of the source a run executes."""
    root = Path(harmony_cli.__file__).parent
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.suffix in (".py", ".yaml", ".urdf") and p.is_file()):
        name = path.relative_to(root).as_posix()
        if not any(name == skip or name.startswith(f"{skip}/") for skip in NOT_IN_A_RUN):
            digest.update(name.encode() + b"\0" + path.read_bytes() + b"\0")
    return f"{getattr(harmony_cli, '__version__', '0')}+{digest.hexdigest()[:12]}"


@cache
def git_sha() -> str:
    """The checkout's commit, `-dirty` when the package's own files differ from it (results and notes beside it do
    not count); `unknown` outside a git checkout."""
    here = Path(harmony_cli.__file__).resolve().parent
    try:
        git = lambda *args: subprocess.run(["git", *args], cwd=here, capture_output=True, text=True).stdout.strip()
        sha, dirty = git("rev-parse", "HEAD"), git("status", "--porcelain", "--untracked-files=no", "--", ".")
    except OSError:
        return UNKNOWN
    return (sha + ("-dirty" if dirty else "")) if sha else UNKNOWN


def cpu_model(cpuinfo: Path = Path("/proc/cpuinfo")) -> str:
    """The CPU's model name (every timing is stated with it), and its family, model and stepping where the name
    alone does not tell generations apart (a virtual machine's "AMD EPYC" names CPUs 2x apart in speed)."""
    try:
        fields = dict(
            (key.strip(), value.strip())
            for key, _, value in (line.partition(":") for line in cpuinfo.read_text().splitlines())
            if value
        )
    except OSError:
        fields = {}
    if "model name" not in fields:
        return platform.processor() or UNKNOWN
    named = (("family", "cpu family"), ("model", "model"), ("stepping", "stepping"))
    generation = [f"{label} {fields[key]}" for label, key in named if key in fields]
    return fields["model name"] + (f" ({', '.join(generation)})" if generation else "")


@dataclass(frozen=True)
class Made:
    """What made a result file: the code version(s) and commit(s) of the runs it was made from, their CPU(s) and
    the day it was written. Several values (runs of different code) are joined by ', ' and never match one code
    version."""

    code_version: str
    git_sha: str
    cpu: str
    day: str

    @classmethod
    def here(cls) -> Made:
        """This process: its code, commit and CPU, today."""
        return cls(code_version(), git_sha(), cpu_model(), date.today().isoformat())

    @classmethod
    def joined(cls, made: Iterable[Made]) -> Made:
        """Of a result made from several (this process when there are none), dated today."""
        made = list(made)
        if not made:
            return cls.here()
        join = lambda field: ", ".join(sorted({getattr(m, field) for m in made}))
        return cls(join("code_version"), join("git_sha"), join("cpu"), date.today().isoformat())

    @classmethod
    def from_metas(cls, metas: Iterable[dict]) -> Made:
        """Of a result made from runs with these meta.json contents."""
        get = lambda meta, key: str(meta.get(key, UNKNOWN))
        return cls.joined(cls(get(m, "code_version"), get(m, "git_sha"), get(m, "cpu"), "") for m in metas)

    @classmethod
    def from_runs(cls, run_dirs: Iterable[Path]) -> Made:
        """Of a result made from these run directories (their meta.json)."""
        return cls.from_metas(json.loads((Path(d) / "meta.json").read_text()) for d in run_dirs)


def record(files: Iterable[Path], made: Made) -> None:
    """Enter `made` for each of `files` in the provenance.json of its directory (other entries kept)."""
    by_dir: dict[Path, list[str]] = {}
    for path in files:
        by_dir.setdefault(Path(path).parent, []).append(Path(path).name)
    for directory, names in by_dir.items():
        entries = read(directory)
        entries.update(dict.fromkeys(names, made))
        text = json.dumps({name: asdict(entries[name]) for name in sorted(entries)}, indent=1)
        (directory / FILE).write_text(text + "\n")


def read(directory: Path) -> dict[str, Made]:
    """The entries of `directory`'s provenance.json by file name (none without one)."""
    path = Path(directory) / FILE
    if not path.is_file():
        return {}
    return {name: Made(**entry) for name, entry in json.loads(path.read_text()).items()}


def made_of(path: Path) -> Made | None:
    """The entry of one result file (None: not recorded)."""
    return read(Path(path).parent).get(Path(path).name)


def copy(source: Path, target: Path) -> Path:
    """Copy a result file to `target` (a file, or a directory to copy into) with its entry: the source's, or the
    run's when it is a file of a run directory (a meta.json beside it). A file without either is copied without."""
    source, target = Path(source), Path(target)
    target = target / source.name if target.is_dir() else target
    shutil.copyfile(source, target)
    run = (source.parent / "meta.json").is_file()
    made = Made.from_runs([source.parent]) if run else made_of(source)
    if made is not None:
        record([target], made)
    return target
