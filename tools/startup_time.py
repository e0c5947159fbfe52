"""Set-up and run time of a `harmony run` command, measured from outside the process.

    python tools/startup_time.py [--runs 5] [--empty-cache] [--keep] -- harmony run SCENARIO [options]

Runs the command N times one after another, each as a fresh subprocess with its own run directory (`--out` is
set per run: `<the command's --out, or a temporary directory>/run-<i>`), and reports the median, min and max of

  first step  time from spawn (time.time() just before the process starts) to the first control step's record
              (the `wall_clock_s` of the first row of <out>/steps.jsonl, else steps.csv): imports, scenario,
              robot, simulation, both MPCs' build and the first solve
  total       wall time of the whole process (run, results, plots; and the interpreter's exit)

Warm by default: HARMONY_CACHE as the environment has it (run the command once first to fill it).
`--empty-cache`: a fresh empty HARMONY_CACHE directory per run (nothing compiled, no prepared URDF).
The machine's load average is printed before the runs: other work on the machine skews every number.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harmony_cli.provenance import cpu_model


def first_step_clock(out: Path) -> float | None:
    """Unix time of the first control step's record in run directory `out` (None: no step was recorded)."""
    stream = out / "steps.jsonl"
    if stream.is_file():
        with stream.open(encoding="utf-8") as lines:
            first = lines.readline()
        if first.endswith("\n"):
            return float(json.loads(first)["wall_clock_s"])
    table = out / "steps.csv"
    if table.is_file():
        with table.open(newline="") as rows:
            row = next(csv.DictReader(rows), None)
        if row is not None:
            return float(row["wall_clock_s"])
    return None


def with_out(command: list[str], out: Path) -> list[str]:
    """`command` with its --out (if any) replaced by `out`."""
    kept, skip = [], False
    for arg in command:
        if skip:
            skip = False
        elif arg == "--out":
            skip = True
        elif not arg.startswith("--out="):
            kept.append(arg)
    return [*kept, "--out", str(out)]


def given_out(command: list[str]) -> Path | None:
    for i, arg in enumerate(command):
        if arg == "--out" and i + 1 < len(command):
            return Path(command[i + 1])
        if arg.startswith("--out="):
            return Path(arg.split("=", 1)[1])
    return None


def run_once(command: list[str], out: Path, cache: Path | None) -> tuple[float | None, float, int]:
    """(spawn to first step [s] or None, total wall time [s], exit code) of one run into `out`."""
    shutil.rmtree(out, ignore_errors=True)
    env = dict(os.environ)
    if cache is not None:
        env["HARMONY_CACHE"] = str(cache)
    start = time.time()
    code = subprocess.run(with_out(command, out), env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE).returncode
    total = time.time() - start
    clock = first_step_clock(out)
    return (None if clock is None else clock - start), total, code


def describe(name: str, values: list[float]) -> str:
    if not values:
        return f"{name:<11} (no values)"
    return (
        f"{name:<11} median {statistics.median(values):7.2f} s   min {min(values):7.2f} s   max {max(values):7.2f} s"
        f"   (n = {len(values)}: {', '.join(f'{v:.2f}' for v in values)})"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=5, help="runs of the command (default 5)")
    parser.add_argument("--empty-cache", action="store_true", help="a fresh empty HARMONY_CACHE per run")
    parser.add_argument("--keep", action="store_true", help="keep the run directories (default: removed)")
    parser.add_argument("command", nargs=argparse.REMAINDER, help="-- harmony run SCENARIO [options]")
    args = parser.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the command after --, e.g. -- .venv/bin/harmony run scenarios/smoke/box_lift.yaml --quiet")
    scratch = Path(tempfile.mkdtemp(prefix="harmony-startup-"))
    root = given_out(command) or scratch
    print(f"{cpu_model()}, {os.cpu_count()} cores; load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"{' '.join(command)}  ({'empty cache per run' if args.empty_cache else 'warm cache'}, {args.runs} runs)")
    first, total = [], []
    try:
        for i in range(args.runs):
            cache = Path(tempfile.mkdtemp(prefix="cache-", dir=scratch)) if args.empty_cache else None
            to_first, wall, code = run_once(command, root / f"run-{i}", cache)
            shown = "no step" if to_first is None else f"{to_first:.2f} s"
            print(f"run {i}: first step {shown}, total {wall:.2f} s, exit {code}", flush=True)
            if to_first is not None:
                first.append(to_first)
            total.append(wall)
            if cache is not None:
                shutil.rmtree(cache, ignore_errors=True)
            if not args.keep and root != scratch:
                shutil.rmtree(root / f"run-{i}", ignore_errors=True)
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)
    print(describe("first step", first))
    print(describe("total", total))
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
