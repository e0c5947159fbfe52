"""`harmony study STUDY.yaml` and `harmony study report DIR`."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import typer

from harmony_cli.console import fail, literal, say
from harmony_cli.scenario import ScenarioError


def study(
    target: str = typer.Argument(..., help="STUDY.yaml, or `report` followed by a study directory"),
    study_dir: Path | None = typer.Argument(None, help="With `report`: the study directory"),
    out: Path | None = typer.Option(None, help="Study directory (default results/studies/<name>/<draws>)"),
    draws: str | None = typer.Option(
        None, help="The set of draws: dev, validation, ... (default: the study file's first)"
    ),
    seed: int | None = typer.Option(None, min=0, help="That set's seed (required for a set the file does not name)"),
    samples: int | None = typer.Option(None, min=1, help="Samples to run (default: the set's)"),
    jobs: int = typer.Option(1, min=1, help="Runs at once on this machine"),
    ray: str | None = typer.Option(
        None, help="Run on Ray: `auto` (this machine's cluster, or a local one) or an address"
    ),
    rerun: str = typer.Option("", help="Also run again: failed, interrupted or all (comma-separated)"),
    plots: str = typer.Option("failed", help="Per-run plots: none, failed (runs that did not succeed) or all"),
    quiet: bool = typer.Option(False, help="No progress bars"),
    grid: list[str] = typer.Option(
        [], help="A grid axis added to the study's, field=v1,v2,... (repeatable), e.g. sim.engine=pybullet,mujoco"
    ),
    run_timeout: float | None = typer.Option(
        None,
        min=0,
        help="Each run's wall-time limit [s]; a run past it ends as failure `timeout` with its logs (0: none; "
        "default: 120 s + 10 s per simulated second)",
    ),
):
    """Run a study (randomised scenes x grid, resumable) and write study.parquet and its report; or, as `harmony
    study report DIR`, write the report of a study directory again."""
    from harmony_cli.experiment.interrupts import RunInterrupted
    from harmony_cli.study.report import write_report
    from harmony_cli.study.runner import PLOTS, Options, run_study

    if target == "report":
        if study_dir is None or not (study_dir / "study.parquet").is_file():
            fail(f"study report: {str(study_dir)!r} is not a study directory (no study.parquet in it)")
            return
        with _unwritable("study report", "the study directory is as it was"):
            for path in write_report(study_dir):
                typer.echo(literal(str(path)))
        return
    if study_dir is not None:
        fail(f"study: unexpected argument {str(study_dir)!r}; `harmony study STUDY.yaml` or `harmony study report DIR`")
    if plots not in PLOTS:
        fail(f"--plots: {plots!r} is not valid; choose one of: {', '.join(PLOTS)}")
    reruns = tuple(r for r in rerun.split(",") if r)
    options = Options(out, jobs, ray, draws, seed, samples, reruns, plots, not quiet, tuple(grid), run_timeout)
    with _unwritable("study", "the runs that ended are kept; `--rerun interrupted` goes on from them"):
        try:
            outcome = run_study(Path(target), options)
        except ScenarioError as exc:
            fail(str(exc))
        except RunInterrupted as exc:
            say(
                "interrupted:",
                "yellow",
                f"{exc.signal_name}; the runs so far and study.parquet are in {options.out or 'results/studies'}",
            )
            raise typer.Exit(exc.exit_code) from None
        _tell(outcome)


@contextmanager
def _unwritable(command: str, kept: str) -> Iterator[None]:
    """A file the study cannot write or read (a full disk, a path in the way) ends the command in one line naming the
    file, why, and what is `kept`, exit code 1, instead of a traceback. A lost connection (Ray) is not a file error."""
    try:
        yield
    except (ConnectionError, TimeoutError):
        raise
    except OSError as exc:
        why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        say("error:", "red", f"{command}: stopped on a file error: {why}; {kept}")
        raise typer.Exit(1) from None


def _tell(outcome) -> None:
    """The report's files, each grid point's headline, and how many runs ran how fast."""
    from harmony_cli.study.report import headline, success_rates, write_report

    for path in write_report(outcome.out):
        typer.echo(literal(str(path)))
    for r in success_rates(outcome.table).itertuples():
        typer.echo(literal(f"{r.point}: {headline(r, outcome.table[outcome.table['point'] == r.point])}"))
    pace = f" in {outcome.minutes:.1f} min ({outcome.ran / outcome.minutes:.1f} runs per minute)" if outcome.ran else ""
    typer.echo(f"{outcome.ran} runs ran{pace}, {outcome.skipped} found done")
