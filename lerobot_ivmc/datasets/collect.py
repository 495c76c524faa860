"""`lerobot-ivmc-collect`: record N successful expert demonstrations of a task as a LeRobotDataset.

Example, in LeRobot's draccus style (`lerobot-record`'s `--dataset.*`; see `record_config.py`)::

    lerobot-ivmc-collect --env.task=pick_place --dataset.num_episodes=1000 \\
        --dataset.root=data/ivmc_pick_place --dataset.repo_id=local/ivmc_pick_place --num_workers=2 --seed=0

or with the short flags (``--task pick_place --num-episodes 1000 --root ... --repo-id ...``); a command
line uses one style or the other.

Attempt k replays the scene drawn by seed `attempt_seed(seed, k)` from the `--split` scenes; the dataset
keeps the successful attempts in attempt order, so the same arguments always give the same episodes.
Workers record attempts in parallel and stage each one durably; this process assembles the staged episodes
in order into a LeRobotDataset with LeRobot's own writer. Killed at any moment and rerun with the same
arguments, it continues from what was staged (see `lerobot_ivmc.datasets.staging`). One collector writes a
root at a time (`lerobot_ivmc.datasets.root_lock`), and a dataset is called complete only after its data
and metadata are checked to agree (`lerobot_ivmc.datasets.verify`).

Where the scene setup is recorded: every frame carries `scene.seed`, `scene.object_cell` and
`scene.target_cell`; `meta/ivmc_collection.json` holds the collection spec (task, scene split, base seed,
image size, features) and each episode's attempt index and scene. (LeRobot's own `info.json` "splits"
entry is its episode range, always "train", unrelated to the scene split.)

Called from Python, `collect_demos` starts its workers with a fork server, so the calling script needs the
usual ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import multiprocessing
import multiprocessing.pool
import sys
import time
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import datasets
import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset
from lerobot.datasets.utils import STATS_PATH, write_json
from tqdm import tqdm

from lerobot_ivmc.datasets import rollout, staging
from lerobot_ivmc.datasets.collection_record import spec_render_style
from lerobot_ivmc.datasets.features import (
    ACTION_KEY,
    DEMO_FPS,
    ENV_STATE_KEY,
    IMAGE_KEY,
    SCENE_OBJECT_CELL_KEY,
    SCENE_SEED_KEY,
    SCENE_TARGET_CELL_KEY,
    STATE_KEY,
    demo_features,
)
from lerobot_ivmc.datasets.root_lock import LOCK_FILE, RootLock
from lerobot_ivmc.datasets.verify import dataset_problems
from lerobot_ivmc.envs import (
    DEMO_EPISODE_STEPS,
    MAX_EPISODE_STEPS,
    TASK_ENVS,
    TASKS,
    check_demo_episode_steps,
    check_task,
    gym_id,
)
from lerobot_ivmc.envs.camera import check_image_size
from lerobot_ivmc.envs.render_styles import (
    DEFAULT_RENDER_STYLE,
    LEGACY_RENDER_STYLE,
    RENDER_STYLES,
    check_render_style,
)
from lerobot_ivmc.envs.scenes import SPLITS

logger = logging.getLogger(__name__)

ROBOT_TYPE = "fetch"
# Give up (keeping what is staged) if the expert fails this often: something is broken, not unlucky.
_MAX_ATTEMPTS_PER_EPISODE = 4
_MIN_ATTEMPT_BUDGET = 20


@dataclass
class CollectConfig:
    """What to collect and where.

    Args:
        task: task name, one of `lerobot_ivmc.envs.TASKS`.
        num_episodes: number of successful demonstrations the dataset must hold.
        root: local dataset folder; default ``data/ivmc_<task>`` under the working directory.
        repo_id: dataset id (``<hub user>/<name>`` to push); default ``local/ivmc_<task>``.
        split: scene split the demonstrations come from: "train" (policy training), "val" or "test".
        image_size: camera image height and width, in pixels.
        render_style: how the camera image is drawn (`fetch_env.RENDER_STYLES`); recorded in the dataset's
            `meta/ivmc_collection.json`, from which `lerobot-ivmc-train` records it in the checkpoint.
        video: store the camera as mp4 video instead of PNG frames (slower to decode when training).
        num_workers: parallel recording processes; 0 records in this process.
        seed: base seed from which every attempt's scene seed is derived.
        action_noise: std (action units, 1 = 5 cm) of Gaussian noise on the executed delta-EE command while
            the recorded action stays the expert's (DART); 0 records the expert's own trajectories.
        episode_steps: steps of every demo, 100 (4 s at 25 Hz) to 200 (the rollouts' limit). Success does
            not end a demo: once done, the expert holds its final pose, so longer demos show the policy's
            carried memory older states than the 100-step demos.
        push_to_hub: publish the finished dataset with `LeRobotDataset.push_to_hub`.
        private: make the hub repository private.
        progress: show a progress bar.
    """

    task: str
    num_episodes: int
    root: Path | None = None
    repo_id: str | None = None
    split: str = "train"
    image_size: int = 64
    render_style: str = DEFAULT_RENDER_STYLE
    video: bool = False
    num_workers: int = 2
    seed: int = 0
    action_noise: float = 0.0
    episode_steps: int = DEMO_EPISODE_STEPS
    push_to_hub: bool = False
    private: bool = False
    progress: bool = True

    def __post_init__(self) -> None:
        check_task(self.task)
        if not isinstance(self.num_episodes, int) or self.num_episodes <= 0:
            raise ValueError(f"num_episodes must be a positive integer, got {self.num_episodes!r}.")
        if self.split not in SPLITS:
            raise ValueError(f"Unknown split {self.split!r}; choose one of {SPLITS}.")
        check_image_size("image_size", self.image_size)
        check_render_style("render_style", self.render_style)
        if self.num_workers < 0:
            raise ValueError(f"num_workers must be >= 0, got {self.num_workers}.")
        if self.seed < 0:
            raise ValueError(f"seed must be >= 0, got {self.seed}.")
        check_demo_episode_steps("episode_steps", self.episode_steps)
        if not 0.0 <= self.action_noise <= 1.0:
            raise ValueError(f"action_noise must be in [0, 1] action units, got {self.action_noise}.")
        self.root = Path(self.root) if self.root is not None else Path("data") / f"ivmc_{self.task}"
        if self.root.exists() and not self.root.is_dir():
            raise ValueError(f"root {self.root} is a file; give a folder (new, or one this command made).")
        self.repo_id = self.repo_id or f"local/ivmc_{self.task}"
        if self.repo_id.count("/") != 1:
            raise ValueError(f"repo_id must look like '<user>/<name>', got {self.repo_id!r}.")
        if self.push_to_hub and self.repo_id.startswith("local/"):
            raise ValueError(f"--push-to-hub needs a hub repo id '<hf user>/<name>', got {self.repo_id!r}.")

    def spec(self) -> dict:
        """What the dataset in `root` must match to be resumed or reused (the episode count aside)."""
        # Noise-free collections keep the spec they had before noise injection existed. Noisy ones name the
        # expert's behaviour after its last waypoint (it holds that pose against the noise; before, it
        # stood still and let the noise random-walk the arm), so the two kinds never mix in one dataset.
        noise = (
            {"action_noise": self.action_noise, "expert_after_last_waypoint": "hold"}
            if self.action_noise > 0
            else {}
        )
        # Datasets of the Fetch XML's look keep the spec they had before render styles existed.
        style = {} if self.render_style == LEGACY_RENDER_STYLE else {"render_style": self.render_style}
        return staging.normalise(
            {
                **noise,
                **style,
                "task": self.task,
                "gym_id": gym_id(self.task),
                "split": self.split,
                "seed": self.seed,
                "image_size": self.image_size,
                "video": self.video,
                "fps": DEMO_FPS,
                "episode_steps": self.episode_steps,
                "features": demo_features(self.image_size, self.video),
            }
        )


@dataclass
class CollectSummary:
    """What a collection produced."""

    root: str
    repo_id: str
    task: str
    split: str
    num_episodes: int
    num_frames: int
    attempts: int = 0
    failed_attempts: int = 0
    resumed_episodes: int = 0
    already_complete: bool = False
    pushed: bool = False
    elapsed_s: float = 0.0
    episode_seeds: list[int] = field(default_factory=list)


class _Assembler:
    """Appends staged episodes, in order, to a LeRobotDataset built in the staging folder."""

    def __init__(self, cfg: CollectConfig, build_root: Path):
        self.task_description = TASK_ENVS[cfg.task].task_description
        self.dataset = LeRobotDataset.create(
            repo_id=cfg.repo_id,
            fps=DEMO_FPS,
            features=demo_features(cfg.image_size, cfg.video),
            root=build_root,
            robot_type=ROBOT_TYPE,
            use_videos=cfg.video,
        )
        self.episodes: list[dict] = []

    def append(self, episode: staging.StagedEpisode) -> None:
        scene = {
            SCENE_SEED_KEY: np.array([episode.scene_seed], dtype=np.int64),
            SCENE_OBJECT_CELL_KEY: np.array([episode.object_cell], dtype=np.int64),
            SCENE_TARGET_CELL_KEY: np.array([episode.target_cell], dtype=np.int64),
        }
        for t in range(episode.num_frames):
            self.dataset.add_frame(
                {
                    IMAGE_KEY: episode.images[t],
                    STATE_KEY: episode.state[t],
                    ENV_STATE_KEY: episode.environment_state[t],
                    ACTION_KEY: episode.action[t],
                    **scene,
                    "task": self.task_description,
                }
            )
        with warnings.catch_warnings():
            # `datasets` warns when it casts LeRobot's shape-(1,) arrays to scalar columns; harmless.
            warnings.filterwarnings("ignore", "Conversion of an array with ndim > 0", DeprecationWarning)
            self.dataset.save_episode()
        self.episodes.append(
            {
                "episode_index": len(self.episodes),
                "attempt": episode.attempt,
                "scene_seed": episode.scene_seed,
                "object_cell": episode.object_cell,
                "target_cell": episode.target_cell,
            }
        )


def _sort_stats(build_root: Path) -> None:
    """Rewrite LeRobot's `meta/stats.json` with sorted keys (it lists features in hash-seed order)."""

    def sort(obj):
        return {key: sort(obj[key]) for key in sorted(obj)} if isinstance(obj, dict) else obj

    path = build_root / STATS_PATH
    write_json(sort(staging.read_json(path)), path)


@contextlib.contextmanager
def _quiet_datasets() -> Iterator[None]:
    """Silence the `datasets` progress bars LeRobot triggers on every `save_episode`."""
    was_enabled = datasets.is_progress_bar_enabled()
    datasets.disable_progress_bars()
    try:
        yield
    finally:
        if was_enabled:
            datasets.enable_progress_bars()


def _resume_hint(cfg: CollectConfig, spec: dict) -> str:
    """How to continue an unfinished collection of `spec` in `cfg.root`, or drop it."""
    drop = f"to drop it, remove {cfg.root / staging.WORK_DIR}."
    if _made_by_the_drifting_expert(spec):
        return (
            "Its demos were recorded by the expert of before the final-pose hold, which no command of this "
            f"version records: {drop}"
        )
    args = f"--task {spec['task']} --split {spec['split']} --seed {spec['seed']}"
    args += f" --image-size {spec['image_size']}"
    args += f" --render-style {spec_render_style(spec)}"
    args += " --video" * bool(spec.get("video"))
    args += f" --action-noise {spec['action_noise']}" if spec.get("action_noise") else ""
    if spec.get("episode_steps", DEMO_EPISODE_STEPS) != DEMO_EPISODE_STEPS:
        args += f" --episode-steps {spec['episode_steps']}"
    return (
        f"To finish it, rerun with its arguments: lerobot-ivmc-collect --root {cfg.root} "
        f"--num-episodes {cfg.num_episodes} {args}; {drop}"
    )


def _made_by_the_drifting_expert(spec: dict) -> bool:
    """A noisy collection of before the expert held its final pose (its spec does not name the hold)."""
    return bool(spec.get("action_noise")) and "expert_after_last_waypoint" not in spec


def _foreign_entries(root: Path, ours: set[str]) -> list[str]:
    return sorted(path.name for path in root.iterdir() if path.name not in ours)


def _prepare_root(cfg: CollectConfig) -> Path | None:
    """Check `root` against the config; return the staging folder to collect into, or None if published.

    Deletes only what the collector wrote: its staging folder's build and temporary files. A publish cut
    short is finished, not rebuilt.

    Raises:
        ValueError: `root` holds something else: another task or feature spec, another episode count,
            or files that are not a collection of this plugin. Nothing is deleted then.
    """
    root, wanted = cfg.root, cfg.spec()
    work = root / staging.WORK_DIR
    staging.remove_tree(root / staging.TRASH_DIR)  # a finished collection killed while cleaning up
    if work.exists() and not (work / staging.SPEC_FILE).exists():
        staging.remove_tree(work)  # killed before anything was staged
    if work.exists():
        stored = staging.read_json(work / staging.SPEC_FILE)
        diffs = staging.spec_differences(stored, wanted)
        if diffs:
            raise ValueError(
                f"{root} holds an unfinished collection of another spec: {'; '.join(diffs)}. "
                + _resume_hint(cfg, stored)
            )
        ours = {staging.WORK_DIR, LOCK_FILE}
        publishing = (work / staging.PUBLISH_FILE).exists()
        if publishing:  # the folders already moved into the root are ours
            ours |= {name for name in staging.read_json(work / staging.PUBLISH_FILE)}
            ours -= {path.name for path in staging.publish_blockers(work, root)}
        foreign = _foreign_entries(root, ours)
        if foreign:
            raise ValueError(
                f"{root} holds an unfinished collection and files it did not write: {', '.join(foreign)}. "
                f"Move them out of {root} and rerun; nothing was changed."
            )
        if publishing:
            staging.finish_publish(work, root)
            return None
        staging.remove_tree(work / staging.BUILD_DIR)
        (work / staging.EPISODES_DIR).mkdir(exist_ok=True)
        return work
    if (root / "meta" / "info.json").exists():
        info_path = root / staging.COLLECTION_INFO_PATH
        if not info_path.exists():
            raise ValueError(f"{root} holds a LeRobot dataset not made by lerobot-ivmc-collect; refusing.")
        collection = staging.read_json(info_path)
        diffs = staging.spec_differences(collection["spec"], wanted)
        if diffs and _made_by_the_drifting_expert(collection["spec"]):
            raise ValueError(
                f"{root} holds noisy demos recorded before the expert held its final pose (after its last "
                "waypoint it stood still while the noise moved the arm); this version records the hold. "
                "Keep that dataset and collect into a new --root."
            )
        if diffs:
            raise ValueError(f"{root} holds a dataset of another spec: {'; '.join(diffs)}.")
        if collection["num_episodes"] != cfg.num_episodes:
            raise ValueError(
                f"{root} already holds {collection['num_episodes']} episodes, not {cfg.num_episodes}; "
                "collect into a new --root."
            )
        return None
    if _foreign_entries(root, {LOCK_FILE}):
        raise ValueError(f"{root} is not empty and holds no collection of this plugin; refusing to write.")
    work.mkdir()
    staging.write_json(work / staging.SPEC_FILE, wanted)
    (work / staging.EPISODES_DIR).mkdir()
    return work


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


def _recorder_args(cfg: CollectConfig, episodes_dir: Path) -> tuple:
    """The arguments of `rollout.Recorder` (and of `rollout.init_worker`, which builds one per worker)."""
    return (
        cfg.task,
        cfg.image_size,
        cfg.split,
        cfg.seed,
        episodes_dir,
        cfg.action_noise,
        cfg.episode_steps,
        cfg.render_style,
    )


def _make_pool(cfg: CollectConfig, episodes_dir: Path) -> multiprocessing.pool.Pool:
    """Worker processes that record attempts.

    They are never forked from this process (MuJoCo's EGL contexts and torch's thread pools do not survive
    a fork): a fork server imports the recorder once and forks them from its clean state, which starts them
    much faster than spawning each.
    """
    if "forkserver" in multiprocessing.get_all_start_methods():
        context = multiprocessing.get_context("forkserver")
        context.set_forkserver_preload([rollout.__name__])
    else:
        context = multiprocessing.get_context("spawn")
    return context.Pool(
        cfg.num_workers,
        initializer=rollout.init_worker,
        initargs=_recorder_args(cfg, episodes_dir),
    )


def _run_collection(cfg: CollectConfig, work: Path, summary: CollectSummary) -> _Assembler:
    """Record and assemble attempts until the build holds `num_episodes` episodes."""
    episodes_dir = work / staging.EPISODES_DIR
    successes, failures = staging.scan_attempts(episodes_dir)
    if successes or failures:
        logger.info("Resuming: %d staged episodes, %d failed attempts.", len(successes), len(failures))
    assembler = _Assembler(cfg, work / staging.BUILD_DIR)
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
        with _quiet_datasets():
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
                    recorder = recorder or rollout.Recorder(*_recorder_args(cfg, episodes_dir))
                    results = map(recorder.record, attempts)
                else:
                    pool = pool or _make_pool(cfg, episodes_dir)
                    results = pool.imap(rollout.record_in_worker, attempts)
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
        dataset.push_to_hub(private=private, tags=tags or ["lerobot-ivmc", "fetch", "expert-demonstrations"])
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
    with RootLock(cfg.root):
        work = _prepare_root(cfg)
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
            _sort_stats(build)
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


DRACCUS_PREFIXES = ("--env.", "--dataset.", "--config_path")


def _parse_args(argv: list[str] | None) -> CollectConfig:
    argv = sys.argv[1:] if argv is None else argv
    if any(arg.startswith(DRACCUS_PREFIXES) for arg in argv):
        return _parse_draccus(argv)
    parser = argparse.ArgumentParser(prog="lerobot-ivmc-collect", description=__doc__.split("\n")[0])
    parser.add_argument("--task", required=True, choices=TASKS)
    parser.add_argument("--num-episodes", type=int, required=True, help="successful demos to record")
    parser.add_argument("--root", type=Path, default=None, help="dataset folder (default: data/ivmc_<task>)")
    parser.add_argument("--repo-id", default=None, help="dataset id (default: local/ivmc_<task>)")
    parser.add_argument("--split", default="train", choices=SPLITS, help="scene split of the demos")
    parser.add_argument("--image-size", type=int, default=64, help="camera height and width in pixels")
    parser.add_argument(
        "--render-style", default=DEFAULT_RENDER_STYLE, choices=tuple(RENDER_STYLES), help="how frames look"
    )
    parser.add_argument("--video", action="store_true", help="store the camera as mp4 instead of PNG")
    parser.add_argument("--num-workers", type=int, default=2, help="recording processes (0: in-process)")
    parser.add_argument("--seed", type=int, default=0, help="base seed of the attempts' scene seeds")
    parser.add_argument(
        "--action-noise",
        type=float,
        default=0.0,
        help="std of noise on the executed delta-EE command, action units (DART); the label stays clean",
    )
    parser.add_argument(
        "--episode-steps",
        type=int,
        default=DEMO_EPISODE_STEPS,
        help=f"steps of every demo, {DEMO_EPISODE_STEPS} to {MAX_EPISODE_STEPS} (the expert holds its pose)",
    )
    parser.add_argument("--push-to-hub", action="store_true", help="publish with LeRobotDataset.push_to_hub")
    parser.add_argument("--private", action="store_true", help="make the hub repository private")
    parser.add_argument("--no-progress", dest="progress", action="store_false", help="hide the progress bar")
    args = parser.parse_args(argv)
    try:
        return CollectConfig(**vars(args))
    except ValueError as error:
        parser.error(str(error))


def _parse_draccus(argv: list[str]) -> CollectConfig:
    import draccus

    from lerobot_ivmc.datasets.record_config import RecordDemosConfig

    cfg = draccus.parse(config_class=RecordDemosConfig, args=argv)
    try:
        return cfg.to_collect_config()
    except ValueError as error:
        print(f"lerobot-ivmc-collect: error: {error}", file=sys.stderr)
        raise SystemExit(2) from error


def main(argv: list[str] | None = None) -> int:
    """Console entry point of `lerobot-ivmc-collect`."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(asctime)s %(name)s: %(message)s")
    cfg = _parse_args(argv)
    try:
        summary = collect_demos(cfg)
    except (ValueError, staging.CollectionError) as error:
        logger.error("%s", error)
        return 2
    except KeyboardInterrupt:
        logger.warning("Interrupted: staged episodes are kept; rerun the same command to resume.")
        return 130
    status = "already complete" if summary.already_complete else f"{summary.elapsed_s:.1f} s"
    print(
        f"{summary.num_episodes} {summary.task} demos ({summary.num_frames} frames, {summary.split} scenes) "
        f"in {summary.root} as {summary.repo_id}: {summary.attempts} attempts, {summary.failed_attempts} "
        f"failed, {summary.resumed_episodes} resumed from staging; {status}"
        + ("; pushed to the hub" if summary.pushed else "")
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
