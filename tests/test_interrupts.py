"""No run loses its data: signals end a run cleanly, the per-step log streams to steps.jsonl, and `harmony summarise`
rebuilds a run killed hard. The signal tests run `harmony run` on the smoke S made long, as a subprocess, and send
the signal a seeded random 3-8 s of wall time after its loop started."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SMOKE
from typer.testing import CliRunner

from harmony_cli.cli import app
from harmony_cli.experiment.interrupts import RunInterrupted, signals_end_the_run
from harmony_cli.experiment.rebuild import REBUILT
from harmony_cli.experiment.stream import StepStream, read_stream

HARMONY = Path(sys.executable).with_name("harmony")
LONG = ["--set", "sim.duration=3600"]  # an hour of steps: every signal lands mid-loop on any machine


def _loop_started(jsonl: Path, proc: subprocess.Popen, within_s: float = 90.0) -> None:
    """Until steps.jsonl has rows: its first write comes at the first step (the stream opened before the build)."""
    deadline = time.time() + within_s
    while not (jsonl.is_file() and jsonl.stat().st_size > 0):
        assert proc.poll() is None, proc.communicate()
        assert time.time() < deadline, f"no steps in {jsonl} after {within_s} s"
        time.sleep(0.05)


def _run_and_signal(out: Path, sig: signal.Signals, seed: int) -> tuple[subprocess.CompletedProcess, float]:
    """`harmony run` into `out`, `sig` a seeded 3-8 s into its loop; the finished process and when it was sent."""
    command = [str(HARMONY), "run", str(SMOKE), "--out", str(out), "--quiet", *LONG]
    # SIGINT at its default even when the tests run in a background job (which ignores it, and so would the run)
    default_int = lambda: signal.signal(signal.SIGINT, signal.SIG_DFL)  # noqa: E731
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_int)
    _loop_started(out / "steps.jsonl", proc)
    time.sleep(np.random.default_rng(seed).uniform(3.0, 8.0))
    proc.send_signal(sig)
    sent = time.time()
    stdout, stderr = proc.communicate(timeout=60)
    return subprocess.CompletedProcess(command, proc.returncode, stdout, stderr), sent


def _assert_interrupted_cleanly(out: Path, done: subprocess.CompletedProcess, sent: float, name: str) -> None:
    steps = pd.read_csv(out / "steps.csv")
    assert len(steps) > 100 and (steps["step"] == np.arange(len(steps))).all()  # every step so far, in order
    assert len(read_stream(out / "steps.jsonl")) == len(steps)  # the stream's final write has them all too
    last = steps["wall_clock_s"].iloc[-1]
    assert sent - 1.0 <= last <= sent + 0.05, f"last step {sent - last:.3f} s before the signal"
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["signal"], summary["steps"]) == ("interrupted", name, len(steps))
    assert name in summary["reason"] and f"after {len(steps)} steps" in summary["reason"]
    assert (out / "run.log").read_text().endswith("status: interrupted\n")
    assert (out / "solve_time.png").is_file() and (out / "tracking_error.png").is_file()
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "interrupted" in lines[0] and name in lines[0] and str(out) in lines[0], done.stderr


def test_sigterm_mid_run_keeps_the_steps_up_to_the_signal_and_exits_143(tmp_path):
    done, sent = _run_and_signal(tmp_path / "run", signal.SIGTERM, seed=1)
    assert done.returncode == 143, done.stderr
    _assert_interrupted_cleanly(tmp_path / "run", done, sent, "SIGTERM")


def test_sigint_mid_run_keeps_the_steps_up_to_the_signal_and_exits_130(tmp_path):
    done, sent = _run_and_signal(tmp_path / "run", signal.SIGINT, seed=2)
    assert done.returncode == 130, done.stderr
    _assert_interrupted_cleanly(tmp_path / "run", done, sent, "SIGINT")


def test_sigkill_leaves_a_readable_stream_that_summarise_rebuilds_the_run_from(tmp_path):
    out = tmp_path / "run"
    done, sent = _run_and_signal(out, signal.SIGKILL, seed=3)
    assert done.returncode == -signal.SIGKILL and not (out / "summary.json").exists()
    rows = read_stream(out / "steps.jsonl")
    assert [r["step"] for r in rows] == list(range(len(rows)))
    # written every 0.1 s: the last write holds the steps up to 0.1 s (and a step) before the kill
    assert sent - rows[-1]["wall_clock_s"] <= 0.5, f"last streamed step {sent - rows[-1]['wall_clock_s']:.2f} s old"
    rebuilt = subprocess.run([str(HARMONY), "summarise", str(out)], capture_output=True, text=True, timeout=60)
    assert rebuilt.returncode == 0, rebuilt.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["reason"], summary["steps"]) == ("killed", REBUILT, len(rows))
    assert len(pd.read_csv(out / "steps.csv")) == len(rows) and (out / "hand_paths.png").is_file()


def test_sighup_ends_an_in_process_run_with_exit_code_129_and_restores_the_handlers(tmp_path):
    if signal.getsignal(signal.SIGHUP) == signal.SIG_IGN:
        pytest.skip("the tests were started with SIGHUP ignored (nohup); a run keeps an inherited ignore")
    out, before, finished = tmp_path / "run", signal.getsignal(signal.SIGHUP), threading.Event()

    def hang_up() -> None:  # once the loop runs, and never after the run (a stray SIGHUP would end pytest)
        while not (finished.is_set() or (out / "steps.jsonl").is_file() and (out / "steps.jsonl").stat().st_size):
            time.sleep(0.05)
        if not finished.wait(0.5):
            os.kill(os.getpid(), signal.SIGHUP)

    threading.Thread(target=hang_up, daemon=True).start()
    try:
        result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", *LONG])
    finally:
        finished.set()
    assert result.exit_code == 129, result.output
    assert json.loads((out / "summary.json").read_text())["signal"] == "SIGHUP"
    assert signal.getsignal(signal.SIGHUP) is before


def test_a_second_signal_while_the_results_are_written_is_ignored():
    with pytest.raises(RunInterrupted) as info, signals_end_the_run() as guard:
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1)  # the handler raises here, at once
        finally:
            guard.hold()
            os.kill(os.getpid(), signal.SIGINT)  # would raise again (or KeyboardInterrupt) if not ignored
            time.sleep(0.01)
    assert info.value.signal_name == "SIGTERM" and info.value.exit_code == 143


def test_the_stream_writes_once_its_interval_has_passed_and_its_reader_ignores_a_cut_last_line(tmp_path):
    path = tmp_path / "steps.jsonl"
    stream = StepStream(path, every_s=0.3)
    stream.add({"step": 0, "success": np.bool_(True), "q": np.float32(0.5)})
    assert path.read_text() == ""  # buffered: no write in the control step
    time.sleep(0.3)
    stream.add({"step": 1, "new_key": float("nan")})  # rows may gain keys
    assert len(path.read_text().splitlines()) == 2
    with path.open("a") as f:
        f.write('{"step": 2, "t": 0.0')  # what a kill in the middle of a write leaves
    rows = read_stream(path)
    assert [r["step"] for r in rows] == [0, 1] and rows[0]["success"] is True and np.isnan(rows[1]["new_key"])
    stream.close()


@pytest.mark.slow  # 11 s (two worker runs)
def test_sigterm_to_compare_ends_every_worker_run_cleanly_and_exits_143(tmp_path):
    command = [str(HARMONY), "compare", str(SMOKE), "--grid", "mpc.knots=6,8", "--jobs", "2", "--out", str(tmp_path)]
    default_int = lambda: signal.signal(signal.SIGINT, signal.SIG_DFL)  # noqa: E731
    proc = subprocess.Popen(
        [*command, *LONG], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=default_int
    )
    runs = [tmp_path / "runs" / f"knots-{k}" for k in (6, 8)]
    for run in runs:
        _loop_started(run / "steps.jsonl", proc)
    time.sleep(2.0)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    assert stderr.strip().splitlines()[-1].startswith("interrupted: SIGTERM"), stderr
    for run in runs:  # each worker got the signal and wrote its results
        summary = json.loads((run / "summary.json").read_text())
        assert summary["status"] == "interrupted" and summary["signal"] == "SIGTERM", summary
        assert len(pd.read_csv(run / "steps.csv")) > 50


def test_a_signal_whose_exception_a_library_swallowed_still_ends_the_run_at_the_next_step(tmp_path, monkeypatch):
    """SIGTERM lands inside the whole-body MPC's step at step 5 and its RunInterrupted is swallowed there (as IPOPT
    does with an exception raised in a Python callback): the run still stops at step 6, exit 143."""
    from harmony_cli.mpc.wholebody import WholeBodyMPC

    original, calls = WholeBodyMPC.step, []

    def swallowing(self, *args, **kwargs):
        calls.append(1)
        if len(calls) == 5:
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.5)  # the handler raises here
            except RunInterrupted:
                pass
        return original(self, *args, **kwargs)

    monkeypatch.setattr(WholeBodyMPC, "step", swallowing)
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--quiet", *LONG])
    assert result.exit_code == 143, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["signal"] == "SIGTERM" and len(calls) == 5
