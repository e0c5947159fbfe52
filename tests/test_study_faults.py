"""Studies that survive what clusters do: a run past its wall-time limit, a worker that dies, a driver killed
outright and started again, a second driver on the same directory, a half-written run directory, a Ray node lost
mid-run. The runs are the smoke box lift (studies/smoke_box_lift.yaml) or stand-ins (study_work.py)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import study_work
from conftest import ROOT
from test_study import STUDY, TIMING

from harmony_cli.study import pool
from harmony_cli.study.execute import ATTEMPTS, Job, commit, end_without_result, ended
from harmony_cli.study.lock import LOCK
from harmony_cli.study.ray_engine import RAY_RETRIES
from harmony_cli.study.runner import Options, plan_study, run_study
from harmony_cli.study.table import TABLE

HARMONY = Path(sys.executable).with_name("harmony")


def _study(tmp_path: Path, duration: float, samples: int) -> Path:
    """The smoke study with its runs `duration` [s] long and `samples` draws, as a file in tmp_path."""
    text = STUDY.read_text().replace('"sim.duration=0.4"', f'"sim.duration={duration}"')
    path = tmp_path / "study.yaml"
    path.write_text(text.replace("samples: 4", f"samples: {samples}").replace("../scenarios", str(ROOT / "scenarios")))
    return path


def _jobs(tmp_path: Path, n: int, timeout: float | None = None) -> list[Job]:
    runs = tmp_path / "runs"
    return [Job(f"r{i}", "", [], str(runs / f"r{i}"), "none", {"i": i}, timeout).again() for i in range(n)]


class _Driver:
    """The engines' callbacks as the study runner uses them: commit each job, note what was lost and why."""

    def __init__(self) -> None:
        self.done: list[str] = []
        self.lost: list[tuple[str, str]] = []

    def on_done(self, job: Job) -> None:
        commit(job)
        self.done.append(job.name)

    def on_lost(self, job: Job, category: str, reason: str) -> None:
        end_without_result(job.attempt_dir, category, reason)
        self.lost.append((job.name, category))
        self.on_done(job)


ENGINES = [{"jobs": 1}, {"jobs": 2}, pytest.param({"ray": "auto"}, marks=pytest.mark.slow)]


@pytest.mark.parametrize("engine", ENGINES, ids=["here", "workers", "ray"])
def test_a_run_past_its_wall_time_limit_ends_as_timeout_with_its_steps_and_log(tmp_path, engine):
    study = _study(tmp_path, 3600.0, 1)
    options = Options(out=tmp_path / "out", progress=False, plots="none", run_timeout=3.0, **engine)
    outcome = run_study(study, options)
    row = outcome.table.iloc[0]
    assert (row["status"], row["failure"], row["outcome"]) == ("failed", "timeout", "run failed: timeout")
    run_dir = Path(row["run_dir"])
    assert "wall-time limit" in json.loads((run_dir / "summary.json").read_text())["reason"]
    assert (run_dir / "steps.csv").stat().st_size > 0 and "timeout" in (run_dir / "run.log").read_text()


def test_a_run_that_ignores_its_limit_is_killed_with_its_worker_and_committed_as_timeout(tmp_path, monkeypatch):
    monkeypatch.setattr(pool, "GRACE_S", 1.0)
    driver = _Driver()
    jobs = _jobs(tmp_path, 2, timeout=1.0)
    start = time.monotonic()
    pool.Workers(2, driver.on_done, driver.on_lost, study_work.ignores_its_limit).run(jobs)
    assert time.monotonic() - start < 60.0
    assert sorted(driver.lost) == [("r0", "timeout"), ("r1", "timeout")]
    summary = json.loads((tmp_path / "runs" / "r0" / "summary.json").read_text())
    assert summary["failure"] == "timeout" and "started" in (tmp_path / "runs" / "r0" / "run.log").read_text()


def test_a_worker_that_dies_mid_run_is_replaced_its_run_started_again_and_then_recorded_as_worker_lost(tmp_path):
    driver = _Driver()
    pool.Workers(2, driver.on_done, driver.on_lost, study_work.dies_once).run(_jobs(tmp_path, 3))
    assert sorted(driver.done) == ["r0", "r1", "r2"] and driver.lost == []  # each died once, then completed
    assert all(ended(tmp_path / "runs" / f"r{i}") for i in range(3))
    driver = _Driver()
    pool.Workers(1, driver.on_done, driver.on_lost, study_work.dies).run(_jobs(tmp_path / "again", 1))
    assert driver.lost == [("r0", "worker_lost")]
    summary = json.loads((tmp_path / "again" / "runs" / "r0" / "summary.json").read_text())
    assert summary["status"] == "failed" and "died 2 times" in summary["reason"]


