"""Did a trained policy learn where the object is? The measurement behind `lerobot-ivmc-perception`
(`scripts/lerobot_ivmc_perception.py`): the median error of the network's object estimate over the first
steps of validation scenes, watching the expert and acting, and the verdict against a limit."""

import statistics
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import torch
from lerobot.configs.eval import EvalPipelineConfig

from lerobot_ivmc.envs import make_task_env_from_config
from lerobot_ivmc.envs.fetch_env import IvmcFetchEnv
from lerobot_ivmc.evaluation.beliefs import BeliefReader, check_network_request
from lerobot_ivmc.evaluation.compatibility import check_policy_matches_env
from lerobot_ivmc.evaluation.loading import load_policy
from lerobot_ivmc.experts import WaypointExpert, make_expert

RECORD_FILE = "perception.json"
DRIVERS = ("watching_expert", "acting")
# Acting object error of the lite pick_place policies that learned (docs/archive/RESULTS_superseded.md,
# "pick_place: the perception check (which training runs learned where the cube is)").
LEARNED_CM = "0.9 to 2.0"


@dataclass
class PerceptionCheckConfig(EvalPipelineConfig):
    """`lerobot-eval`'s policy, env, seed and output folder, plus:

    Args:
        n_scenes: scenes measured: the scenes of seeds `seed`, `seed + 1`, ... of `--env.split`.
        steps: steps measured from each episode's start (the object is still where it was spawned, or
            just being grasped: where a policy that does not know where it is goes wrong).
        max_object_error_cm: the largest acting object error (cm) a policy that learned where the object is
            shows; 0: no limit, only report.
        fail_above_limit: exit 1 when the acting error exceeds the limit (false: only record the verdict).
    """

    n_scenes: int = 20
    steps: int = 30
    max_object_error_cm: float = 0.0
    fail_above_limit: bool = True


def check_inputs(cfg: PerceptionCheckConfig) -> None:
    check_network_request(cfg, "lerobot-ivmc-perception")
    if cfg.steps <= 0 or cfg.n_scenes <= 0:
        raise ValueError(f"--steps and --n_scenes must be positive, got {cfg.steps}, {cfg.n_scenes}.")
    if cfg.steps > cfg.env.episode_length:
        raise ValueError(
            f"--steps={cfg.steps} is longer than an episode (--env.episode_length={cfg.env.episode_length})."
        )
    if cfg.max_object_error_cm < 0:
        raise ValueError(
            f"--max_object_error_cm must be >= 0 (0: only report), got {cfg.max_object_error_cm}."
        )
    record = Path(cfg.output_dir) / RECORD_FILE
    if record.exists():
        raise FileExistsError(f"{record} exists: pass another --output_dir (results are never overwritten).")
    check_policy_matches_env(cfg.policy, cfg.env)


def scene_errors(
    reader: BeliefReader,
    env: IvmcFetchEnv,
    expert: WaypointExpert,
    scene_seed: int,
    steps: int,
    driver: Literal["watching_expert", "acting"],
) -> dict[str, list[float]]:
    """Per-step distance (m) between the believed and the true grip and object positions on one scene, the
    expert (`driver="watching_expert"`) or the policy itself (`"acting"`) choosing the actions. Each
    estimate is compared with the state the observation it came from was rendered in."""
    observation, _ = env.reset(seed=scene_seed)
    reader.reset()
    expert.reset()
    acting = driver == "acting"
    torch.manual_seed(scene_seed)  # a bvmc's Monte Carlo masks: the same per scene, whatever ran before
    errors: dict[str, list[float]] = {"object": [], "grip": []}
    for _ in range(steps):
        step = reader.step(observation, with_action=acting)
        errors["object"].append(
            float(np.linalg.norm(np.subtract(step.beliefs["object"], env.object_position)))
        )
        errors["grip"].append(float(np.linalg.norm(np.subtract(step.beliefs["grip"], env.grip_position))))
        action = step.action.numpy() if acting else expert.act()
        observation, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    return errors


def summarise(per_scene: list[dict]) -> dict:
    """Median over scenes of each scene's median error, in cm, and the scenes' own values."""
    out = {}
    for part in ("object", "grip"):
        medians = [100 * statistics.median(errors[part]) for errors in per_scene]
        out[f"{part}_cm"] = round(statistics.median(medians), 3)
        out[f"per_scene_{part}_cm"] = [round(m, 3) for m in medians]
    return out


def check_perception(cfg: PerceptionCheckConfig) -> dict:
    """Measure the object and grip estimates of `cfg.policy` on the scenes; returns the record."""
    check_inputs(cfg)
    reader = BeliefReader(load_policy(cfg))
    seeds = [(cfg.seed or 0) + i for i in range(cfg.n_scenes)]
    env = make_task_env_from_config(cfg.env)
    try:
        expert = make_expert(env)
        measured = {
            driver: summarise([scene_errors(reader, env, expert, s, cfg.steps, driver) for s in seeds])
            for driver in DRIVERS
        }
    finally:
        env.close()
    limit = cfg.max_object_error_cm
    return {
        "policy_path": str(cfg.policy.pretrained_path),
        "policy_type": cfg.policy.type,
        "task": cfg.env.task,
        "split": cfg.env.split,
        "scene_seeds": seeds,
        "steps": cfg.steps,
        **measured,
        "max_object_error_cm": limit,
        # None without a limit: nothing was judged.
        "passed": None if limit == 0 else measured["acting"]["object_cm"] <= limit,
    }


def failure_message(record: dict, path: Path) -> str:
    """What went wrong, where the measurements are, and what to do."""
    acting = record["acting"]["object_cm"]
    scenes = f"{len(record['scene_seeds'])} {record['split']} scenes"
    return (
        f"error: the {record['policy_type']} at {record['policy_path']} did not learn where the object is: "
        f"acting on {scenes}, its estimate of the object's position is off by a median {acting:.1f} cm "
        f"over the first {record['steps']} steps (limit {record['max_object_error_cm']:g} cm; on "
        f"pick_place, policies that learned it measured {LEARNED_CM} cm, docs/archive/RESULTS_superseded.md; "
        f"details: {path}). "
        "Rows evaluated from it would say little about recovery. Train it again from another seed or for "
        "longer (lerobot-ivmc-pipeline: --train.seed=..., --train.steps=...), or go on with it by lifting "
        "the limit (0 only reports; --perception.max_object_error_cm=0 in the pipeline)."
    )
