"""`harmony study STUDY.yaml`: draw the scenes, plan the runs, skip those already done (resume), run the rest on
the chosen engine with a progress bar (ETA, running success rate), and keep study.parquet current after each.

One driver per study directory (lock.py). A run is a result once committed (execute.py); what a driver that died
left in flight is run again when the study is started again, as is a run directory without a whole summary."""

from __future__ import annotations

import json
import shutil
import socket
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import yaml
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from harmony_cli.console import warn
from harmony_cli.experiment.interrupts import RunInterrupted
from harmony_cli.provenance import Made, code_version, record
from harmony_cli.scenario import ScenarioError, load_scenario, scenario_yaml
from harmony_cli.study.execute import ATTEMPTS, Job, commit, end_without_result, ended, run_here
from harmony_cli.study.lock import study_lock
from harmony_cli.study.plan import PlannedRun, plan_runs
from harmony_cli.study.pool import Workers
from harmony_cli.study.ray_engine import run_ray
from harmony_cli.study.sampling import Sampler
from harmony_cli.study.scene_kind import describer
from harmony_cli.study.spec import StudySpec, base_scenario_path, draw_set, load_study, with_grid
from harmony_cli.study.table import INCOMPLETE, NOT_RUN, TABLE, run_row, write_table
from harmony_cli.tasks.scene_check import SceneCheck

RERUN = ("failed", "interrupted", "all")  # what `--rerun` may ask for besides the runs never started or cut off
PLOTS = ("none", "failed", "all")
# a run's default wall-time limit: TIMEOUT_S plus TIMEOUT_PER_S per second it simulates (its phases may wait as long
# again); a run takes about a third of its simulated time on a 2-core VM
TIMEOUT_S, TIMEOUT_PER_S = 120.0, 10.0
LOG = "study_log.jsonl"  # a line per `harmony study` that ran something: when, where, how many, how fast


@dataclass(frozen=True)
class Options:
    out: Path | None = None
    jobs: int = 1
    ray: str | None = None  # auto | a cluster address
    draws: str | None = None  # the set of draws (None: the study file's first)
    seed: int | None = None  # that set's seed replaced (a set the file does not have needs one)
    samples: int | None = None  # fewer (or more) than the study file says
    rerun: tuple[str, ...] = ()
    plots: str = "failed"
    progress: bool = True
    grid: tuple[str, ...] = ()  # grid axes added on the command line (field=v1,v2,...)
    run_timeout: float | None = None  # [s] each run's wall-time limit (None: from its duration; <= 0: none)


@dataclass(frozen=True)
class StudyOutcome:
    out: Path
    table: pd.DataFrame
    ran: int
    skipped: int
    minutes: float = 0.0  # the runs' wall time


def run_timeout(run: PlannedRun, asked: float | None) -> float | None:
    """[s] a run's wall-time limit: `asked`, none for `asked` <= 0, or from its simulated duration."""
    if asked is None:
        return TIMEOUT_S + TIMEOUT_PER_S * run.duration
    return asked if asked > 0 else None


def study_dir(spec: StudySpec, draws: str, out: Path | None) -> Path:
    return out if out is not None else Path("results/studies") / spec.name / draws


def _bar(progress: bool) -> Progress:
    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        TextColumn("{task.fields[rate]}"),
        disable=not progress,
    )


def _wanted(row: dict, rerun: tuple[str, ...]) -> bool:
    """Run it now? Never started, or cut off (its driver died; its directory half written): yes; completed: with
    `all`; failed / interrupted (a run that ended on its own): when asked."""
    status = row["status"]
    if status == "not run" or status in INCOMPLETE:
        return True
    if "all" in rerun:
        return True
    if status == "failed":
        return "failed" in rerun
    return status in NOT_RUN and "interrupted" in rerun


def _rate(rows: dict[str, dict]) -> str:
    results = [r["success"] for r in rows.values() if r["success"] is not None]
    return f"success {sum(results)}/{len(results)}" if results else ""


@dataclass(frozen=True)
class Plan:
    """A study's runs, their rows as the study directory has them, and those to run now."""

    spec: StudySpec
    scenario_path: Path
    out: Path
    runs: list[PlannedRun]
    rows: dict[str, dict]
    todo: list[PlannedRun]


def _drawn(path: Path, options: Options) -> tuple[StudySpec, Path, Path, list[PlannedRun]]:
    """The study file's spec, base scenario, directory and runs, the scenes drawn (ScenarioError: a bad study or
    base scenario)."""
    if options.rerun and not set(options.rerun) <= set(RERUN):
        raise ScenarioError(f"--rerun {','.join(options.rerun)}: choose from {', '.join(RERUN)}")
    spec = with_grid(path, load_study(path), options.grid)
    name, draws = draw_set(spec, options.draws, options.seed, options.samples)
    scenario_path = base_scenario_path(path, spec)
    check = SceneCheck(scenario_path.parent, spec.check.clearance)
    sampler = Sampler(spec, scenario_path, check, (name, draws.seed), describer(check))
    warn(sampler.notices)
    with _bar(options.progress) as bar:
        task = bar.add_task(f"drawing scenes ({name}, seed {draws.seed})", total=draws.samples, rate="")
        runs = plan_runs(spec, sampler, draws.samples, lambda done, total: bar.update(task, completed=done))
    return spec, scenario_path, study_dir(spec, name, options.out), runs


