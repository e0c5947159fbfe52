"""A run's figures drawn by helper processes while the run itself writes its tables.

Drawing a run's figures takes longer than writing steps.csv, summary.json and replay.npz, and matplotlib takes a
good part of a second to import. A run that draws every figure on a machine it has to itself therefore starts
helper processes before it builds its controllers: each imports the plotting code while the run builds and
simulates (it waits on its standard input, using no CPU), then draws its share of the figures (every parts-th) from
the steps it is sent at the run's end, while the run writes its tables. The helpers run at a lower priority so that
they never take time from the closed loop; a helper's error comes back to the run as the exception it raised.

python -m harmony_cli.experiment.figure_process PART PARTS   (a helper: a pickled job on stdin, the answer on
stdout)
"""

from __future__ import annotations

import os
import pickle
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

    from harmony_cli.scenario import Scenario

HELPERS = 2  # the figures are shared by this many processes
# [s] simulated: shorter runs (smoke runs, tests) start no helpers; their figures are quick to draw in the run itself
MIN_DURATION = 20.0
NICENESS = 5  # the helpers' priority below the run's


@dataclass(frozen=True)
class FigureJob:
    """What a helper draws from: the run directory, its steps, scenario and summary."""

    out: Path
    steps: pd.DataFrame
    scenario: Scenario
    summary: dict


class FigureProcesses:
    """Helper processes that draw a run's figures, started now and sent their job at the run's end (`draw`).
    Closing them without a job (`close`) ends them."""

    def __init__(self, parts: int = HELPERS):
        command = [sys.executable, "-m", __name__]
        self.children = [
            subprocess.Popen(
                [*command, str(part), str(parts)],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
            )
            for part in range(parts)
        ]

    def send(self, job: FigureJob) -> bool:
        """Every helper starts drawing its share of `job`'s figures; False if one has gone (killed with the run's
        process group): the run then draws them itself."""
        data = pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL)
        try:
            for child in self.children:
                assert child.stdin is not None
                child.stdin.write(data)
                child.stdin.close()
        except BrokenPipeError:
            return False
        return True

    def wait(self) -> None:
        """Back when every helper is done; a helper's exception raised here (the first one's)."""
        errors = []
        for child in self.children:
            assert child.stdout is not None
            answer = child.stdout.read()
            child.wait()
            if answer:
                errors.append(pickle.loads(answer))
            elif child.returncode != 0:
                errors.append(ChildProcessError(f"a figure process ended with exit code {child.returncode}"))
        if errors:
            raise errors[0]

    def close(self) -> None:
        """Every helper ended (those not sent a job read the end of their input and stop)."""
        for child in self.children:
            for stream in (child.stdin, child.stdout):
                if stream is not None and not stream.closed:
                    stream.close()
            child.wait()


def figure_processes(plots: str, concurrency: int, duration: float) -> FigureProcesses | None:
    """Helpers for a run that draws all its figures (`plots`), alone on its machine (`concurrency` 1: a CPU is
    free), and long enough to pay for them; otherwise None (it draws them itself)."""
    if plots != "all" or concurrency != 1 or duration < MIN_DURATION:
        return None
    return FigureProcesses()


def _serve(part: int, parts: int) -> int:
    os.nice(NICENESS)
    for name in ("SIGINT", "SIGHUP"):  # the terminal's signals are the run's to handle: it sends the job or closes
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_IGN)
    from harmony_cli.report.plots import plot_run_dir  # imported while the run builds and simulates

    _warm_up()
    answer, sys.stdout = sys.stdout.buffer, sys.stderr  # stdout carries the answer alone
    data = sys.stdin.buffer.read()
    if not data:  # closed without a job
        return 0
    job: FigureJob = pickle.loads(data)
    try:
        plot_run_dir(job.out, job.steps, job.scenario, job.summary, part, parts)
    except Exception as exc:  # noqa: BLE001 - the run reports it, as it would its own
        try:
            answer.write(pickle.dumps(exc))
        except Exception:  # noqa: BLE001 - an exception that does not pickle goes back as its text
            answer.write(pickle.dumps(RuntimeError(f"{type(exc).__name__}: {exc}")))
        return 1
    return 0


def _warm_up() -> None:
    """A small figure drawn and thrown away: the fonts, text layout and PNG encoder a first figure loads are loaded
    while the run goes on."""
    import io

    from harmony_cli.report.figure import plt, save

    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([1.0, 10.0], [1.0, 2.0], label="warm-up")
    ax.set(xscale="log", xlabel="x [m]", title="warm-up")
    ax.legend()
    save(fig, io.BytesIO())  # type: ignore[arg-type]


if __name__ == "__main__":
    sys.exit(_serve(int(sys.argv[1]), int(sys.argv[2])))
