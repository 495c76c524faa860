"""Demo collection: N successful expert demonstrations of a task recorded into a LeRobotDataset, the library
of `lerobot-ivmc-collect` (`scripts/lerobot_ivmc_collect.py`).

Attempt k replays the scene drawn by seed `attempt_seed(seed, k)` from the `--split` scenes; the dataset
keeps the successful attempts in attempt order, so the same arguments always give the same episodes.
Workers record attempts in parallel and stage each one durably; this process assembles the staged episodes
in order into a LeRobotDataset with LeRobot's own writer (`assembler.py`). Killed at any moment and rerun
with the same arguments, it continues from what was staged (`staging.py`, the root's checks in
`collect_root.py`). One collector writes a root at a time (`root_lock.py`), and a dataset is called complete
only after its data and metadata are checked to agree (`verify.py`).

Called from Python, `collect_demos` starts its workers with a fork server, so the calling script needs the
usual ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import logging
import multiprocessing
import multiprocessing.pool
import time
from pathlib import Path

from lerobot.datasets.lerobot_dataset import LeRobotDataset
from tqdm import tqdm

from lerobot_ivmc.datasets import expert_attempts, staging
from lerobot_ivmc.datasets.assembler import (
    EpisodeAssembler,
    batched_image_embedding,
    quiet_datasets,
    sort_stats,
)
from lerobot_ivmc.datasets.collect_config import CollectConfig, CollectSummary
from lerobot_ivmc.datasets.collect_root import (
    prepare_root,
)
from lerobot_ivmc.datasets.root_lock import RootLock
from lerobot_ivmc.datasets.verify import dataset_problems

logger = logging.getLogger(__name__)

# Give up (keeping what is staged) if the expert fails this often: something is broken, not unlucky.
_MAX_ATTEMPTS_PER_EPISODE = 4
_MIN_ATTEMPT_BUDGET = 20


def _plan(start: int, need: int, successes: dict, failures: set) -> list[int]:
    """Unstaged attempts from `start` on that, with the staged ones, may give `need` more episodes."""
    attempts, expected, attempt = [], 0, start
    while expected < need:
        if attempt not in failures:
            expected += 1
            if attempt not in successes:
                attempts.append(attempt)
        attempt += 1
    return attempts


def recorder_args(cfg: CollectConfig, episodes_dir: Path) -> tuple:
    """The arguments of the suite's recorder (`expert_attempts.Recorder`) and of
    `expert_attempts.init_worker`, which builds one per worker."""
    return (
        cfg.task,
        cfg.image_size,
        cfg.split,
        cfg.seed,
        episodes_dir,
        cfg.action_noise,
        cfg.episode_steps,
        cfg.render_style,
        cfg.expert_after_success,
    )


def _make_pool(cfg: CollectConfig, episodes_dir: Path) -> multiprocessing.pool.Pool:
    """Worker processes that record attempts.

    They are never forked from this process (MuJoCo's EGL contexts and torch's thread pools do not survive
    a fork): a fork server imports the recorder once and forks them from its clean state, which starts them
    much faster than spawning each.
    """
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload([expert_attempts.__name__])
    else:
        context = multiprocessing.get_context("spawn")
    return context.Pool(
        cfg.num_workers,
        initializer=expert_attempts.init_worker,
        initargs=recorder_args(cfg, episodes_dir),
    )


def _run_collection(cfg: CollectConfig, work: Path, summary: CollectSummary) -> EpisodeAssembler:
    """Record and assemble attempts until the build holds `num_episodes` episodes."""
    episodes_dir = work / staging.EPISODES_DIR
    successes, failures = staging.scan_attempts(episodes_dir)
    if successes or failures:
        logger.info("Resuming: %d staged episodes, %d failed attempts.", len(successes), len(failures))
    assembler = EpisodeAssembler(cfg, work / staging.BUILD_DIR)
    target, budget = cfg.num_episodes, _MAX_ATTEMPTS_PER_EPISODE * cfg.num_episodes + _MIN_ATTEMPT_BUDGET
    next_attempt = 0  # the first attempt not yet assembled or skipped
    bar = tqdm(total=target, unit="ep", desc=f"collect {cfg.task}", disable=not cfg.progress)
    start = time.perf_counter()

    def assemble_ready() -> None:
        nonlocal next_attempt
        while len(assembler.episodes) < target and (next_attempt in successes or next_attempt in failures):
            if next_attempt in successes:
                assembler.append(staging.read_episode(successes[next_attempt]))
                frames = len(assembler.episodes) * cfg.episode_steps
                bar.update(1)
                bar.set_postfix(frames=frames, fps=f"{frames / (time.perf_counter() - start):.0f}")
            next_attempt += 1

    pool = recorder = None
    try:
        if cfg.num_workers > 0 and _plan(0, target, successes, failures):
            pool = _make_pool(cfg, episodes_dir)  # workers start up while staged episodes are reassembled
        with quiet_datasets(), batched_image_embedding():
            assemble_ready()
            summary.resumed_episodes = len(assembler.episodes)
            while len(assembler.episodes) < target:
                attempts = _plan(next_attempt, target - len(assembler.episodes), successes, failures)
                if attempts[-1] >= budget:
                    raise RuntimeError(
                        f"The {cfg.task} expert failed {len(failures)} of {next_attempt} attempts; giving up "
                        f"(staged episodes are kept in {episodes_dir})."
                    )
                if cfg.num_workers == 0:
                    recorder = recorder or cfg.suite.recorder_class()(*recorder_args(cfg, episodes_dir))
                    results = map(recorder.record, attempts)
                else:
                    pool = pool or _make_pool(cfg, episodes_dir)
                    results = pool.imap(expert_attempts.record_in_worker, attempts)
                for attempt, success in results:
                    if success:
                        successes[attempt] = staging.attempt_path(episodes_dir, attempt, "npz")
                    else:
                        failures.add(attempt)
                    assemble_ready()
                    if len(assembler.episodes) >= target:
                        break
    finally:
        bar.close()
        if pool is not None:
            pool.terminate()  # attempts still in flight are not needed
            pool.join()
        if recorder is not None:
            recorder.close()
    summary.attempts = next_attempt
    summary.failed_attempts = len([a for a in failures if a < next_attempt])
    return assembler


def push_dataset(root: Path, repo_id: str, private: bool = False, tags: list[str] | None = None) -> None:
    """Publish a finished dataset with LeRobot's own `LeRobotDataset.push_to_hub`; a hub that cannot be
    reached (offline, no token, a network error) ends in one `CollectionError` saying the dataset is kept."""
    from huggingface_hub.errors import HfHubHTTPError, OfflineModeIsEnabled
    from requests.exceptions import RequestException

    dataset = LeRobotDataset(repo_id, root=root)
    try:
        dataset.push_to_hub(private=private, tags=tags or ["lerobot-ivmc", "expert-demonstrations"])
    except (HfHubHTTPError, OfflineModeIsEnabled, RequestException, OSError) as error:
        first_line = (str(error).strip().splitlines() or [""])[0]
        raise staging.CollectionError(
            f"The dataset in {root} is complete, but pushing it to {repo_id} failed "
            f"({type(error).__name__}: {first_line}). Nothing is lost: rerun the same command once the hub "
            "is reachable (and `huggingface-cli login` done); it finds the dataset complete and only pushes."
        ) from None


def collect_demos(cfg: CollectConfig) -> CollectSummary:
    """Record (or resume recording) `cfg.num_episodes` successful demonstrations into `cfg.root`.

    Returns:
        A summary of the finished dataset.
    """
    start = time.perf_counter()
    summary = CollectSummary(str(cfg.root), cfg.repo_id, cfg.task, cfg.split, cfg.num_episodes, 0)
    with RootLock(cfg.root, flag="--dataset.root"):
        work = prepare_root(cfg)
        if work is None:
            problems = dataset_problems(cfg.root, cfg.num_episodes, cfg.episode_steps)
            if problems:
                raise staging.CollectionError(
                    f"{cfg.root} holds a damaged dataset, not the {cfg.num_episodes} episodes it should: "
                    f"{'; '.join(problems)}. Nothing was changed; move it away or delete it, then collect "
                    "again."
                )
            logger.info("%s already holds the %d requested episodes.", cfg.root, cfg.num_episodes)
            collection = staging.read_json(cfg.root / staging.COLLECTION_INFO_PATH)
            summary.already_complete = True
            summary.attempts, summary.failed_attempts = collection["attempts"], collection["failed_attempts"]
            summary.episode_seeds = [ep["scene_seed"] for ep in collection["episodes"]]
        else:
            assembler = _run_collection(cfg, work, summary)
            assembler.dataset.finalize()
            build = work / staging.BUILD_DIR
            sort_stats(build)
            summary.episode_seeds = [ep["scene_seed"] for ep in assembler.episodes]
            collection = {
                "spec": cfg.spec(),
                "repo_id": cfg.repo_id,
                "num_episodes": cfg.num_episodes,
                "attempts": summary.attempts,
                "failed_attempts": summary.failed_attempts,
                "episodes": assembler.episodes,
            }
            staging.write_json(build / staging.COLLECTION_INFO_PATH, collection)
            problems = dataset_problems(build, cfg.num_episodes, cfg.episode_steps)
            if problems:
                raise staging.CollectionError(
                    f"The assembled dataset failed its check: {'; '.join(problems)}. It was not published; "
                    f"the staged episodes are kept in {work / staging.EPISODES_DIR}."
                )
            staging.publish(work, cfg.root)
    summary.num_frames = cfg.num_episodes * cfg.episode_steps
    if cfg.push_to_hub:  # a published root is only read, so other runs may open it meanwhile
        push_dataset(cfg.root, cfg.repo_id, private=cfg.private)
        summary.pushed = True
    summary.elapsed_s = time.perf_counter() - start
    return summary
