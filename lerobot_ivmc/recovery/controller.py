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
from lerobot.utils.constants import OBS_ENV_STATE
from torch import Tensor

from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.candidates import widen_candidates
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.manoeuvres import (
    NORMAL,
    BacktrackThenFollow,
    FifoEntry,
    Manoeuvre,
    MemoryChange,
    MoveToInit,
    RandomMoves,
)
from lerobot_ivmc.recovery.rollout_wrapper import BVMCRolloutWrapper
from lerobot_ivmc.recovery.trigger import RecoveryTrigger


@dataclass
class BatchTrace:
    """What the controller saw in one `rollout` (one batch of episodes), step by step.

    Attributes:
        uncertainty: per step, (B,) uncertainty of the Monte Carlo pass.
        window_sum: per step, (B,) the trigger's sliding-window sum (after this step's value).
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
            from the normalised observation (the first three entries).
        seed: seeds the random draws of rand and init, and min_unc's candidate noise.
        observers: shown every step's observation batch and every finished batch's trace.
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
    ):
        super().__init__(policy)
        if recovery.mode != "none" and threshold is None:
            raise ValueError(f"Recovery mode {recovery.mode!r} needs a threshold.")
        if recovery.mode == "min_unc":
            policy.require_foresight()
        self.recovery = recovery
        # Without recovery the trigger still keeps the window sums for the traces, but never fires.
        self.threshold = np.inf if recovery.mode == "none" or threshold is None else float(threshold)
        self.window = window
        self.env_state_mean, self.env_state_std = env_state_stats
        self.rng = np.random.default_rng(seed)
        self.generator = torch.Generator().manual_seed(seed)
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
        self.trigger = RecoveryTrigger(
            batch_size,
            self.threshold,
            self.window,
            self.recovery.initial_interval,
            self.recovery.reset_window_after_recovery,
        )
        self.manoeuvres: list[Manoeuvre | None] = [None] * batch_size
        self.fifos = [deque(maxlen=self.recovery.backtrack_horizon) for _ in range(batch_size)]
        self.initial_grip = grip.copy()
        self.step = 0
        self.traces.append(BatchTrace(events=[[] for _ in range(batch_size)]))

    def grip_positions(self, batch: dict[str, Tensor]) -> np.ndarray:
        """(B, 3) world positions of the grip point, from the normalised environment state."""
        env_state = batch[OBS_ENV_STATE].float().cpu()
        raw = env_state * self.env_state_std + self.env_state_mean
        return raw[:, :3].numpy().astype(np.float64)

    def _apply(self, row: int, change: MemoryChange) -> None:
        memory = self.policy._memory
        if memory is None:
            return
        values = change.memory
        if values is None:  # a fresh start: the memory after reset()
            values = memory_row(self.policy.initial_memory(1), 0)
        write_memory_row(memory, row, values)

    def _min_unc_action(self, prediction: MCPrediction, row: int) -> np.ndarray:
        """The candidate action of `row` (a sample, widened by `candidate_noise`) with the lowest foreseen
        uncertainty of the next step."""
        candidates = widen_candidates(prediction.samples[row : row + 1], self.candidate_noise, self.generator)
        foreseen = self.policy.foresee(prediction.embedding[row : row + 1], candidates)
        return candidates[0, int(foreseen[0].argmin())].cpu().numpy()

    def _begin_recovery(self, row: int, grip: np.ndarray, window_sum: float) -> Manoeuvre:
        mode, cfg = self.recovery.mode, self.recovery
        if mode == "min_unc":
            manoeuvre = BacktrackThenFollow(
                list(self.fifos[row]),
                cfg.recovery_steps,
                cfg.backtrack_horizon,
                cfg.backtrack_tolerance,
                reset_memory=cfg.min_unc_memory == "reset",
            )
            event_extra = {"backtrack_to_step": manoeuvre.target.step}
        elif mode == "rand":
            manoeuvre, event_extra = RandomMoves(cfg.recovery_steps, cfg.rand_step_scale, self.rng), {}
        else:
            manoeuvre = MoveToInit(
                self.initial_grip[row],
                cfg.init_sphere_radius,
                cfg.recovery_steps,
                cfg.move_tolerance,
                self.rng,
            )
            event_extra = {"target": manoeuvre.target.round(4).tolist()}
        self.fifos[row].clear()
        self.traces[-1].events[row].append(
            {"step": self.step, "mode": mode, "window_sum": window_sum, **event_extra}
        )
        return manoeuvre

    @torch.no_grad()
    def select_action(self, batch: dict[str, Tensor], **kwargs) -> Tensor:
        """(B, 4) actions: the Monte Carlo mean, or a recovery step where one is under way."""
        grip = self.grip_positions(batch)
        batch_size = grip.shape[0]
        if self._batch_size != batch_size:
            self._start_batch(batch_size, grip)
        for observer in self.observers:
            observer.observe(batch)
        for row, manoeuvre in enumerate(self.manoeuvres):
            if manoeuvre is not None:
                change = manoeuvre.advance(grip[row])
                if change is not None:
                    self._apply(row, change)
                if manoeuvre.finished:
                    self.manoeuvres[row] = None

        keep_fifo = self.recovery.mode == "min_unc"
        # The live memory, not a copy: `sample` replaces it with new tensors, and `memory_row` copies rows.
        memory_before = self.policy._memory if keep_fifo else None
        if keep_fifo and memory_before is None:
            memory_before = self.policy.initial_memory(batch_size)
        prediction = self.policy.sample(batch)
        uncertainty = prediction.uncertainty.float().cpu().numpy()
        normal = np.array([m is None for m in self.manoeuvres])
        if keep_fifo:
            for row in np.flatnonzero(normal):
                self.fifos[row].append(
                    FifoEntry(float(uncertainty[row]), memory_row(memory_before, row), grip[row], self.step)
                )
        fire = self.trigger.update(uncertainty, normal)
        window_sum = self.trigger.decision_sums

        actions = prediction.mean_action.clone()
        phases = np.zeros(batch_size, dtype=np.int8)
        for row in range(batch_size):
            if fire[row]:
                self.manoeuvres[row] = self._begin_recovery(row, grip[row], float(window_sum[row]))
            manoeuvre = self.manoeuvres[row]
            if manoeuvre is None:
                phases[row] = NORMAL
                continue
            phases[row] = manoeuvre.phase
            action = manoeuvre.act(grip[row], lambda row=row: self._min_unc_action(prediction, row))
            actions[row] = torch.as_tensor(action, dtype=actions.dtype, device=actions.device)

        trace = self.traces[-1]
        trace.uncertainty.append(uncertainty)
        trace.window_sum.append(window_sum.copy())
        trace.phase.append(phases)
        self.step += 1
        return actions
