"""When to recover: Algorithm 1's test on the sliding-window sum, with exponential backoff."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.recovery.time_baseline import step_scores


class RecoveryTrigger:
    """Algorithm 1, lines 4 to 9, for a batch of rollouts that started together.

    At every step each rollout in normal operation adds its uncertainty to a sliding window; a recovery
    fires when the window sum (over the baseline at this step, where one is given) exceeds C, or the
    rollout's clock reaches the deadline where one is set, or another alarm is raised for it (a missed grasp,
    `recovery/grasp_miss.py`), and more than T_recovery steps have passed since the last recovery (or the
    episode's start). Each firing doubles that rollout's T_recovery.

    Args:
        num_rollouts: B.
        threshold: C.
        window: the sliding window's length in steps.
        initial_interval: T_recovery at the episode's start.
        reset_window_after_recovery: clear a rollout's window when it fires.
        backoff_from: count T_recovery's steps from the last recovery's start ("trigger", the paper's) or
            from the policy's resumption after it ("resume": only steps in normal operation count).
        max_recoveries: the most recoveries a rollout fires in its episode; 0: no limit (the paper's).
        baseline: (T,) the time-conditioned score's per-step baseline (`recovery/time_baseline.py`); None:
            the window sum itself is compared (the paper's). Its step is each rollout's clock: the steps it
            spent in normal operation since its policy's memory was last reset (`restart_clock`), the
            episode's step before any recovery. A recovery that restores or keeps the memory (min_unc,
            anchor's follow) does not set it back, and its own steps do not count.
        deadline: a rollout also fires when its clock reaches this many steps, whatever its score (a
            timeout: a little beyond the longest successful validation episode); 0: no deadline.
    """

    def __init__(
        self,
        num_rollouts: int,
        threshold: float,
        window: int,
        initial_interval: int,
        reset_window_after_recovery: bool = True,
        backoff_from: str = "trigger",
        max_recoveries: int = 0,
        baseline: np.ndarray | None = None,
        deadline: int = 0,
    ):
        self.threshold = threshold
        self.deadline = deadline
        self.window = window
        self.reset_window_after_recovery = reset_window_after_recovery
        self.values = np.zeros((num_rollouts, window))  # circular buffer of the last `window` values
        self.counts = np.zeros(num_rollouts, dtype=np.int64)  # values pushed since the last clear
        self.interval = np.full(num_rollouts, initial_interval, dtype=np.int64)
        self.backoff_from = backoff_from
        self.since_recovery = np.zeros(num_rollouts, dtype=np.int64)  # steps counted since the last recovery
        self.decision_sums = np.zeros(num_rollouts)
        self.max_recoveries = max_recoveries
        self.fired = np.zeros(num_rollouts, dtype=np.int64)  # recoveries fired so far, per rollout
        self.baseline = None if baseline is None else np.asarray(baseline, dtype=np.float64)
        self.clock = np.zeros(num_rollouts, dtype=np.int64)
        # Why each rollout fired at the last update: "score", else "deadline", else "alarm" ("" where none).
        self.causes = np.full(num_rollouts, "", dtype=object)

    @property
    def window_sum(self) -> np.ndarray:
        """(B,) the current sliding-window sums."""
        return self.values.sum(axis=1)

    def update(
        self, uncertainty: np.ndarray, active: np.ndarray, alarm: np.ndarray | None = None
    ) -> np.ndarray:
        """Add this step's uncertainties and decide which rollouts recover now.

        Args:
            uncertainty: (B,) this step's uncertainty.
            active: (B,) bool, rollouts in normal operation (a rollout inside a recovery adds nothing and
                cannot fire).
            alarm: (B,) bool, other reasons to recover now (a missed grasp); None: none.

        Returns:
            (B,) bool: rollouts that start a recovery at this step.
        """
        rows = np.flatnonzero(active)
        self.values[rows, self.counts[rows] % self.window] = uncertainty[rows]
        self.counts[rows] += 1
        # What the test saw (the window may be cleared below): the window sum, or its time-conditioned score.
        self.decision_sums = self.window_sum
        if self.baseline is not None:
            self.decision_sums = step_scores(self.decision_sums, self.clock, self.baseline, self.window)
        self.clock[rows] += 1
        score = self.decision_sums > self.threshold
        late = self.clock >= self.deadline if self.deadline > 0 else np.zeros_like(score)
        other = np.zeros_like(score) if alarm is None else np.asarray(alarm, dtype=bool)
        fire = active & (score | late | other) & (self.since_recovery > self.interval)
        if self.max_recoveries > 0:
            fire &= self.fired < self.max_recoveries
        fired = np.flatnonzero(fire)
        self.causes[:] = ""
        self.causes[fired] = np.where(score[fired], "score", np.where(late[fired], "deadline", "alarm"))
        self.fired[fired] += 1
        self.interval[fired] *= 2
        self.since_recovery[fired] = 0
        # "resume": a step counts once the rollout is back in normal operation (the firing step starts the
        # manoeuvre).
        self.since_recovery += 1 if self.backoff_from == "trigger" else (active & ~fire)
        if self.reset_window_after_recovery:
            self.values[fired] = 0.0
            self.counts[fired] = 0
        return fire

    def restart_clock(self, row: int) -> None:
        """Rollout `row`'s policy starts again from a fresh memory: the baseline's steps count from here."""
        self.clock[row] = 0
