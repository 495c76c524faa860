"""The pipeline's ray executor on stand-in stages (`fake_stages.py`) and a local Ray cluster: dependency
order, independent stages side by side, the perception gate, stop on the first failure, a killed driver, two
nodes. (The smoke study on Ray, its results equal to the local executor's: `test_stage_kills.py`.)"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from fake_stages import fake_stage, killable_study

from lerobot_ivmc.pipeline.critical_path import critical_path, overlaps
from lerobot_ivmc.pipeline.runner import STAGES_DIR, PipelineError, run_stages
from lerobot_ivmc.pipeline.study import make_executor, parse_config, run_studies, split_tasks

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

ray = pytest.importorskip("ray")
from lerobot_ivmc.pipeline.ray_executor import RayExecutor  # noqa: E402


@pytest.fixture
def local_ray():
    """A Ray cluster of this machine's 2 CPUs for one test."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def record(root: Path, name: str) -> dict:
    path = root / STAGES_DIR / f"{name}.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_independent_stages_run_side_by_side_each_after_what_it_waits_for(tmp_path: Path, local_ray) -> None:
    root = tmp_path / "study"
    # Two stages first, so that two Ray workers have started (and imported the plugin) before the trainings.
    stages = [
        fake_stage(root, "warm_a", sleep=1.0),
        fake_stage(root, "warm_b", sleep=1.0),
        fake_stage(root, "collect", ("warm_a", "warm_b"), sleep=0.2),
        fake_stage(root, "train_a", ("collect",), sleep=3.0),
        fake_stage(root, "train_b", ("collect",), sleep=3.0),
        fake_stage(root, "check_a", ("train_a",), sleep=0.2),
        fake_stage(root, "foresight", ("train_b",), after=("check_a",)),  # gated by the check
        fake_stage(root, "eval", ("foresight",), cpus=8),  # more than the cluster has: clamped to 2
    ]
    results = run_stages(root, stages, log=lambda _: None, executor=RayExecutor())
    spans = {r.name: (r.started_s, r.ended_s) for r in results}
    assert {r.status for r in results} == {"ran"} and len(results) == len(stages)
    for stage in stages:
        for before in stage.prerequisites:
            assert spans[stage.name][0] >= spans[before][1], (stage.name, before)
    assert {"train_a", "train_b"} in [set(pair) for pair in overlaps(spans)]  # (either may start first)
    # Threads from the CPU share: 1 for a one-CPU stage, 2 (the clamp) for the one asking for 8.
    assert (root / "train_a" / "done").read_text() == "1"
    assert (root / "eval" / "done").read_text() == "2"
    # The same records as the local executor's: a local rerun skips everything.
    assert {r.status for r in run_stages(root, stages, log=lambda _: None)} == {"skipped"}
    seconds, path = critical_path(stages, {r.name: r.wall_s for r in results})
    assert path[1] == "collect" and path[-1] == "eval"
    assert seconds < sum(r.wall_s for r in results)


def test_the_first_failure_stops_new_stages_and_the_running_ones_finish(tmp_path: Path, local_ray) -> None:
    root = tmp_path / "study"
    stages = [
        fake_stage(root, "check", sleep=0.5, fail=True),
        fake_stage(root, "train", sleep=3.0),
        fake_stage(root, "foresight", after=("check",)),  # the gate failed: never started
        fake_stage(root, "eval", ("train",)),  # after the failure: never started
    ]
    with pytest.raises(PipelineError, match=r"Stage check failed \(exit 3\); its log is .*check\.log"):
        run_stages(root, stages, log=lambda _: None, executor=RayExecutor())
    assert record(root, "train")["status"] == "done"  # it was running: finished and recorded
    assert record(root, "check")["status"] == "running"  # redone by the next run
    assert record(root, "foresight") == {} and record(root, "eval") == {}


def test_a_killed_driver_takes_its_stages_down_and_the_next_run_resumes(tmp_path: Path) -> None:
    root = tmp_path / "study"
    root.mkdir()
    (root / "long_sleep.txt").write_text("120")
    script = Path(__file__).with_name("fake_stages.py")
    driver = subprocess.Popen(
        [sys.executable, str(script), str(root)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    pid_file = root / "long" / "pid"
    deadline = time.monotonic() + 120
    while not pid_file.is_file() and time.monotonic() < deadline and driver.poll() is None:
        time.sleep(0.2)
    assert pid_file.is_file(), "the long stage never started"
    time.sleep(0.5)
    stage_pid = int(pid_file.read_text())
    os.kill(driver.pid, signal.SIGKILL)  # the driver alone, as a crash of it would
    driver.wait()
    deadline = time.monotonic() + 60
    while alive(stage_pid) and time.monotonic() < deadline:
        time.sleep(0.5)
    assert not alive(stage_pid), "the stage's command outlived the driver"
    os.killpg(driver.pid, signal.SIGKILL)  # whatever of the cluster is left
    (root / "long_sleep.txt").write_text("0")
    results = run_stages(root, killable_study(root), log=lambda _: None)
    assert [(r.name, r.status) for r in results] == [("quick", "skipped"), ("long", "ran")]


def test_two_one_cpu_nodes_each_take_a_stage(tmp_path: Path) -> None:
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1})
    cluster.add_node(num_cpus=1)
    try:
        ray.init(address=cluster.address, log_to_driver=False)
        root = tmp_path / "study"
        stages = [fake_stage(root, name, sleep=3.0, cpus=2) for name in ("train_a", "train_b")]
        results = run_stages(root, stages, log=lambda _: None, executor=RayExecutor(log=lambda _: None))
        assert len(overlaps({r.name: (r.started_s, r.ended_s) for r in results})) == 1
        assert (root / "train_a" / "done").read_text() == "1"  # clamped to the largest node
    finally:
        ray.shutdown()
        cluster.shutdown()


def test_several_tasks_are_studies_of_their_own_side_by_side_on_one_cluster(tmp_path: Path) -> None:
    args = ["--task=[push,pick_place]", "--preset=smoke", f"--output_dir={tmp_path}", "--executor.type=ray"]
    studies = split_tasks([*args, "--executor.num_cpus=2"])
    assert [s[0] for s in studies] == ["--task=push", "--task=pick_place"]
    cfgs = [parse_config(study) for study in studies]
    assert [cfg.root for cfg in cfgs] == [tmp_path / "push", tmp_path / "pick_place"]
    spans = {}

    def run_study(cfg, log) -> dict:  # one stand-in stage per study, on the shared cluster
        stages = [fake_stage(cfg.root, "train", sleep=3.0)]
        executor = make_executor(cfg, log)
        results = run_stages(cfg.root, stages, log, executor=executor)
        executor.close()
        spans[cfg.task] = (time.time() - results[0].wall_s, time.time())
        return {}

    run_studies(cfgs, run_study)
    assert (tmp_path / "push" / "train" / "done").is_file() and (tmp_path / "pick_place" / "train").is_dir()
    assert overlaps(spans), spans
    with pytest.raises(ValueError, match="name each task once"):
        split_tasks(["--task=[push,push]"])


def test_without_ray_the_ray_executor_is_refused_in_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    with pytest.raises(ValueError, match=r"needs Ray: pip install 'lerobot_policy_ivmc\[ray\]'"):
        RayExecutor()
