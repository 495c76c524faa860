"""Distillation data for the uncertainty foresight head (the paper's Section "Experiments").

A trained Bayesian VMC is deployed on training scenes; at every step it executes one action drawn from
its Monte Carlo samples (not the mean, so the data covers the spread of actions recovery will rank),
optionally widened by Gaussian noise (`candidates.widen_candidates`), and each step gives a record
(e_t, a_t, uncertainty at t + 1). Episodes end on task success or at 200 steps.

Collection runs LeRobot's own `rollout` one batch of episodes at a time and writes each batch as a shard
(`shard_00000.npz`, ...) atomically, so a killed collection resumes at the first missing shard and never
records an episode twice; `spec.json` refuses a resume with other settings.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from lerobot.scripts.lerobot_eval import rollout
from torch import Tensor
from tqdm import tqdm

from lerobot_ivmc.atomic_files import atomic_write, write_json_atomic
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.candidates import widen_candidates
from lerobot_ivmc.recovery.rollout_wrapper import BVMCRolloutWrapper

SPEC_FILE = "spec.json"


class SampledActionRecorder(BVMCRolloutWrapper):
    """Executes one Monte Carlo sample per step (drawn uniformly among the S, plus `action_noise`) and
    records e_t, a_t, u_t.

    Args:
        policy: the Bayesian VMC.
        seed: seeds the choice of the executed sample and its noise.
        action_noise: standard deviation (action units) of the noise on the sample's end-effector move.
    """

    name = "bvmc_distillation"

    def __init__(self, policy: BVMCPolicy, seed: int, action_noise: float = 0.0):
        super().__init__(policy)
        self.generator = torch.Generator().manual_seed(seed)
        self.action_noise = action_noise
        self.embeddings: list[Tensor] = []
        self.actions: list[Tensor] = []
        self.uncertainties: list[Tensor] = []

    def reset(self) -> None:
        super().reset()
        self.embeddings, self.actions, self.uncertainties = [], [], []

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        prediction = self.policy.sample(batch)
        samples = prediction.samples  # (B, S, 4)
        index = torch.randint(samples.shape[1], (samples.shape[0],), generator=self.generator)
        action = samples[torch.arange(samples.shape[0]), index.to(samples.device)]
        action = widen_candidates(action, self.action_noise, self.generator)
        self.embeddings.append(prediction.embedding.float().cpu())
        self.actions.append(action.float().cpu())
        self.uncertainties.append(prediction.uncertainty.float().cpu())
        return action


def distillation_pairs(
    embeddings: Tensor, actions: Tensor, uncertainties: Tensor, done: Tensor, first_trajectory: int
) -> dict[str, np.ndarray]:
    """Pair each step's (e_t, a_t) with u_{t+1} of the same episode.

    Args:
        embeddings: (T, B, H); actions: (T, B, 4); uncertainties: (T, B): what the recorder saw.
        done: (B, T) LeRobot's cumulative done mask.
        first_trajectory: id of the batch's first episode.

    Returns:
        Arrays over records: embedding, action, uncertainty (u_t), next_uncertainty (u_{t+1}),
        trajectory, step; and per episode: trajectory_length.
    """
    done = done.bool()
    steps = done.shape[1]
    lengths = torch.where(
        done.any(dim=1), done.int().argmax(dim=1) + 1, torch.full_like(done[:, 0], steps, dtype=torch.long)
    )
    parts: dict[str, list] = {
        k: [] for k in ("embedding", "action", "uncertainty", "next_uncertainty", "trajectory", "step")
    }
    for row, length in enumerate(lengths.tolist()):
        n = length - 1  # the last action's next observation is terminal: the policy never saw it
        parts["embedding"].append(embeddings[:n, row].numpy())
        parts["action"].append(actions[:n, row].numpy())
        parts["uncertainty"].append(uncertainties[:n, row].numpy())
        parts["next_uncertainty"].append(uncertainties[1 : n + 1, row].numpy())
        parts["trajectory"].append(np.full(n, first_trajectory + row, dtype=np.int64))
        parts["step"].append(np.arange(n, dtype=np.int64))
    arrays = {k: np.concatenate(v) for k, v in parts.items()}
    arrays["trajectory_length"] = lengths.numpy()
    return arrays


@dataclass
class ShardWriter:
    """Shards of a distillation collection in `root`, written atomically; `spec` guards resumes."""

    root: Path
    spec: dict

    def __post_init__(self) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        spec_path = self.root / SPEC_FILE
        if spec_path.exists():
            stored = json.loads(spec_path.read_text())
            if stored != self.spec:
                keys = sorted(stored.keys() | self.spec.keys())
                diff = {
                    k: (stored.get(k), self.spec.get(k)) for k in keys if stored.get(k) != self.spec.get(k)
                }
                raise ValueError(
                    f"{self.root} holds a distillation collection with other settings (stored, asked): "
                    f"{diff}. "
                    "Rerun with the stored settings to resume it, or choose another --output_dir."
                )
        else:
            write_json_atomic(spec_path, self.spec)

    def path(self, index: int) -> Path:
        return self.root / f"shard_{index:05d}.npz"

    def write(self, index: int, arrays: dict[str, np.ndarray]) -> None:
        atomic_write(self.path(index), lambda file: np.savez(file, **arrays))

    def missing(self, num_shards: int) -> list[int]:
        return [i for i in range(num_shards) if not self.path(i).exists()]


def collect_distillation_data(
    env,
    policy: BVMCPolicy,
    processors: tuple,
    root: Path,
    num_trajectories: int,
    seed: int,
    spec: dict,
    action_noise: float = 0.0,
) -> list[Path]:
    """Collect `num_trajectories` episodes (rounded up to whole batches of the vector env) into shards.

    Batch k runs the scenes of seeds seed + k * B + j, and its Monte Carlo masks and executed samples are
    seeded by (seed, k), so a resumed collection equals an uninterrupted one.

    Args:
        env: the vector env (B sub-envs on training scenes).
        policy: the Bayesian VMC.
        processors: (env_preprocessor, env_postprocessor, preprocessor, postprocessor).
        root: the shard folder.
        num_trajectories: episodes to collect.
        seed: the base seed.
        spec: settings stored with the shards.
        action_noise: noise on the executed samples' end-effector moves (`SampledActionRecorder`).

    Returns:
        The shard paths, in order.
    """
    batch_size = env.num_envs
    num_shards = -(-num_trajectories // batch_size)
    writer = ShardWriter(root, spec)
    todo = writer.missing(num_shards)
    for index in tqdm(
        todo, desc="Distillation episodes (batches)", initial=num_shards - len(todo), total=num_shards
    ):
        batch_seed = int(np.random.SeedSequence([seed, index]).generate_state(1)[0])
        torch.manual_seed(batch_seed)  # the Monte Carlo masks: a resumed batch draws the same ones
        recorder = SampledActionRecorder(policy, seed=batch_seed, action_noise=action_noise)
        seeds = list(range(seed + index * batch_size, seed + (index + 1) * batch_size))
        with torch.no_grad():
            result = rollout(env, recorder, *processors, seeds=seeds)
        arrays = distillation_pairs(
            torch.stack(recorder.embeddings),
            torch.stack(recorder.actions),
            torch.stack(recorder.uncertainties),
            result["done"],
            first_trajectory=index * batch_size,
        )
        arrays["trajectory_success"] = result["success"].any(dim=1).numpy()
        writer.write(index, arrays)
    return [writer.path(i) for i in range(num_shards)]


def load_shards(paths: list[Path]) -> dict[str, np.ndarray]:
    """Concatenate the records of all shards."""
    keys = ("embedding", "action", "uncertainty", "next_uncertainty", "trajectory", "step")
    parts: dict[str, list] = {k: [] for k in keys}
    for path in paths:
        try:
            with np.load(path) as data:
                for k in keys:
                    parts[k].append(data[k])
        except (OSError, ValueError, KeyError) as error:
            raise ValueError(
                f"Distillation shard {path} is damaged ({error}); delete it and rerun to redo it."
            ) from error
    return {k: np.concatenate(v) for k, v in parts.items()}
