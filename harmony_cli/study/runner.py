"""`harmony study STUDY.yaml`: draw the scenes, plan the runs, skip those already done (resume), run the rest on
the chosen engine with a progress bar (ETA, running success rate), and keep study.parquet current after each."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import yaml
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from harmony_cli.console import warn
from harmony_cli.experiment.interrupts import RunInterrupted
from harmony_cli.scenario import ScenarioError, load_scenario, scenario_yaml
from harmony_cli.study.execute import Job, run_here, run_pool, run_ray
from harmony_cli.study.plan import PlannedRun, code_version, plan_runs
from harmony_cli.study.sampling import Sampler
from harmony_cli.study.spec import StudySpec, base_scenario_path, draw_set, load_study, with_grid
from harmony_cli.study.table import NOT_RUN, TABLE, run_row, write_table
from harmony_cli.tasks.scene_check import SceneCheck

RERUN = ("failed", "interrupted", "all")  # what `--rerun` may ask for besides the runs never started
PLOTS = ("none", "failed", "all")


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


@dataclass(frozen=True)
class StudyOutcome:
    out: Path
    table: pd.DataFrame
    ran: int
    skipped: int


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
    """Run it now? Never started: yes; completed: with `all`; failed / interrupted: when asked."""
    status = row["status"]
    if status == "not run":
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


def plan_study(path: Path, options: Options) -> Plan:
    """Draw the scenes and find what the study directory already has (ScenarioError: a bad study or base
    scenario)."""
    if options.rerun and not set(options.rerun) <= set(RERUN):
        raise ScenarioError(f"--rerun {','.join(options.rerun)}: choose from {', '.join(RERUN)}")
    spec = with_grid(path, load_study(path), options.grid)
    name, draws = draw_set(spec, options.draws, options.seed, options.samples)
    scenario_path = base_scenario_path(path, spec)
    sampler = Sampler(spec, scenario_path, SceneCheck(scenario_path.parent, spec.check.clearance), (name, draws.seed))
    warn(sampler.notices)
    out = study_dir(spec, name, options.out)
    with _bar(options.progress) as bar:
        task = bar.add_task(f"drawing scenes ({name}, seed {draws.seed})", total=draws.samples, rate="")
        runs = plan_runs(spec, sampler, draws.samples, lambda done, total: bar.update(task, completed=done))
    rows = {run.name: run_row(run, out / "runs" / run.name) for run in runs}
    todo = [run for run in runs if _wanted(rows[run.name], options.rerun)]
    return Plan(spec, scenario_path, out, runs, rows, todo)


def run_study(path: Path, options: Options) -> StudyOutcome:
    """Run a study (ScenarioError: a bad study or base scenario, nothing run); RunInterrupted propagates after
    the runs in flight wrote their results and study.parquet is current."""
    plan = plan_study(path, options)
    spec, out, runs, rows, todo = plan.spec, plan.out, plan.runs, plan.rows, plan.todo
    out.mkdir(parents=True, exist_ok=True)
    (out / "study.yaml").write_text(
        path.read_text()
        if not options.grid
        else yaml.safe_dump(spec.model_dump(mode="json", exclude_defaults=True), sort_keys=False)
    )
    base = scenario_yaml(load_scenario(plan.scenario_path, spec.set))  # the base scene, for the report's map
    (out / "base_scenario.yaml").write_text(base)
    for run in todo:
        shutil.rmtree(out / "runs" / run.name, ignore_errors=True)  # a run again starts from nothing
        rows[run.name] = run_row(run, out / "runs" / run.name)
    by_name = {run.name: run for run in runs}
    write_table(list(rows.values()), out / TABLE)
    jobs = [_job(run, spec, plan.scenario_path, out, options.plots) for run in todo]
    with _bar(options.progress) as bar:
        task = bar.add_task(f"{spec.name}: {len(todo)} runs", total=len(todo), rate=_rate(rows))

        def done(name: str) -> None:
            rows[name] = run_row(by_name[name], out / "runs" / name)
            write_table(list(rows.values()), out / TABLE)
            bar.update(task, advance=1, rate=_rate(rows))

        try:
            if options.ray is not None:
                run_ray(jobs, options.ray, done)
            elif options.jobs > 1:
                run_pool(jobs, options.jobs, done)
            else:
                run_here(jobs, done)
        except RunInterrupted as exc:
            exc.run_dir = out
            raise
        finally:  # interrupted too: the runs in flight wrote their results; the table says so
            rows |= {run.name: run_row(run, out / "runs" / run.name) for run in todo}
            table = write_table(list(rows.values()), out / TABLE)
    return StudyOutcome(out, table, len(todo), len(runs) - len(todo))


def _job(run: PlannedRun, spec: StudySpec, scenario_path: Path, out: Path, plots: str) -> Job:
    record = {
        "study": spec.name,
        "draws": run.sample.draws,
        "seed": run.sample.seed,
        "sample": run.sample.index,
        "point": run.point,
        "values": run.sample.values,
        "rejected": run.sample.rejected,
        "key": run.key,
        "code_version": code_version(),
    }
    return Job(run.name, str(scenario_path), run.overrides, str(out / "runs" / run.name), plots, record)
