"""The pipeline's `ray` executor: each stage a Ray task with the stage's resources, side by side where the
cluster has room (`--executor.type=ray`; the optional extra `pip install 'lerobot_policy_ivmc[ray]'`).

The driver (`runner.run_stages`) keeps the study lock, decides what to skip, resume or redo and writes every
record; a task only runs the stage's command (`run_stage_task`), with its log and heartbeat and its threads
set from its CPU share, through `stage_process`, which takes the command's whole process group down with
it when the task's worker dies. With no address, a Ray cluster of this machine starts and ends with the run;
with one, the user's cluster, whose nodes must see the study's folder at the same path.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from lerobot_ivmc.pipeline.runner import PipelineError, run_command
from lerobot_ivmc.pipeline.stages import Stage, StageResources

# Environment variables that set the threads of a stage's numerical libraries (torch reads OMP's).
THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def run_stage_task(stage: Stage, log_path: Path, resume: bool, cpus: float) -> tuple[str, float | str, float]:
    """In a Ray worker: run the stage's command with `cpus` threads; ("done", wall seconds, start time) or
    ("failed", the message of its `PipelineError`, start time), the start as `time.time()`."""
    threads = str(max(1, math.floor(cpus)))
    started_at = time.time()
    try:
        wall = run_command(
            stage, log_path, resume, extra_env=dict.fromkeys(THREAD_VARIABLES, threads), tied_to_parent=True
        )
    except PipelineError as error:
        return "failed", str(error), started_at
    return "done", wall, started_at


class RayExecutor:
    """Stages as Ray tasks: `start` submits one with its resources (clamped to the cluster's largest node,
    so none waits for a node that does not exist), `wait_any` returns the first to end."""

    parallel = True

    def __init__(self, address: str | None = None, num_cpus: int | None = None, log=print):
        try:
            import ray
        except ImportError:  # a one-line refusal (cli.USER_ERRORS), not a traceback
            raise ValueError(
                "--executor.type=ray needs Ray: pip install 'lerobot_policy_ivmc[ray]' (or pip install ray), "
                "or drop --executor.type=ray."
            ) from None
        self.ray = ray
        self.owns_cluster = not ray.is_initialized()
        if self.owns_cluster:
            local = {"num_cpus": num_cpus} if address is None else {}
            ray.init(address=address, include_dashboard=False, log_to_driver=False, **local)
        self.task = ray.remote(max_retries=0)(run_stage_task)
        nodes = [node["Resources"] for node in ray.nodes() if node.get("Alive")]
        self.largest = {key: max(node.get(key, 0.0) for node in nodes) for key in ("CPU", "GPU", "memory")}
        log(
            f"Ray cluster: {len(nodes)} node(s), {sum(n.get('CPU', 0.0) for n in nodes):g} CPUs, "
            f"{sum(n.get('GPU', 0.0) for n in nodes):g} GPUs"
        )
        self.running: dict = {}

    @property
    def has_gpus(self) -> bool:
        return self.largest["GPU"] > 0

    def fit(self, resources: StageResources) -> dict:
        """Ray task options for `resources`, each at most what the largest node has."""
        options = {"num_cpus": min(resources.cpus, self.largest["CPU"])}
        if resources.gpus:
            options["num_gpus"] = min(resources.gpus, self.largest["GPU"])
        if resources.memory:
            options["memory"] = min(resources.memory, self.largest["memory"])
        return options

    def start(self, stage: Stage, log_path: Path, resume: bool) -> None:
        options = self.fit(stage.resources)
        ref = self.task.options(**options).remote(stage, log_path, resume, options["num_cpus"])
        self.running[ref] = stage.name

    def wait_any(self) -> tuple[str, float | PipelineError, float | None]:
        (ref,), _ = self.ray.wait(list(self.running), num_returns=1)
        name = self.running.pop(ref)
        try:
            status, value, started_at = self.ray.get(ref)
        except self.ray.exceptions.RayError as error:  # the worker died, or the task was cancelled
            return (
                name,
                PipelineError(
                    f"Stage {name}'s Ray task ended without a result ({type(error).__name__}: "
                    f"{str(error).splitlines()[0]}). Rerun the same command: finished stages are kept."
                ),
                None,
            )
        return name, (value if status == "done" else PipelineError(value)), started_at

    def cancel(self) -> None:
        """Stop every running stage (its worker kills the command's process group), then the cluster if
        this run started it."""
        for ref in self.running:
            self.ray.cancel(ref, force=False)
        if self.running:
            self.ray.wait(list(self.running), num_returns=len(self.running), timeout=30)
        self.running.clear()
        self.close()

    def close(self) -> None:
        if self.owns_cluster and self.ray.is_initialized():
            self.ray.shutdown()
