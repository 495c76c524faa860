"""A study from its config: the preset and flags parsed into a `PipelineConfig`, and the stages run (or
resumed) in the study's folder with the results written as they grow; the library of
`lerobot-ivmc-pipeline` (`scripts/lerobot_ivmc_pipeline.py`)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import replace

import draccus

from lerobot_ivmc.pipeline.config import PRESETS_DIR, PipelineConfig
from lerobot_ivmc.pipeline.critical_path import critical_path, overlaps
from lerobot_ivmc.pipeline.results import RESULTS_DIR, adds_results, write_results
from lerobot_ivmc.pipeline.runner import (
    Executor,
    LocalExecutor,
    PipelineError,
    StageResult,
    check_root,
    claim_root,
    plan_stages,
    run_stages,
    study_holder,
    study_lock,
)
from lerobot_ivmc.pipeline.stages import CUDA, Stage, build_stages


def available_presets() -> list[str]:
    return sorted(p.stem for p in PRESETS_DIR.glob("*.yaml"))


def parse_config(argv: list[str]) -> PipelineConfig:
    """The preset named by `--preset` (default lite) with the other flags applied on top."""
    preset, rest = "lite", []
    for i, arg in enumerate(argv):
        if arg.startswith("--preset="):
            preset = arg.split("=", 1)[1]
        elif arg == "--preset" and i + 1 < len(argv):
            preset = argv[i + 1]
        elif not (i > 0 and argv[i - 1] == "--preset"):
            rest.append(arg)
    path = PRESETS_DIR / f"{preset}.yaml"
    if not path.is_file():
        raise ValueError(
            f"Unknown preset {preset!r}: choose --preset from {available_presets()} ({PRESETS_DIR})."
        )
    cfg = draccus.parse(config_class=PipelineConfig, config_path=path, args=rest)
    if not cfg.task:
        raise ValueError("Give the task: --task=push|pick_place|pick_reach.")
    cfg.preset = preset
    return cfg


def split_tasks(argv: list[str]) -> list[list[str]]:
    """One argument list per study: `--task=[push,pick_place]` gives one per task, each in its own folder
    (`<output_dir>/<task>` where `--output_dir` is given, else the default per task); other argv as is."""
    tasks = [arg.split("=", 1)[1] for arg in argv if arg.startswith("--task=")]
    if len(tasks) != 1 or not tasks[0].startswith("["):
        return [argv]
    names = [name.strip() for name in tasks[0].strip("[]").split(",") if name.strip()]
    if len(set(names)) != len(names) or not names:
        raise ValueError(f"--task={tasks[0]}: name each task once, e.g. --task=[push,pick_place].")
    studies = []
    for name in names:
        study = []
        for arg in argv:
            if arg.startswith("--task="):
                arg = f"--task={name}"
            elif arg.startswith("--output_dir="):
                arg = f"{arg}/{name}"
            study.append(arg)
        studies.append(study)
    return studies


def make_executor(cfg: PipelineConfig, log=print) -> Executor:
    """The executor `cfg.executor` names: local, or Ray (joining `address`, or a cluster of this machine)."""
    if cfg.executor.type == "ray":
        from lerobot_ivmc.pipeline.ray_executor import RayExecutor

        return RayExecutor(cfg.executor.address, cfg.executor.num_cpus, log)
    return LocalExecutor()


@contextmanager
def open_executor(cfg: PipelineConfig, log=print) -> Iterator[Executor]:
    """`make_executor`'s executor, closed (a Ray one let go) when the block ends."""
    executor = make_executor(cfg, log)
    try:
        yield executor
    finally:
        if hasattr(executor, "close"):
            executor.close()


