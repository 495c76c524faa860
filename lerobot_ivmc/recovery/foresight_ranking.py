"""Does the foresight head rank actions? Measured by trying every candidate action in a copy of the env.

On a sample of states visited by the Bayesian VMC (mean actions, as at test time), the S sampled actions
of the step are each executed from the same saved env state, the policy's Monte Carlo uncertainty of the
resulting observation is measured (from the same memory), and the head's argmin over the candidates is
compared with the measured one. The measured argmin is itself a Monte Carlo estimate: a second,
independent measurement gives the agreement that a perfect head could reach.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy import stats
from tqdm import tqdm

from lerobot_ivmc.envs import MAX_EPISODE_STEPS
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.candidates import widen_candidates


def batch_observations(observations: list[dict]) -> dict:
    """Stack single-env observations into the batched numpy dict a vector env returns."""
    first = observations[0]
    out: dict = {}
    for key, value in first.items():
        if isinstance(value, dict):
            out[key] = {k: np.stack([o[key][k] for o in observations]) for k in value}
        else:
            out[key] = np.stack([o[key] for o in observations])
    return out


def _expand_memory(memory: tuple[torch.Tensor, ...], copies: int) -> tuple[torch.Tensor, ...]:
    return tuple(t.expand(copies, *t.shape[1:]).clone() for t in memory)


@torch.no_grad()
def measure_action_ranking(
    env,
    policy: BVMCPolicy,
    to_policy_batch,
    seeds: list[int],
    num_states: int,
    every: int = 15,
    action_noise: float = 0.0,
    noise_seed: int = 0,
) -> dict[str, float]:
    """Compare the head's ranking of each step's S candidate actions with measured next-step uncertainty.

    Args:
        env: an ivmc task env (unwrapped, with `get_snapshot` / `set_snapshot`).
        policy: the Bayesian VMC with its foresight head.
        to_policy_batch: maps a batched numpy observation to the policy's preprocessed batch.
        seeds: scenes to visit (reset seeds), used in order until `num_states` states are measured.
        num_states: states to measure.
        every: measure every this many steps along each episode (starting at step `every`).
        action_noise: the candidates are the S samples widened by this noise, as min_unc ranks them.
        noise_seed: seeds that noise.

    Returns:
        argmin_match_rate (head's argmin == measured argmin), its chance level 1/S, the measurement's own
        agreement (two independent measurements' argmins), the mean percentile of the head's choice among
        the measured uncertainties (0 = the best candidate, 0.5 = chance), the mean within-state Spearman
        rho, and the mean measured uncertainty of the head's choice, of a random candidate and of the best.
    """
    matches, self_matches, percentiles, rhos = [], [], [], []
    chosen_u, candidate_u, best_u = [], [], []
    num_samples = policy.config.num_samples
    generator = torch.Generator().manual_seed(noise_seed)
    progress = tqdm(total=num_states, desc="Foresight ranking (states)")
    for seed in seeds:
        if len(matches) >= num_states:
            break
        observation, _ = env.reset(seed=seed)
        policy.reset()
        for step in range(MAX_EPISODE_STEPS):
            prediction = policy.sample(to_policy_batch(batch_observations([observation])))
            if step > 0 and step % every == 0:
                memory = policy.get_memory()
                candidates = widen_candidates(prediction.samples, action_noise, generator)  # (1, S, 4)
                foreseen = policy.foresee(prediction.embedding, candidates)[0].cpu().numpy()
                snapshot = env.get_snapshot()
                next_observations = []
                for action in candidates[0].cpu().numpy():
                    env.set_snapshot(snapshot)
                    next_observations.append(env.step(action)[0])
                env.set_snapshot(snapshot)
                batch = to_policy_batch(batch_observations(next_observations))
                measured = []
                for _ in range(2):  # two independent Monte Carlo measurements
                    policy.set_memory(_expand_memory(memory, num_samples))
                    measured.append(policy.sample(batch).uncertainty.float().cpu().numpy())
                policy.set_memory(memory)
                first, second = measured
                choice = int(foreseen.argmin())
                matches.append(choice == int(first.argmin()))
                self_matches.append(int(second.argmin()) == int(first.argmin()))
                percentiles.append(float((first < first[choice]).mean()))
                rho = stats.spearmanr(foreseen, first).statistic
                if np.isfinite(rho):
                    rhos.append(float(rho))
                chosen_u.append(float(first[choice]))
                candidate_u.append(float(first.mean()))
                best_u.append(float(first.min()))
                progress.update()
                if len(matches) >= num_states:
                    break
            observation, _, terminated, truncated, _ = env.step(prediction.mean_action[0].cpu().numpy())
            if terminated or truncated:
                break
    progress.close()
    if not matches:
        raise ValueError("No state was measured: give more seeds or a smaller `every`.")
    return {
        "num_states": len(matches),
        "num_candidates": num_samples,
        "candidate_noise": action_noise,
        "argmin_match_rate": float(np.mean(matches)),
        "chance_match_rate": 1.0 / num_samples,
        "measurement_self_match_rate": float(np.mean(self_matches)),
        "mean_percentile_of_choice": float(np.mean(percentiles)),
        "mean_within_state_spearman_rho": float(np.mean(rhos)) if rhos else float("nan"),
        "measured_u_of_choice": float(np.mean(chosen_u)),
        "measured_u_mean_candidate": float(np.mean(candidate_u)),
        "measured_u_best_candidate": float(np.mean(best_u)),
    }