def _start_driver(study: Path, out: Path, *extra: str) -> subprocess.Popen:
    command = [str(HARMONY), "study", str(study), "--out", str(out), "--quiet", "--plots", "none", *extra]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _wait_for(condition, proc: subprocess.Popen, seconds: float = 180.0) -> None:
    deadline = time.time() + seconds
    while not condition():
        assert proc.poll() is None and time.time() < deadline, (proc.kill(), proc.communicate())
        time.sleep(0.1)


def _committed(out: Path) -> int:
    try:
        return int((pd.read_parquet(out / TABLE)["status"] == "completed").sum())
    except (OSError, ValueError, KeyError):
        return 0


def test_a_driver_killed_outright_and_started_again_gives_every_run_exactly_once(tmp_path):
    study, out = _study(tmp_path, 0.4, 6), tmp_path / "out"
    driver = _start_driver(study, out, "--jobs", "2")
    _wait_for(lambda: _committed(out) >= 2, driver)
    workers = _children(driver.pid)
    driver.kill()  # SIGKILL: no handler runs, its runs in flight are cut off
    driver.wait()
    deadline = time.time() + 60
    while any(_alive(pid) for pid in workers):  # its workers die with it (the parent-death signal)
        assert time.time() < deadline, f"workers {workers} outlived their driver"
        time.sleep(0.2)
    again = _start_driver(study, out, "--jobs", "2")
    _, stderr = again.communicate(timeout=600)
    assert again.returncode == 0, stderr
    table = pd.read_parquet(out / TABLE)
    assert len(table) == 6 and table["key"].is_unique and (table["status"] == "completed").all()
    assert sorted(p.name for p in (out / "runs").iterdir() if p.name != ATTEMPTS) == sorted(
        Path(d).name for d in table["run_dir"]
    )
    assert not (out / "runs" / ATTEMPTS).exists() or not any((out / "runs" / ATTEMPTS).iterdir())
    assert not (out / LOCK).exists()


def _children(pid: int) -> list[int]:
    """The processes whose parent is `pid` (Linux's /proc)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.append(int(stat.parent.name))
    return found


def _alive(pid: int) -> bool:
    """Running (not gone, not a zombie)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_a_second_driver_on_the_same_directory_is_refused_in_one_line_with_exit_code_2(tmp_path):
    study, out = _study(tmp_path, 3600.0, 1), tmp_path / "out"
    first = _start_driver(study, out, "--run-timeout", "0")
    _wait_for(lambda: any(out.glob(f"runs/{ATTEMPTS}/*/run.log")), first)
    second = _start_driver(study, out)
    _, stderr = second.communicate(timeout=120)
    first.send_signal(signal.SIGTERM)
    first.communicate(timeout=120)
    lines = stderr.strip().splitlines()
    assert second.returncode == 2 and len(lines) == 1, stderr
    assert str(out) in lines[0] and "another `harmony study` is running" in lines[0] and "pid" in lines[0]


def test_a_lock_left_by_a_driver_that_died_is_taken_over(tmp_path, monkeypatch):
    study, out = _study(tmp_path, 0.4, 1), tmp_path / "out"
    dead = subprocess.Popen(["true"])
    dead.wait()
    out.mkdir()
    (out / LOCK).write_text(json.dumps({"host": socket.gethostname(), "pid": dead.pid}))
    outcome = run_study(study, Options(out=out, progress=False, plots="none"))
    assert outcome.ran == 1 and not (out / LOCK).exists()


def test_a_run_directory_without_a_whole_summary_is_run_again_not_reported(tmp_path):
    study, out = _study(tmp_path, 0.4, 2), tmp_path / "out"
    first = run_study(study, Options(out=out, progress=False, plots="none"))
    broken = Path(first.table["run_dir"][1]) / "summary.json"
    broken.write_text(broken.read_text()[:40])  # cut mid-write (a full disk, a copy stopped)
    plan = plan_study(study, Options(out=out, progress=False))
    assert [run.name for run in plan.todo] == [Path(first.table["run_dir"][1]).name]
    assert plan.rows[plan.todo[0].name]["outcome"] == "incomplete" and plan.rows[plan.todo[0].name]["success"] is None
    again = run_study(study, Options(out=out, progress=False, plots="none"))
    assert again.ran == 1 and (again.table["status"] == "completed").all()
    assert json.loads(broken.read_text())["status"] == "completed"


