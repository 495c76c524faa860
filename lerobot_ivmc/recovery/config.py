"""Settings of the recovery loop (Algorithm 1) and the choice of strategy, with each strategy's own settings
(`strategy_settings.py`) nested in them."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from lerobot_ivmc.envs.task_traits import TaskTraits
from lerobot_ivmc.recovery.strategy_settings import (
    STRATEGY_SETTINGS,
    AnchorSettings,
    MinUncSettings,
    ReachSettings,
    RetrySettings,
    check_choice,
)

# none: Bayesian VMC without recovery; min_unc: the paper's back-track and minimum-uncertainty recovery;
# rand and init: the paper's baselines ("Baselines for Visuomotor Control Recovery"); beyond the paper, anchor
# (a planner for the Fetch tasks on the policy's beliefs), retry and reach (they know no task).
RECOVERY_MODES = ("none", "rand", "init", "min_unc", "anchor", "retry", "reach")
# The recovery modes that use no task-specific code: only the robot's embodiment, the policy and its heads.
TASK_FREE_MODES = ("rand", "init", "min_unc", "retry", "reach")
RANDOM_STREAMS = ("batch", "episode")
# `--recovery.deadline=auto`: the deadline the checkpoint's threshold record holds.
AUTO = "auto"
BACKOFF_FROM = ("trigger", "resume")


@dataclass
class RecoveryConfig:
    """How a Bayesian VMC rollout detects trouble and recovers (`--recovery.<field>=` on the eval CLI).

    Args:
        mode: the recovery strategy (`recovery/strategies/`): "none", the paper's "rand", "init" and
            "min_unc", and beyond the paper "anchor" (a planner for the Fetch tasks on the policy's
            beliefs), "retry" and "reach" (they know no task: docs/recovery.md).
        threshold: C, the window-sum threshold. None: read from the checkpoint's `recovery_threshold.json`
            (written by `lerobot-ivmc-threshold`); a value given here wins.
        window: steps in the sliding window of uncertainties (the paper: 20, "best avoids noisy peaks").
            None: the window the threshold was picked with (else 20). A threshold is only meaningful for
            the window it was picked with, so another value is refused.
        initial_interval: T_recovery at the start of an episode, in steps; doubled at every recovery
            (binary exponential backoff). The paper leaves it open; 20 = one window, so no recovery fires
            before a full window of evidence, and a second one needs at least 40 more steps.
        backoff_from: where T_recovery's steps are counted from: "trigger" (the last recovery's first step,
            the paper's reading) or "resume" (the policy's resumption after the last recovery: only steps
            in normal operation count, so a long manoeuvre does not use up the backoff).
        max_recoveries: the most recoveries an episode may fire; 0: no limit (the paper's). With 1, a rollout
            that recovered once goes on with the policy however uncertain it becomes (a second retry throws
            away the first one's progress).
        deadline: a recovery also fires when a rollout has acted this many steps since its memory was last
            fresh (the trigger's clock: the episode's step before any recovery) without succeeding, whatever
            its uncertainty: a timeout, set a little beyond the longest successful validation episode
            (`lerobot-ivmc-threshold` prints it). "auto": the checkpoint's threshold record's (the longest
            successful validation episode + 1). 0: no deadline (the paper's trigger).
        grasp_miss: a recovery also fires when the policy has kept the gripper commanded closed this many
            consecutive steps while the fingers read closed on nothing (the embodiment's held gap): a missed
            or dropped grasp, seen by proprioception however sure the policy is (`recovery/grasp_miss.py`).
            0: off.
        reset_window_after_recovery: clear the window sum when a recovery starts and add no uncertainty
            during it, so the next trigger is decided on steps after the recovery only. The paper is
            silent; without it the high uncertainties that fired the trigger keep the sum above C.
        recovery_steps: the paper's maximum of 25 recovery steps: min_unc's steps of following the
            minimum foreseen uncertainty (after the back-track), rand's random moves, init's move budget.
        backtrack_horizon: size of min_unc's FIFO of (uncertainty, memory, end-effector position, step),
            the steps it may back-track over (the paper: 20); also the most steps a back-track may take.
        backtrack_tolerance: the back-track ends when the grip point is this close (metres) to the point of
            minimum uncertainty (or after `backtrack_horizon` steps).
        rand_step_scale: rand's moves are uniform in [-scale, scale] action units per axis (1 unit = 5 cm).
            The paper gives no size; 0.5 (up to 2.5 cm a step, about 7 cm of drift over 25 steps) leaves
            the scene in view and the object within reach.
        init_sphere_radius: init's target is uniform in a ball of this radius (metres) around the grip
            point's position at the start of the episode, the arm's initial pose above the table. The paper
            says only "a sphere above the table".
        move_tolerance: init's move ends when the grip point is this close (metres) to its target.
        candidate_noise: min_unc's candidates are the S Monte Carlo samples with N(0, noise^2) added to
            their end-effector moves (action units). None: the noise the checkpoint's foresight head was
            distilled with (`--foresight.action_noise`; 0, the paper's plain samples, for older heads), so
            the head ranks the kind of actions it learned from.
        max_videos: at most this many videos of episodes with a recovery, the uncertainty trace drawn under
            the frames (frames are rendered for every episode until they are found; 0 disables).
        random_streams: where a rollout's random draws come from (its Monte Carlo dropout masks, and rand's,
            init's and min_unc's draws). "batch" (the studies' so far): the masks of every rollout of a batch
            from torch's global generator, so an episode's samples depend on the batch size and, after the
            first batch, on how many steps the earlier batches took (which recovery changes); the other
            draws per (seed, batch, row). "episode": every episode its own streams, seeded by (seed,
            episode index): the same episode acts the same whatever the batch size, and a recovery row
            acts exactly as the row without recovery on the same scenes until its own first trigger, so
            the rescued / lost counts hold nothing but the recovery.
        min_unc, retry, anchor, reach: each strategy's own settings (`strategy_settings.py`), as
            `--recovery.<mode>.<name>=`; refused where `mode` is another.
    """

    mode: str = "none"
    threshold: float | None = None
    window: int | None = None
    initial_interval: int = 20
    backoff_from: str = "trigger"
    max_recoveries: int = 0
    deadline: int | str = 0
    grasp_miss: int = 0
    reset_window_after_recovery: bool = True
    recovery_steps: int = 25
    backtrack_horizon: int = 20
    backtrack_tolerance: float = 0.01
    rand_step_scale: float = 0.5
    init_sphere_radius: float = 0.1
    move_tolerance: float = 0.01
    candidate_noise: float | None = None
    max_videos: int = 4
    random_streams: str = "batch"
    min_unc: MinUncSettings = field(default_factory=MinUncSettings)
    retry: RetrySettings = field(default_factory=RetrySettings)
    anchor: AnchorSettings = field(default_factory=AnchorSettings)
    reach: ReachSettings = field(default_factory=ReachSettings)

    def for_task_traits(self, traits: TaskTraits) -> RecoveryConfig:
        """These settings with anchor's unset task-dependent ones taken from a task's traits
        (`AnchorSettings.for_traits`; the settings themselves for another mode)."""
        return replace(self, anchor=self.anchor.for_traits(traits)) if self.mode == "anchor" else self

    def for_task(self, *args, **kwargs) -> RecoveryConfig:
        """`for_task_traits` with the traits given one by one (`AnchorSettings.for_task`)."""
        return replace(self, anchor=self.anchor.for_task(*args, **kwargs)) if self.mode == "anchor" else self

    def __post_init__(self) -> None:
        check_choice("mode", self.mode, RECOVERY_MODES)
        check_choice("random_streams", self.random_streams, RANDOM_STREAMS)
        check_choice("backoff_from", self.backoff_from, BACKOFF_FROM)
        if self.threshold is not None and not math.isfinite(self.threshold):
            raise ValueError(
                f"--recovery.threshold must be a finite number, got {self.threshold}: a NaN threshold never "
                "fires, so recovery would silently be off."
            )
        if self.window is not None and self.window < 1:
            raise ValueError(f"--recovery.window must be >= 1 step, got {self.window}.")
        if isinstance(self.deadline, str) and self.deadline != AUTO:
            raise ValueError(
                f"--recovery.deadline must be a number of steps or {AUTO!r}, got {self.deadline!r}."
            )
        for name in ("deadline", "grasp_miss"):
            if getattr(self, name) and self.mode == "none":
                raise ValueError(
                    f"--recovery.{name} fires a recovery; with --recovery.mode=none there is none to fire: "
                    "drop it or choose a mode."
                )
        counts = ["initial_interval", "max_videos", "max_recoveries", "grasp_miss"]
        if self.deadline != AUTO:  # "auto" is resolved from the threshold record later
            counts.append("deadline")
        for name in counts:
            if getattr(self, name) < 0:
                raise ValueError(f"--recovery.{name} must be >= 0, got {getattr(self, name)}.")
        for name in ("backtrack_horizon", "recovery_steps"):
            if getattr(self, name) < 1:
                raise ValueError(f"--recovery.{name} must be >= 1, got {getattr(self, name)}.")
        for name in ("backtrack_tolerance", "rand_step_scale", "init_sphere_radius", "move_tolerance"):
            if getattr(self, name) <= 0:
                raise ValueError(f"--recovery.{name} must be positive, got {getattr(self, name)}.")
        if self.rand_step_scale > 1:
            raise ValueError(
                f"--recovery.rand_step_scale is in action units, at most 1; got {self.rand_step_scale}."
            )
        if self.candidate_noise is not None and self.mode != "min_unc":
            raise ValueError(
                f"--recovery.candidate_noise widens min_unc's candidates; it has no effect with "
                f"--recovery.mode={self.mode}: drop it or use --recovery.mode=min_unc."
            )
        if self.candidate_noise is not None and not 0.0 <= self.candidate_noise <= 1.0:
            raise ValueError(
                f"--recovery.candidate_noise is a standard deviation in action units, in [0, 1]; got "
                f"{self.candidate_noise}."
            )
        for mode, settings_class in STRATEGY_SETTINGS.items():
            if mode != self.mode and getattr(self, mode) != settings_class():
                raise ValueError(
                    f"--recovery.{mode}.* set the {mode} mode; they have no effect with "
                    f"--recovery.mode={self.mode}: drop them or use --recovery.mode={mode}."
                )