def _rows_todo(runs: list[PlannedRun], out: Path, rerun: tuple[str, ...]) -> tuple[dict[str, dict], list[PlannedRun]]:
    """The runs' rows as the study directory has them, and those to run now."""
    rows = {run.name: run_row(run, out / "runs" / run.name) for run in runs}
    return rows, [run for run in runs if _wanted(rows[run.name], rerun)]


def plan_study(path: Path, options: Options) -> Plan:
    """Draw the scenes and find what the study directory already has (ScenarioError: a bad study or base
    scenario)."""
    spec, scenario_path, out, runs = _drawn(path, options)
    return Plan(spec, scenario_path, out, runs, *_rows_todo(runs, out, options.rerun))


def run_study(path: Path, options: Options) -> StudyOutcome:
    """Run a study (ScenarioError: a bad study or base scenario, or another driver on its directory, nothing
    run); RunInterrupted propagates after the runs in flight wrote their results and study.parquet is current."""
    spec, scenario_path, out, runs = _drawn(path, options)
    out.mkdir(parents=True, exist_ok=True)
    with study_lock(out):
        rows, todo = _rows_todo(runs, out, options.rerun)  # read once no other driver can write the directory
        shutil.rmtree(out / "runs" / ATTEMPTS, ignore_errors=True)  # a dead driver's runs in flight: no results
        (out / "study.yaml").write_text(
            path.read_text()
            if not options.grid
            else yaml.safe_dump(spec.model_dump(mode="json", exclude_defaults=True), sort_keys=False)
        )
        base = scenario_yaml(load_scenario(scenario_path, spec.set))  # the base scene, for the report's map
        (out / "base_scenario.yaml").write_text(base)
        for run in todo:
            shutil.rmtree(out / "runs" / run.name, ignore_errors=True)  # a run again starts from nothing
            rows[run.name] = run_row(run, out / "runs" / run.name)
        write_table(list(rows.values()), out / TABLE)
        jobs = [_job(run, spec, scenario_path, out, options) for run in todo]
        start = time.monotonic()
        _execute(jobs, rows, {run.name: run for run in runs}, out, options, spec.name)
        minutes = (time.monotonic() - start) / 60.0
        shutil.rmtree(out / "runs" / ATTEMPTS, ignore_errors=True)  # lost workers' attempts: every run is committed
        table = write_table(list(rows.values()), out / TABLE)
        made = Made.from_runs(d for d in (out / "runs" / run.name for run in runs) if (d / "meta.json").is_file())
        record([out / TABLE, out / "study.yaml", out / "base_scenario.yaml"], made)
        _log(out, options, len(todo), minutes)
    return StudyOutcome(out, table, len(todo), len(runs) - len(todo), minutes)


def _execute(jobs: list[Job], rows: dict, by_name: dict, out: Path, options: Options, name: str) -> None:
    """The jobs on the engine the options ask for, each committed as it ends and its row written at once."""
    with _bar(options.progress) as bar:
        task = bar.add_task(f"{name}: {len(jobs)} runs", total=len(jobs), rate=_rate(rows))
        committed: set[str] = set()

        def done(job: Job) -> None:
            commit(job)
            committed.add(job.name)
            rows[job.name] = run_row(by_name[job.name], out / "runs" / job.name)
            write_table(list(rows.values()), out / TABLE)
            bar.update(task, advance=1, rate=_rate(rows))

        def lost(job: Job, category: str, reason: str) -> None:
            end_without_result(job.attempt_dir, category, reason)
            done(job)

        try:
            if options.ray is not None:
                run_ray(jobs, options.ray, done, lost)
            elif options.jobs > 1:
                Workers(options.jobs, done, lost).run(jobs)
            else:
                run_here(jobs, done)
        except RunInterrupted as exc:
            exc.run_dir = out
            raise
        finally:  # interrupted too: the runs in flight that ended on their own (interrupted) are results
            for job in jobs:
                if job.name not in committed and ended(job.attempt_dir):
                    commit(job)
                rows[job.name] = run_row(by_name[job.name], out / "runs" / job.name)
            write_table(list(rows.values()), out / TABLE)


def _log(out: Path, options: Options, ran: int, minutes: float) -> None:
    """A line in the study's log: when, on which engine and host, how many runs, how fast."""
    if not ran:
        return
    engine = f"ray {options.ray}" if options.ray is not None else f"{options.jobs} local job(s)"
    line = {
        "ended": time.strftime("%Y-%m-%d %H:%M:%S"),
        "host": socket.gethostname(),
        "engine": engine,
        "runs": ran,
        "minutes": round(minutes, 3),
        "runs_per_minute": round(ran / minutes, 3) if minutes > 0 else None,
    }
    with (out / LOG).open("a") as log:
        log.write(json.dumps(line) + "\n")


def _job(run: PlannedRun, spec: StudySpec, scenario_path: Path, out: Path, options: Options) -> Job:
    record = {
        "study": spec.name,
        "draws": run.sample.draws,
        "seed": run.sample.seed,
        "sample": run.sample.index,
        "point": run.point.values,
        "point_name": run.label,
        "values": run.sample.values,
        "rejected": run.sample.rejected,
        "key": run.key,
        "code_version": code_version(),
    }
    timeout = run_timeout(run, options.run_timeout)
    job = Job(run.name, str(scenario_path), run.overrides, str(out / "runs" / run.name), options.plots, record, timeout)
    return job.again()