def test_a_study_whose_table_cannot_be_written_ends_in_one_line_naming_the_file_with_exit_code_1(tmp_path):
    study, out = _study(tmp_path, 0.4, 1), tmp_path / "out"
    (out / f"{TABLE}.part").mkdir(parents=True)  # a path in the way of the table's write, as a full disk would be
    done = subprocess.run(
        [str(HARMONY), "study", str(study), "--out", str(out), "--quiet"], capture_output=True, text=True, timeout=300
    )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 1 and len(lines) == 1, done.stderr
    assert f"{TABLE}.part" in lines[0] and "Is a directory" in lines[0] and "--rerun interrupted" in lines[0]


@pytest.mark.slow  # ~2 min: a two-node Ray cluster on this machine
def test_a_ray_node_lost_mid_study_leaves_every_row_once_and_the_rows_of_an_undisturbed_run(tmp_path):
    ray = pytest.importorskip("ray")
    from ray.cluster_utils import Cluster

    study = _study(tmp_path, 0.4, 6)
    undisturbed = run_study(study, Options(out=tmp_path / "pool", jobs=2, progress=False, plots="none"))
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 0})
    nodes = [cluster.add_node(num_cpus=1) for _ in range(2)]
    out = tmp_path / "ray"
    try:
        ray.init(address=cluster.address, logging_level="ERROR", log_to_driver=False)
        import threading

        killed: list[int] = []

        def kill_a_node() -> None:  # when both nodes run a draw, one node goes, and a run in flight with it
            deadline = time.time() + 300
            while time.time() < deadline:
                busy = [p for p in out.glob(f"runs/{ATTEMPTS}/*/steps.jsonl") if p.stat().st_size]
                if len(busy) >= 2:
                    cluster.remove_node(nodes[0], allow_graceful=False)
                    killed.append(len(busy))
                    return
                time.sleep(0.05)

        killer = threading.Thread(target=kill_a_node)
        killer.start()
        on_ray = run_study(study, Options(out=out, ray="auto", progress=False, plots="none"))
        killer.join()
    finally:
        ray.shutdown()
        cluster.shutdown()
    assert killed, "no node was lost while two runs were in flight"
    assert on_ray.table["key"].is_unique and len(on_ray.table) == 6 and (on_ray.table["status"] == "completed").all()
    columns = [c for c in undisturbed.table.columns if not any(t in c for t in TIMING)]
    left = undisturbed.table.sort_values("sample")[columns].reset_index(drop=True)
    right = on_ray.table.sort_values("sample")[columns].reset_index(drop=True)
    pd.testing.assert_frame_equal(left, right)


def _ray_worker_running_a_run() -> int | None:
    """The pid of a Ray worker executing a study run (its process title names the task), if any."""
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if b"ray::run_job_packed" in cmdline.read_bytes():
                return int(cmdline.parent.name)
        except OSError:
            continue
    return None


@pytest.mark.slow  # ~1 min: a local Ray whose worker is killed on every attempt of a run
def test_a_ray_worker_killed_on_every_attempt_leaves_a_worker_lost_row_not_a_missing_one(tmp_path):
    ray = pytest.importorskip("ray")
    import threading

    study, out = _study(tmp_path, 3600.0, 1), tmp_path / "out"
    kills: list[int] = []

    def kill_every_attempt() -> None:  # each of Ray's attempts, once it runs, loses its worker (as to an OOM kill)
        deadline = time.time() + 240
        while len(kills) < RAY_RETRIES + 1 and time.time() < deadline:
            pid = _ray_worker_running_a_run()
            if pid is not None and pid not in kills and any(out.glob(f"runs/{ATTEMPTS}/*/run.log")):
                os.kill(pid, signal.SIGKILL)
                kills.append(pid)
            time.sleep(0.2)

    ray.init(num_cpus=1, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    try:
        killer = threading.Thread(target=kill_every_attempt)
        killer.start()
        outcome = run_study(study, Options(out=out, ray="auto", progress=False, plots="none", run_timeout=0))
        killer.join()
    finally:
        ray.shutdown()
    row = outcome.table.iloc[0]
    assert len(kills) == RAY_RETRIES + 1 and len(outcome.table) == 1
    assert (row["status"], row["failure"]) == ("failed", "worker_lost") and "lost 3 times" in row["reason"]


def test_a_negative_run_timeout_is_refused_in_one_line_naming_the_option_and_its_range():
    result = subprocess.run([str(HARMONY), "study", str(STUDY), "--run-timeout", "-1"], capture_output=True, text=True)
    lines = (result.stdout + result.stderr).strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert "--run-timeout" in lines[0] and "greater than or equal to 0" in lines[0]
