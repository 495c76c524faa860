"""The dataset root a collection writes: checked against the config (the same collection resumes, another
one or foreign files are refused, a published dataset is kept), and how to resume an unfinished one."""

from __future__ import annotations

from pathlib import Path

from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.collect_config import CollectConfig
from lerobot_ivmc.datasets.collection_record import spec_render_style
from lerobot_ivmc.datasets.demo_suites import EDITED_STATE, suite_of
from lerobot_ivmc.datasets.root_lock import LOCK_FILE


def resume_hint(cfg: CollectConfig, spec: dict) -> str:
    """How to continue an unfinished collection of `spec` in `cfg.root`, or drop it."""
    drop = f"to drop it, remove {cfg.root / staging.WORK_DIR}."
    older = older_expert(spec)
    if older is not None:
        return f"Its demos are {older}, which no command of this version records: {drop}"
    args = f"--env.task={spec['task']} --env.split={spec['split']} --seed={spec['seed']}"
    args += f" --env.image_size={spec['image_size']}"
    args += f" --env.render_style={spec_render_style(spec)}"
    args += " --dataset.video=true" * bool(spec.get("video"))
    args += f" --action_noise={spec['action_noise']}" if spec.get("action_noise") else ""
    default_steps = suite_of(spec["task"]).default_episode_steps
    if spec.get("episode_steps", default_steps) != default_steps:
        args += f" --dataset.episode_steps={spec['episode_steps']}"
    return (
        f"To finish it, rerun with its arguments: lerobot-ivmc-collect --dataset.root={cfg.root} "
        f"--dataset.num_episodes={cfg.num_episodes} {args}; {drop}"
    )


def older_expert(spec: dict) -> str | None:
    """What a collection's demos are where an earlier version's expert recorded them (before its hold once
    the task was done, or with the state MetaWorld's scripted policy edited), else None."""
    suite = suite_of(spec["task"])
    if suite.recorded_before_the_hold(spec):
        return suite.before_hold
    if suite.recorded_with_edited_state(spec):
        return EDITED_STATE
    return None


def foreign_entries(root: Path, ours: set[str]) -> list[str]:
    return sorted(path.name for path in root.iterdir() if path.name not in ours)


def prepare_root(cfg: CollectConfig) -> Path | None:
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
                + resume_hint(cfg, stored)
            )
        ours = {staging.WORK_DIR, LOCK_FILE}
        publishing = (work / staging.PUBLISH_FILE).exists()
        if publishing:  # the folders already moved into the root are ours
            ours |= {name for name in staging.read_json(work / staging.PUBLISH_FILE)}
            ours -= {path.name for path in staging.publish_blockers(work, root)}
        foreign = foreign_entries(root, ours)
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
        older = older_expert(collection["spec"])
        if diffs and older is not None:
            raise ValueError(
                f"{root} holds {older}, which this version no longer records. "
                "Keep that dataset and collect into a new --dataset.root."
            )
        if diffs:
            raise ValueError(f"{root} holds a dataset of another spec: {'; '.join(diffs)}.")
        if collection["num_episodes"] != cfg.num_episodes:
            raise ValueError(
                f"{root} already holds {collection['num_episodes']} episodes, not {cfg.num_episodes}; "
                "collect into a new --dataset.root."
            )
        return None
    if foreign_entries(root, {LOCK_FILE}):
        raise ValueError(f"{root} is not empty and holds no collection of this plugin; refusing to write.")
    work.mkdir()
    staging.write_json(work / staging.SPEC_FILE, wanted)
    (work / staging.EPISODES_DIR).mkdir()
    return work
