"""One episode step by step, the world next to what the policy believes (the library of
`lerobot-ivmc-inspect`, `scripts/lerobot_ivmc_inspect.py`): per step the true grip, object and target
positions, the grasp, the executed action, the uncertainty and the network's own position estimates."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from lerobot.configs.eval import EvalPipelineConfig

from lerobot_ivmc.envs import make_task_env_from_config
from lerobot_ivmc.evaluation.beliefs import BeliefReader, check_network_request
from lerobot_ivmc.evaluation.compatibility import check_policy_matches_env
from lerobot_ivmc.evaluation.loading import load_policy

AXES = "xyz"


@dataclass
class InspectConfig(EvalPipelineConfig):
    """`lerobot-eval`'s policy, env and output folder, plus the scene and how often to print.

    The scene is exactly the eval episode's; the run is not: the policy acts alone (one env, no recovery)
    and `--seed` seeds its own Monte Carlo masks, so a bvmc episode can end otherwise than in the eval.

    Args:
        episode_seed: the scene's reset seed (`lerobot-ivmc-eval --seed=s` runs seeds s, s + 1, ...; its
            `eval_info.json` lists each episode's seed).
        print_every: print a line every this many steps (0: none).
    """

    episode_seed: int = 0
    print_every: int = 10


def check_inputs(cfg: InspectConfig) -> None:
    check_network_request(cfg, "lerobot-ivmc-inspect", any_plugin_env=True)
    if cfg.print_every < 0:
        raise ValueError(f"--print_every must be >= 0, got {cfg.print_every}.")
    existing = output_paths(cfg)[0]
    if existing.exists():
        raise FileExistsError(
            f"{existing} exists: pass another --output_dir (results are never overwritten)."
        )
    check_policy_matches_env(cfg.policy, cfg.env)


def output_paths(cfg: InspectConfig) -> tuple[Path, Path]:
    """The episode's JSON record and plot."""
    stem = Path(cfg.output_dir) / f"inspect_seed{cfg.episode_seed}"
    return stem.with_suffix(".json"), stem.with_suffix(".png")


@torch.no_grad()
def inspect_episode(cfg: InspectConfig) -> dict:
    """Run the episode and return its per-step record (lists, one entry per step) and final milestones."""
    check_inputs(cfg)
    reader = BeliefReader(load_policy(cfg))
    env = make_task_env_from_config(cfg.env)
    try:
        torch.manual_seed(cfg.seed or 0)  # the Monte Carlo masks
        observation, _ = env.reset(seed=cfg.episode_seed)
        reader.reset()
        keys = ["grip", "object", "target", "believed_grip", "believed_object", "action", "grasped"]
        record: dict[str, list] = {k: [] for k in keys + (["believed_goal"] if reader.with_goal else [])}
        record["uncertainty"] = []
        info: dict = {}
        for step in range(cfg.env.episode_length):
            policy_step = reader.step(observation)
            record["uncertainty"].append(policy_step.uncertainty)
            for name, position in policy_step.beliefs.items():
                record[f"believed_{name}"].append(position)
            record["grip"].append(env.grip_position.tolist())
            record["object"].append(env.object_position.tolist())
            record["target"].append(env.target_position.tolist())
            grasped = env.is_grasped()
            record["grasped"].append(None if grasped is None else bool(grasped))
            record["action"].append(policy_step.action.tolist())
            if cfg.print_every and step % cfg.print_every == 0:
                print(format_step(step, record))
            observation, _, terminated, _, info = env.step(policy_step.action.numpy())
            if terminated:
                break
    finally:
        env.close()
    return {
        "task": cfg.env.task,
        "split": cfg.env.split,
        "episode_seed": cfg.episode_seed,
        "policy_path": str(cfg.policy.pretrained_path),
        "steps": len(record["grip"]),
        "milestones": info.get("subtasks", {}),
        "success": bool(info.get("is_success", False)),
        "per_step": record,
    }


def format_step(step: int, record: dict) -> str:
    """One printed line: true and believed positions (cm are enough to see a drift) and the action."""

    def fmt(values: list[float]) -> str:
        return "(" + ", ".join(f"{v:.3f}" for v in values) + ")"

    line = (
        f"step {step:3d} grip {fmt(record['grip'][-1])} object {fmt(record['object'][-1])} "
        f"believed object {fmt(record['believed_object'][-1])}"
    )
    if "believed_goal" in record:
        line += f" goal {fmt(record['target'][-1])} believed {fmt(record['believed_goal'][-1])}"
    grasped = record["grasped"][-1]
    line += f" grasped {'-' if grasped is None else int(grasped)} action {fmt(record['action'][-1])}"
    if record["uncertainty"][-1] is not None:
        line += f" u {record['uncertainty'][-1]:.3f}"
    return line


def plot_episode(result: dict, path: Path) -> None:
    """Per axis: true grip / object / target against the network's beliefs; below, the uncertainty."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    record = result["per_step"]
    has_u = record["uncertainty"] and record["uncertainty"][0] is not None
    fig, axes = plt.subplots(4 if has_u else 3, 1, figsize=(8, 9), sharex=True)
    steps = np.arange(result["steps"])
    series = [
        ("grip", "tab:blue", "-"),
        ("believed_grip", "tab:blue", ":"),
        ("object", "tab:red", "-"),
        ("believed_object", "tab:red", ":"),
        ("target", "tab:green", "-"),
        ("believed_goal", "tab:green", ":"),
    ]
    for axis, ax in enumerate(axes[:3]):
        for key, color, style in series:
            if key in record:
                ax.plot(steps, np.asarray(record[key])[:, axis], color=color, linestyle=style, label=key)
        ax.set_ylabel(f"{AXES[axis]} [m]")
    axes[0].legend(fontsize=7, ncol=3)
    if has_u:
        axes[3].plot(steps, record["uncertainty"], color="black")
        axes[3].set_ylabel("uncertainty")
    axes[-1].set_xlabel("step")
    milestones = ", ".join(f"{k} {'yes' if v else 'no'}" for k, v in result["milestones"].items())
    fig.suptitle(f"{result['task']} {result['split']} scene {result['episode_seed']}: {milestones}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
