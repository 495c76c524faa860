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
from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.recovery.anchor import (
    PUSH_LEGS,
    BeliefAnchor,
    LookFromStart,
    carry_to_goal,
    is_holding,
    on_goal,
    push_to_goal,
    regrasp,
)
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

# The object's and the goal's parts of the frame position head's outputs (EE 0:3, object 3:6, goal 6:9).
OBJECT_POSITION, GOAL_POSITION = slice(3, 6), slice(6, 9)


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
            streams, `_draws`), and with `recovery.random_streams="episode"` each episode's Monte Carlo
            masks.
        observers: shown every step's observation batch and every finished batch's trace.
        state_stats: (mean, std) of `observation.state`, to read the finger joints (where `embodiment`
            says); required by `anchor`, which decides by them whether the robot holds the object.
        embodiment: the robot: where its grip point and fingers are, its action scale and gripper commands.
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
        embodiment: Embodiment = FETCH,
    ):
        super().__init__(policy)
        self.embodiment = embodiment
        # Anchor's task-dependent settings left unset (`RecoveryConfig.for_task` fills them from the task):
        # those of a task that picks its object up and lets it go at the goal, as pick_place, acting at the
        # object's believed height.
        recovery = recovery.for_task(object_picked=True, object_held_at_end=False)
        if recovery.mode != "none" and threshold is None:
            raise ValueError(f"Recovery mode {recovery.mode!r} needs a threshold.")
        if recovery.mode == "min_unc":
            policy.require_foresight()
        if recovery.mode == "anchor" and not getattr(policy.config, "goal_head", False):
            raise ValueError(
                "--recovery.mode=anchor reads the goal the policy believes: it needs a policy trained with "
                "--policy.goal_head=true (the lite preset's); use another --recovery.mode for this one."
            )
        on_frame = [name for name in ("anchor_object", "anchor_goal") if getattr(recovery, name) == "frame"]
        if on_frame and not getattr(policy.config, "frame_position_head", False):
            settings = " and ".join(f"--recovery.{name}=frame" for name in on_frame)
            fix = " ".join(f"--recovery.{name}=memory" for name in on_frame)
            raise ValueError(
                f"{settings} {'read' if len(on_frame) > 1 else 'reads'} the policy's frame position head: it "
                "needs a policy trained with "
                f"--policy.frame_position_head=true (the lite preset's); pass {fix} for this one."
            )
        if recovery.mode == "anchor" and state_stats is None:
            raise ValueError(
                "--recovery.mode=anchor needs the statistics of observation.state (state_stats)."
            )
        self.state_stats = state_stats
        self.recovery = recovery
        # Without recovery the trigger still keeps the window sums for the traces, but never fires.
        self.threshold = np.inf if recovery.mode == "none" or threshold is None else float(threshold)
        self.window = window
        self.env_state_mean, self.env_state_std = env_state_stats
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
        )
        self.manoeuvres: list[Manoeuvre | None] = [None] * batch_size
        self.fifos = [deque(maxlen=self.recovery.backtrack_horizon) for _ in range(batch_size)]
        self.anchors = [BeliefAnchor(self.recovery.anchor_goal_steps) for _ in range(batch_size)]
        self.object_beliefs = np.zeros((batch_size, 3))  # the last step's believed object positions
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

    def _draws(self, row: int) -> tuple[np.random.Generator, torch.Generator]:
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

    def _update_beliefs(self, prediction: MCPrediction, uncertainty: np.ndarray, normal: np.ndarray) -> None:
        """Read the believed object and goal positions (the net's deterministic heads, or the frame position
        head's reading of this frame, metres); add the goals of rollouts in normal operation to their
        anchors."""
        outputs = self.policy.net.decode(prediction.embedding, stochastic=False, with_goal=True)
        mean, std = self.env_state_mean[3:], self.env_state_std[3:]  # the object's part of the env state
        believed = outputs[3]
        if self.recovery.anchor_object == "frame":  # this frame's reading, without the memory
            believed = self.policy.frame_positions[:, OBJECT_POSITION]
        self.object_beliefs = (believed.float().cpu() * std + mean).numpy().astype(np.float64)
        goals = outputs[4]
        if self.recovery.anchor_goal == "frame":  # each frame's reading, averaged by the anchor
            goals = self.policy.frame_positions[:, GOAL_POSITION]
        goals = (goals.float().cpu() * std + mean).numpy().astype(np.float64)
        for row in np.flatnonzero(normal):
            self.anchors[row].update(float(uncertainty[row]), goals[row])

    def _holding(self, row: int, fingers: np.ndarray) -> bool:
        """Whether rollout `row` holds the object: it last commanded "close" and the fingers rest apart."""
        return bool(self.last_gripper[row] == self.embodiment.gripper_close) and is_holding(fingers[row])

    def _carry(self, row: int, grip: np.ndarray, grasped_offset: np.ndarray | None = None) -> Manoeuvre:
        """Carry the held object to the anchored goal; `grasped_offset`: where anchor's own re-grasp put the
        object's centre from the grip point, used instead of the believed offset where
        `anchor_held_offset` is "grasped"."""
        cfg = self.recovery
        held_offset = self.object_beliefs[row] - grip
        if grasped_offset is not None and cfg.anchor_held_offset == "grasped":
            held_offset = grasped_offset
        return carry_to_goal(
            grip,
            self.anchors[row].goal,
            held_offset,
            cfg.anchor_steps,
            cfg.move_tolerance,
            cfg.anchor_release,
            cfg.anchor_max_held_offset,
            cfg.anchor_carry_memory == "reset",
        )

    def _push(self, row: int, grip: np.ndarray, legs: int) -> Manoeuvre:
        cfg = self.recovery
        goal = self.anchors[row].goal
        return push_to_goal(
            grip,
            self.object_beliefs[row],
            goal,
            cfg.anchor_steps,
            cfg.move_tolerance,
            legs,
            cfg.anchor_rest_height,
        )

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
        uncertainty of the next step (or, as `min_unc_choice` says, the mean or a random candidate)."""
        choice = self.recovery.min_unc_choice
        if choice == "mean":
            return prediction.mean_action[row].cpu().numpy()
        rng, generator = self._draws(row)
        candidates = widen_candidates(prediction.samples[row : row + 1], self.candidate_noise, generator)
        if choice == "random":
            return candidates[0, int(rng.integers(candidates.shape[1]))].cpu().numpy()
        foreseen = self.policy.foresee(prediction.embedding[row : row + 1], candidates)
        return candidates[0, int(foreseen[0].argmin())].cpu().numpy()

    def _anchor(self, row: int, grip: np.ndarray, fingers: np.ndarray) -> tuple[Manoeuvre, dict]:
        """Anchor's manoeuvre for rollout `row` from what it feels and believes now, and what the recovery
        event reports of it."""
        cfg = self.recovery
        holding = self._holding(row, fingers)
        if holding:
            manoeuvre = self._carry(row, grip)
        elif cfg.anchor_grasp:
            manoeuvre = regrasp(
                grip,
                self.object_beliefs[row],
                cfg.anchor_steps,
                cfg.move_tolerance,
                cfg.anchor_rest_height,
                cfg.anchor_grasp_offset,
            )
        else:
            manoeuvre = self._push(row, grip, PUSH_LEGS)
        return manoeuvre, {"holding": holding, "target": manoeuvre.target.round(4).tolist()}

    def _begin_recovery(
        self, row: int, grip: np.ndarray, window_sum: float, fingers: np.ndarray | None
    ) -> Manoeuvre:
        mode, cfg = self.recovery.mode, self.recovery
        if mode == "anchor" and cfg.anchor_look_steps > 0 and not self._holding(row, fingers):
            gripper = int(self.last_gripper[row])  # anchor runs on the Fetch arm only
            manoeuvre = LookFromStart(
                grip,
                self.initial_grip[row],
                gripper,
                cfg.anchor_look_steps,
                cfg.anchor_steps,
                cfg.move_tolerance,
            )
            event_extra = {"look_steps": cfg.anchor_look_steps}
        elif mode == "anchor":
            manoeuvre, event_extra = self._anchor(row, grip, fingers)
        elif mode == "min_unc":
            manoeuvre = BacktrackThenFollow(
                list(self.fifos[row]),
                cfg.recovery_steps,
                cfg.backtrack_horizon,
                cfg.backtrack_tolerance,
                self.embodiment,
                memory=cfg.min_unc_memory,
            )
            event_extra = {"backtrack_to_step": manoeuvre.target.step}
        elif mode == "rand":
            manoeuvre, event_extra = (
                RandomMoves(cfg.recovery_steps, cfg.rand_step_scale, self._draws(row)[0]),
                {},
            )
        else:
            manoeuvre = MoveToInit(
                self.initial_grip[row],
                cfg.init_sphere_radius,
                cfg.recovery_steps,
                cfg.move_tolerance,
                self._draws(row)[0],
                self.embodiment,
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
        fingers = self.finger_joints(batch) if self.recovery.mode == "anchor" else None
        for row, manoeuvre in enumerate(self.manoeuvres):
            if manoeuvre is not None:
                change = manoeuvre.advance(grip[row])
                if change is not None:
                    self._apply(row, change)
                if manoeuvre.finished:
                    self.manoeuvres[row] = None
                    if manoeuvre.then_anchor:  # the look is over: anchor on what it showed
                        self.manoeuvres[row], event_extra = self._anchor(row, grip[row], fingers)
                        self.traces[-1].events[row][-1].update(event_extra)
                    elif manoeuvre.then_carry and self._holding(row, fingers):
                        # a re-grasp that held
                        self.manoeuvres[row] = self._carry(row, grip[row], manoeuvre.held_offset)
                    elif manoeuvre.then_push and not on_goal(
                        self.object_beliefs[row], self.anchors[row].goal
                    ):
                        self.manoeuvres[row] = self._push(row, grip[row], manoeuvre.then_push)

        keep_fifo = self.recovery.mode == "min_unc"
        # The live memory, not a copy: `sample` replaces it with new tensors, and `memory_row` copies rows.
        memory_before = self.policy._memory if keep_fifo else None
        if keep_fifo and memory_before is None:
            memory_before = self.policy.initial_memory(batch_size)
        prediction = self.policy.sample(batch, noise=self._mask_noise())
        uncertainty = prediction.uncertainty.float().cpu().numpy()
        normal = np.array([m is None for m in self.manoeuvres])
        if keep_fifo:
            for row in np.flatnonzero(normal):
                self.fifos[row].append(
                    FifoEntry(float(uncertainty[row]), memory_row(memory_before, row), grip[row], self.step)
                )
        if self.recovery.mode == "anchor":
            self._update_beliefs(prediction, uncertainty, normal)
        fire = self.trigger.update(uncertainty, normal)
        window_sum = self.trigger.decision_sums

        actions = prediction.mean_action.clone()
        phases = np.zeros(batch_size, dtype=np.int8)
        for row in range(batch_size):
            if fire[row]:
                self.manoeuvres[row] = self._begin_recovery(row, grip[row], float(window_sum[row]), fingers)
            manoeuvre = self.manoeuvres[row]
            if manoeuvre is None:
                phases[row] = NORMAL
                continue
            phases[row] = manoeuvre.phase
            action = manoeuvre.act(grip[row], lambda row=row: self._min_unc_action(prediction, row))
            actions[row] = torch.as_tensor(action, dtype=actions.dtype, device=actions.device)

        held = torch.isnan(actions[:, -1])  # manoeuvres that leave the fingers as they are
        if held.any():
            hold = torch.as_tensor(self.embodiment.hold(self.last_gripper), dtype=actions.dtype)
            actions[:, -1] = torch.where(held, hold.to(actions.device), actions[:, -1])
        self.last_gripper = self.embodiment.remember(self.last_gripper, actions[:, -1].float().cpu().numpy())
        trace = self.traces[-1]
        trace.uncertainty.append(uncertainty)
        trace.window_sum.append(window_sum.copy())
        trace.phase.append(phases)
        self.step += 1
        return actions
