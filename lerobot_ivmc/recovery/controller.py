"""Algorithm 1 as a LeRobot policy: Bayesian VMC that detects trouble from its uncertainty and recovers.

LeRobot's `rollout` calls `select_action` once per step on a vector env, so the controller is itself a
policy: its `select_action` returns, per rollout of the batch, either the Monte Carlo mean action of the
wrapped `BVMCPolicy` or the next step of a recovery manoeuvre, and it keeps Algorithm 1's state (window,
backoff, FIFO, manoeuvre) per rollout. LeRobot's `eval_policy` runs it unchanged, videos included. It also
records what `rollout` does not return: per-step uncertainty, window sum and phase, and recovery events.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import torch
from lerobot.utils.constants import OBS_ENV_STATE, OBS_STATE
from torch import Tensor

from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.envs.task_traits import TaskTraits
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.config import AUTO, RecoveryConfig
from lerobot_ivmc.recovery.grasp_miss import GraspMissAlarm
from lerobot_ivmc.recovery.manoeuvres import FifoEntry, Manoeuvre, MemoryChange
from lerobot_ivmc.recovery.rollout_wrapper import BVMCRolloutWrapper
from lerobot_ivmc.recovery.strategies import make_strategy
from lerobot_ivmc.recovery.trigger import RecoveryTrigger


@dataclass
class BatchTrace:
    """What the controller saw in one `rollout` (one batch of episodes), step by step.

    Attributes:
        uncertainty: per step, (B,) uncertainty of the Monte Carlo pass.
        window_sum: per step, (B,) what the trigger compared with C (after this step's value): the
            sliding-window sum, or its time-conditioned score.
        phase: per step, (B,) manoeuvre phase (`manoeuvres.PHASE_NAMES`).
        events: per rollout, the recoveries it started: step, mode and the window sum that fired.
    """

    uncertainty: list[np.ndarray] = field(default_factory=list)
    window_sum: list[np.ndarray] = field(default_factory=list)
    phase: list[np.ndarray] = field(default_factory=list)
    events: list[list[dict]] = field(default_factory=list)

    def episode(self, row: int, length: int) -> dict:
        """The first `length` steps of rollout `row`: arrays and its recovery events."""
        return {
            "uncertainty": np.stack(self.uncertainty)[:length, row],
            "window_sum": np.stack(self.window_sum)[:length, row],
            "phase": np.stack(self.phase)[:length, row].astype(np.int8),
            "events": [event for event in self.events[row] if event["step"] < length],
        }


class StepObserver(Protocol):
    """Sees what the controller sees (e.g. `evaluation.recovery_videos.RecoveryVideoStore`)."""

    def observe(self, batch: dict[str, Tensor]) -> None:
        """Called with each step's observation batch, before the controller acts on it."""

    def end_batch(self, batch_index: int, trace: BatchTrace) -> None:
        """Called once a batch of episodes is over, with its trace (`traces[batch_index]`)."""


# The purposes of a rollout's random streams (`IntrospectiveController._stream`).
DRAWS, MASKS = 0, 1


def memory_row(memory: tuple[Tensor, ...], row: int) -> tuple[Tensor, ...]:
    """One rollout's part of a batched policy memory (copies)."""
    return tuple(t[row].clone() for t in memory)


def write_memory_row(memory: tuple[Tensor, ...], row: int, values: tuple[Tensor, ...]) -> None:
    """Overwrite one rollout's part of a batched policy memory in place."""
    for tensor, value in zip(memory, values, strict=True):
        tensor[row] = value


class IntrospectiveController(BVMCRolloutWrapper):
    """Bayesian VMC with Algorithm 1's failure recovery.

    Args:
        policy: the Bayesian VMC (with a foresight head for `min_unc`).
        recovery: the recovery settings; `mode="none"` only records the uncertainty.
        threshold: C (required unless mode is "none").
        window: the sliding window's length.
        env_state_stats: (mean, std) of `observation.environment_state`, to read the grip point's position
            from the normalised observation (where `embodiment` says).
        seed: seeds the random draws of rand and init, and min_unc's candidate noise (each rollout its own
            streams, `draws`), and with `recovery.random_streams="episode"` each episode's Monte Carlo
            masks.
        observers: shown every step's observation batch and every finished batch's trace.
        state_stats: (mean, std) of `observation.state`, to read the finger joints (where `embodiment`
            says); required by `anchor`, which decides by them whether the robot holds the object.
        embodiment: the robot: where its grip point and fingers are, its action scale and gripper commands.
        task_traits: what recovery may know of the task (`envs/task_traits.py`; anchor reads it), None
            where nothing is known.
        baseline: (T,) the per-step baseline of a time-conditioned threshold (`recovery/time_baseline.py`),
            None for the paper's window sum.
    """

    name = "bvmc_introspective"

    def __init__(
        self,
        policy: BVMCPolicy,
        recovery: RecoveryConfig,
        threshold: float | None,
        window: int,
        env_state_stats: tuple[Tensor, Tensor],
        seed: int = 0,
        observers: tuple[StepObserver, ...] = (),
        state_stats: tuple[Tensor, Tensor] | None = None,
        *,
        embodiment: Embodiment,
        task_traits: TaskTraits | None = None,
        baseline: np.ndarray | None = None,
    ):
        super().__init__(policy)
        self.baseline = baseline
        self.embodiment = embodiment
        self.task_traits = task_traits
        if recovery.mode != "none" and threshold is None:
            raise ValueError(f"Recovery mode {recovery.mode!r} needs a threshold.")
        self.strategy = make_strategy(recovery)
        self.strategy.check(policy, state_stats)
        if recovery.deadline == AUTO:
            raise ValueError(
                "Resolve --recovery.deadline=auto from the threshold record first (`resolve_deadline`)."
            )
        if recovery.grasp_miss and state_stats is None:
            raise ValueError("--recovery.grasp_miss reads the fingers: the policy needs observation.state.")
        self.reads_fingers = self.strategy.reads_fingers or recovery.grasp_miss > 0
        self.state_stats = state_stats
        self.recovery = recovery
        # Without recovery the trigger still keeps the window sums for the traces, but never fires.
        self.threshold = np.inf if recovery.mode == "none" or threshold is None else float(threshold)
        self.window = window
        self.env_state_mean, self.env_state_std = env_state_stats
        # Where the environment state keeps the object the auxiliary heads learn (None: no such heads).
        aux = policy.config.aux_indices
        self._object_entries = None if aux is None else list(aux[3:6])
        self.seed = seed
        self._row_draws: dict[int, tuple[np.random.Generator, torch.Generator]] = {}
        self._mask_draws: list[torch.Generator] = []
        self._episodes_begun = 0  # episodes of the batches begun so far
        self.candidate_noise = (
            recovery.candidate_noise
            if recovery.candidate_noise is not None
            else float(getattr(policy.config, "foresight_action_noise", 0.0))
        )
        self.traces: list[BatchTrace] = []
        self.observers = observers
        self._batch_size: int | None = None

    def reset(self) -> None:
        """Start a batch of episodes (LeRobot's `rollout` calls this once per batch)."""
        super().reset()
        self.end_batch()

    def end_batch(self) -> None:
        """Close the batch under way, if any, for the observers (`reset` does; call it after the last)."""
        if self._batch_size is not None:
            for observer in self.observers:
                observer.end_batch(len(self.traces) - 1, self.traces[-1])
        self._batch_size = None

    # ---------------------------------------------------------------------------------------- Algorithm 1
    def _start_batch(self, batch_size: int, grip: np.ndarray) -> None:
        self._batch_size = batch_size
        self._first_episode = self._episodes_begun
        self._episodes_begun += batch_size
        self.trigger = RecoveryTrigger(
            batch_size,
            self.threshold,
            self.window,
            self.recovery.initial_interval,
            self.recovery.reset_window_after_recovery,
            self.recovery.backoff_from,
            self.recovery.max_recoveries,
            self.baseline,
            self.recovery.deadline,
        )
        self.grasp_miss = (
            GraspMissAlarm(batch_size, self.recovery.grasp_miss, self.embodiment)
            if self.recovery.grasp_miss
            else None
        )
        self.manoeuvres: list[Manoeuvre | None] = [None] * batch_size
        self.fifos = [deque(maxlen=self.recovery.backtrack_horizon) for _ in range(batch_size)]
        self.strategy.start_batch(batch_size)
        # The last gripper command other than no-op each rollout executed (the fingers' open start: open).
        self.last_gripper = np.full(batch_size, self.embodiment.gripper_open, dtype=np.float64)
        self.initial_grip = grip.copy()
        self.step = 0
        self._row_draws = {}
        self.traces.append(BatchTrace(events=[[] for _ in range(batch_size)]))
        if self.recovery.random_streams == "episode":
            self._mask_draws = [
                torch.Generator().manual_seed(int(self._stream(row, MASKS).generate_state(1)[0]))
                for row in range(batch_size)
            ]

    def _stream(self, row: int, purpose: int) -> np.random.SeedSequence:
        """The seed sequence of rollout `row`'s draws for `purpose` (`DRAWS` or `MASKS`): by (seed, batch,
        row) with `random_streams="batch"`, by (seed, episode index) with "episode"."""
        if self.recovery.random_streams == "episode":
            return np.random.SeedSequence([self.seed, self._first_episode + row], spawn_key=(purpose,))
        return np.random.SeedSequence([self.seed, max(len(self.traces) - 1, 0), row])

    def draws(self, row: int) -> tuple[np.random.Generator, torch.Generator]:
        """Rollout `row`'s own random streams (numpy, torch) for its recovery: what one rollout draws does
        not depend on whether or when the others recover."""
        if row not in self._row_draws:
            stream = self._stream(row, DRAWS)
            torch_draws = torch.Generator().manual_seed(int(stream.generate_state(1)[0]))
            self._row_draws[row] = (np.random.default_rng(stream), torch_draws)
        return self._row_draws[row]

    def _mask_noise(self) -> list[Tensor] | None:
        """This step's uniform noise of the Monte Carlo masks, each dropout layer's (B, S, K_l), every row
        from its episode's own stream; None with `random_streams="batch"` (torch's global generator)."""
        if self.recovery.random_streams != "episode":
            return None
        rows = self._mask_draws
        return self.policy.draw_noise(len(rows), self.policy.config.num_samples, rows)

    def object_positions(self, normalised: Tensor) -> np.ndarray:
        """(B, 3) world positions (metres) of object-space head outputs (B, 3): the object and goal heads,
        normalised as the object's entries of `observation.environment_state`."""
        mean, std = self.env_state_mean[self._object_entries], self.env_state_std[self._object_entries]
        return (normalised.float().cpu() * std + mean).numpy().astype(np.float64)

    def grip_positions(self, batch: dict[str, Tensor]) -> np.ndarray:
        """(B, 3) world positions of the grip point, from the normalised environment state."""
        env_state = batch[OBS_ENV_STATE].float().cpu()
        raw = env_state * self.env_state_std + self.env_state_mean
        return raw[:, list(self.embodiment.grip_state_indices)].numpy().astype(np.float64)

    def finger_joints(self, batch: dict[str, Tensor]) -> np.ndarray:
        """(B, F) finger positions from the normalised proprioception (Fetch: its two joints, metres)."""
        mean, std = self.state_stats
        raw = batch[OBS_STATE].float().cpu() * std + mean
        return raw[:, list(self.embodiment.finger_state_indices)].numpy().astype(np.float64)

    def _apply(self, row: int, change: MemoryChange) -> None:
        memory = self.policy._memory
        if memory is None:
            return
        values = change.memory
        if values is None:  # a fresh start: the memory after reset()
            values = memory_row(self.policy.initial_memory(1), 0)
            self.trigger.restart_clock(row)
        write_memory_row(memory, row, values)

    def _begin_recovery(self, row: int, grip: np.ndarray, window_sum: float, fingers: np.ndarray | None):
        """The strategy's manoeuvre for rollout `row`, its FIFO cleared and the recovery event recorded."""
        manoeuvre, event_extra = self.strategy.begin(self, row, grip, fingers)
        self.fifos[row].clear()
        event = {"step": self.step, "mode": self.recovery.mode, "window_sum": window_sum, **event_extra}
        if self.recovery.deadline or self.recovery.grasp_miss:  # more than one cause can fire
            cause = self.trigger.causes[row]
            event["cause"] = "grasp_miss" if cause == "alarm" else cause
        self.traces[-1].events[row].append(event)
        return manoeuvre

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """(B, 4) actions: the Monte Carlo mean, or a recovery step where one is under way."""
        grip = self.grip_positions(batch)
        if self._batch_size != grip.shape[0]:
            self._start_batch(grip.shape[0], grip)
        for observer in self.observers:
            observer.observe(batch)
        fingers = self.finger_joints(batch) if self.reads_fingers else None
        self._advance_manoeuvres(grip, fingers)
        # The live memory, not a copy: `sample` replaces it with new tensors, and `memory_row` copies rows.
        memory_before = self.policy._memory if self.strategy.keeps_fifo else None
        prediction = self.policy.sample(batch, noise=self._mask_noise())
        uncertainty = prediction.uncertainty.float().cpu().numpy()
        normal = np.array([m is None for m in self.manoeuvres])
        if self.strategy.keeps_fifo:
            self._keep_fifo(memory_before, uncertainty, normal, grip)
        self.strategy.observe(self, prediction, uncertainty, normal)
        missed = (
            None if self.grasp_miss is None else self.grasp_miss.update(fingers, self.last_gripper, normal)
        )
        fire = self.trigger.update(uncertainty, normal, missed)
        if self.grasp_miss is not None:
            self.grasp_miss.clear(np.flatnonzero(fire))
        window_sum = self.trigger.decision_sums
        actions = prediction.mean_action.clone()
        self.strategy.normal_actions(self, prediction, actions, normal)
        phases = np.zeros(grip.shape[0], dtype=np.int8)
        for row in range(grip.shape[0]):
            if fire[row]:
                self.manoeuvres[row] = self._begin_recovery(row, grip[row], float(window_sum[row]), fingers)
            manoeuvre = self.manoeuvres[row]
            if manoeuvre is not None:
                phases[row] = manoeuvre.phase
                action = manoeuvre.act(
                    grip[row], lambda row=row: self.strategy.policy_action(self, prediction, row)
                )
                actions[row] = torch.as_tensor(action, dtype=actions.dtype, device=actions.device)
        self._resolve_gripper(actions)
        self._record(uncertainty, window_sum, phases)
        return actions

    def _advance_manoeuvres(self, grip: np.ndarray, fingers: np.ndarray | None) -> None:
        """Advance every manoeuvre under way (memory changes applied); a finished one is followed by what its
        strategy says (or the policy)."""
        for row, manoeuvre in enumerate(self.manoeuvres):
            if manoeuvre is None:
                continue
            change = manoeuvre.advance(grip[row])
            if change is not None:
                self._apply(row, change)
            if manoeuvre.finished:
                self.manoeuvres[row] = self.strategy.follow(self, row, manoeuvre, grip[row], fingers)

    def _keep_fifo(
        self, memory_before: tuple[Tensor, ...] | None, uncertainty: np.ndarray, normal: np.ndarray, grip
    ) -> None:
        """Add this step of every rollout in normal operation to its FIFO (min_unc's back-track targets)."""
        if memory_before is None:
            memory_before = self.policy.initial_memory(len(uncertainty))
        for row in np.flatnonzero(normal):
            entry = FifoEntry(float(uncertainty[row]), memory_row(memory_before, row), grip[row], self.step)
            self.fifos[row].append(entry)

    def _resolve_gripper(self, actions: Tensor) -> None:
        """Give manoeuvre steps that leave the fingers as they are (NaN) the robot's command for that, in
        place, and remember each rollout's last gripper command."""
        held = torch.isnan(actions[:, -1])
        if held.any():
            hold = torch.as_tensor(self.embodiment.hold(self.last_gripper), dtype=actions.dtype)
            actions[:, -1] = torch.where(held, hold.to(actions.device), actions[:, -1])
        self.last_gripper = self.embodiment.remember(self.last_gripper, actions[:, -1].float().cpu().numpy())

    def _record(self, uncertainty: np.ndarray, window_sum: np.ndarray, phases: np.ndarray) -> None:
        trace = self.traces[-1]
        trace.uncertainty.append(uncertainty)
        trace.window_sum.append(window_sum.copy())
        trace.phase.append(phases)
        self.step += 1