def run_studies(cfgs: list[PipelineConfig], run_study: Callable[[PipelineConfig, Callable], dict]) -> None:
    """Run several studies (`split_tasks`): one after the other on the local executor; on Ray side by side,
    one driver thread each on one cluster, their log lines prefixed with the task. Raises the first
    `PipelineError` once every study has stopped."""
    if len(cfgs) == 1 or cfgs[0].executor.type != "ray":
        for cfg in cfgs:
            run_study(cfg, print)
        return
    from lerobot_ivmc.pipeline.ray_executor import RayExecutor

    cluster = RayExecutor(cfgs[0].executor.address, cfgs[0].executor.num_cpus)  # the studies join it
    errors: list[PipelineError] = []

    def run_one(cfg: PipelineConfig) -> None:
        try:
            run_study(cfg, lambda message: print(f"[{cfg.task}] {message}", flush=True))
        except PipelineError as error:
            errors.append(error)

    try:
        with ThreadPoolExecutor(len(cfgs)) as pool:
            list(pool.map(run_one, cfgs))
    finally:
        cluster.close()
    if errors:
        raise errors[0]


def with_train_device(cfg: PipelineConfig, executor: Executor) -> PipelineConfig:
    """`cfg` with `train.device` "auto" resolved where the trainings run: on Ray, CUDA if the cluster has a
    GPU; locally, if this machine has one (`stages.train_device`)."""
    if cfg.train.device != "auto" or not hasattr(executor, "has_gpus"):
        return cfg
    return replace(cfg, train=replace(cfg.train, device=CUDA if executor.has_gpus else "cpu"))


def run_pipeline(cfg: PipelineConfig, log=print) -> dict:
    """Run (or resume) the study; returns the results JSON (with `dry_run`, log the plan and return {})."""
    root = cfg.root
    if cfg.dry_run:
        check_root(root, {"task": cfg.task, "preset": cfg.preset})
        with open_executor(cfg, log) as executor:  # (on Ray, where trainings would run decides their device)
            plan = plan_stages(root, build_stages(with_train_device(cfg, executor)))
        for index, (name, state) in enumerate(plan, start=1):
            log(f"[{index}/{len(plan)}] {name}: {state}")
        to_run = sum(state != "done" for _, state in plan)
        log(f"{to_run} of {len(plan)} stages would run in {root}; nothing was run.")
        if holder := study_holder(root):
            log(f"A pipeline runs there now ({holder}): a second one would be refused until it ends.")
        return {}
    claim_root(root, {"task": cfg.task, "preset": cfg.preset})
    start = time.perf_counter()
    out = root / RESULTS_DIR
    with study_lock(root), open_executor(cfg, log) as executor:
        cfg = with_train_device(cfg, executor)
        stages = build_stages(cfg)

        def write_when_results_grow(timings: list[StageResult]) -> None:
            if adds_results(cfg, timings):
                write_results(cfg, stages, timings)
                log(f"Results so far in {out}")

        timings = run_stages(root, stages, log, on_stage_end=write_when_results_grow, executor=executor)
    log_stage_times(cfg, stages, timings, time.perf_counter() - start, log)
    log(f"\n{(out / 'table.md').read_text()}\nResults in {out}")
    return json.loads((out / f"{cfg.task}.json").read_text())


def log_stage_times(
    cfg: PipelineConfig, stages: list[Stage], timings: list[StageResult], elapsed: float, log=print
) -> None:
    """Each stage's wall time, their sum, this run's elapsed time, the critical path (the study's time with
    unlimited workers) and the stages that ran side by side."""
    log(f"\nStage wall times ({cfg.task}, preset {cfg.preset}; skipped stages show their earlier time):")
    by_name = {t.name: t for t in timings}
    for stage in stages:
        t = by_name[stage.name]
        log(f"  {t.name:<28} {t.status:<8} {t.wall_s:8.0f} s")
    path_s, path = critical_path(stages, {t.name: t.wall_s for t in timings})
    log(f"  {'sum of stage times':<37} {sum(t.wall_s for t in timings):8.0f} s")
    log(f"  {'this run':<37} {elapsed:8.0f} s ({cfg.executor.type} executor)")
    log(f"  {'critical path':<37} {path_s:8.0f} s: {' -> '.join(path)}")
    spans = {t.name: (t.started_s, t.ended_s) for t in timings if t.status == "ran"}
    side_by_side = overlaps(spans)
    if side_by_side:
        log(f"  ran side by side: {', '.join(f'{a} | {b}' for a, b in side_by_side)}")
