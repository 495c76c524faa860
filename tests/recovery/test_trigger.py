"""Algorithm 1's trigger on scripted uncertainty streams: window sum, threshold, backoff doubling."""

from __future__ import annotations

import numpy as np

from lerobot_ivmc.recovery.trigger import RecoveryTrigger


def run(trigger: RecoveryTrigger, stream: list[float], active: list[bool] | None = None) -> list[int]:
    """Steps at which rollout 0 fires."""
    fired = []
    for t, u in enumerate(stream):
        on = np.array([True if active is None else active[t]])
        if trigger.update(np.array([u]), on)[0]:
            fired.append(t)
    return fired


def test_fires_when_window_sum_exceeds_threshold_after_the_interval() -> None:
    # window 3, C = 2.5, T = 2: the sum first exceeds 2.5 at step 2 (1+1+1 = 3), but 2 - 0 > 2 fails;
    # step 3: sum 3 and 3 > 2 -> fire; window cleared, T doubles to 4.
    trigger = RecoveryTrigger(1, threshold=2.5, window=3, initial_interval=2)
    fired = run(trigger, [1.0] * 12)
    # After step 3 the window refills: sum 3 again at step 6, but 6 - 3 > 4 fails until step 8; T -> 8;
    # then 11 - 8 > 8 fails to the end.
    assert fired == [3, 8]
    assert trigger.interval[0] == 8  # doubled twice: 2 -> 4 -> 8


def test_window_sum_slides_and_low_values_never_fire() -> None:
    trigger = RecoveryTrigger(1, threshold=2.5, window=3, initial_interval=0)
    assert run(trigger, [1.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0]) == []  # no 3 consecutive highs
    np.testing.assert_allclose(trigger.window_sum, [2.0])
    assert run(RecoveryTrigger(1, 2.5, 3, 0), [0.5, 2.0, 0.1]) == [2]  # 2.6 > 2.5


def test_inactive_steps_add_nothing_and_cannot_fire() -> None:
    trigger = RecoveryTrigger(1, threshold=1.5, window=2, initial_interval=0)
    active = [True, False, False, True, True]
    assert run(trigger, [1.0, 5.0, 5.0, 1.0, 0.0], active) == [3]  # the 5s are never counted


def test_window_is_kept_when_reset_is_disabled() -> None:
    trigger = RecoveryTrigger(
        1, threshold=1.5, window=2, initial_interval=0, reset_window_after_recovery=False
    )
    # fires at 1 (sum 2, T -> 0*2 = 0), and again at 2 since the window still holds the high values.
    assert run(trigger, [1.0, 1.0, 1.0]) == [1, 2]


def test_rollouts_of_a_batch_are_independent() -> None:
    trigger = RecoveryTrigger(2, threshold=0.5, window=1, initial_interval=0)
    fires = [
        trigger.update(np.array(u), np.array([True, True])) for u in ([0.0, 0.0], [1.0, 0.0], [0.0, 1.0])
    ]
    assert [f.tolist() for f in fires] == [[False, False], [True, False], [False, True]]


def test_backoff_from_resume_counts_only_the_steps_after_the_manoeuvre() -> None:
    # Every normal step is above C; the first recovery fires at step 2 (T 1 -> 2), its manoeuvre takes
    # steps 3-5.
    stream, active = [1.0] * 12, [True] * 3 + [False] * 3 + [True] * 6
    # From the trigger: the manoeuvre's steps count, so the first normal step fires again (6 - 2 > 2).
    assert run(RecoveryTrigger(1, 0.5, 1, initial_interval=1), stream, active)[:2] == [2, 6]
    # From the resumption: three normal steps first (steps 6, 7 and 8: 3 > 2).
    resume = RecoveryTrigger(1, 0.5, 1, initial_interval=1, backoff_from="resume")
    assert run(resume, stream, active)[:2] == [2, 9]


def test_max_recoveries_stops_firing_after_the_limit_per_rollout() -> None:
    # Every step above C and T = 0: unlimited, a rollout fires at every step from step 1; with a limit of 2
    # it fires twice and then never, while the other rollout keeps its own count.
    assert run(RecoveryTrigger(1, 0.5, 1, initial_interval=0), [1.0] * 5) == [1, 2, 3, 4]
    limited = RecoveryTrigger(2, 0.5, 1, initial_interval=0, max_recoveries=2)
    streams = [[1.0, 0.0]] * 4 + [[1.0, 1.0]] * 3
    fires = [limited.update(np.array(u), np.array([True, True])).tolist() for u in streams]
    assert [row[0] for row in fires] == [False, True, True, False, False, False, False]
    assert [row[1] for row in fires] == [False] * 4 + [True, True, False]


def test_a_deadline_fires_at_its_age_without_uncertainty_and_counts_from_a_fresh_memory() -> None:
    # Zero uncertainty never crosses C; the deadline of 5 fires at the step the clock reaches 5 (step 4).
    assert run(RecoveryTrigger(1, 0.5, 1, initial_interval=0), [0.0] * 20) == []
    trigger = RecoveryTrigger(1, 0.5, 1, initial_interval=0, deadline=5)
    active = [True] * 5 + [False] * 3 + [True] * 12  # a 3-step manoeuvre after the firing step
    fired = []
    for t in range(13):
        if t == 8:
            trigger.restart_clock(0)  # the manoeuvre handed back with a fresh memory
        if trigger.update(np.array([0.0]), np.array([active[t]]))[0]:
            fired.append(t)
    assert fired == [4, 12]  # five steps of the fresh policy: steps 8 to 12
    # Without the restart the clock keeps counting the episode's normal steps: it stays past the deadline,
    # so the next firing waits only for the doubled backoff.
    kept = RecoveryTrigger(1, 0.5, 1, initial_interval=2, deadline=5)
    assert run(kept, [0.0] * 20, active)[:2] == [4, 9]
