"""A missed grasp seen by proprioception alone (`--recovery.grasp_miss`): scripted finger readings on the
robots' own gripper codes, then the trigger's cause, then a Fetch arm closing on air."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from helpers.scripted import FAKE, IDENTITY_STATS, run_episode, scripted_policy

from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH
from lerobot_ivmc.envs.metaworld.embodiment import SAWYER
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.controller import IntrospectiveController
from lerobot_ivmc.recovery.grasp_miss import GraspMissAlarm
from lerobot_ivmc.recovery.trigger import RecoveryTrigger


def alarms(alarm: GraspMissAlarm, fingers: list[float], commands: list[float], active=None) -> list[int]:
    """Steps at which rollout 0's alarm is up."""
    up = []
    for t, (f, c) in enumerate(zip(fingers, commands, strict=True)):
        on = np.array([True if active is None else active[t]])
        if alarm.update(np.array([[f]]), np.array([c]), on)[0]:
            up.append(t)
    return up


def test_a_grasp_closed_on_nothing_alarms_after_its_run_and_one_on_the_object_never() -> None:
    # FAKE closes with -0.5 and reads 0.2-0.8 on something: closing on nothing ends below 0.2.
    closing = [1.0, 0.6, 0.3, 0.1, 0.1, 0.1, 0.1, 0.1]
    assert alarms(GraspMissAlarm(1, 3, FAKE), closing, [-0.5] * 8) == [5, 6, 7]
    on_object = [1.0, 0.6, 0.3, 0.25, 0.25, 0.25, 0.25, 0.25]
    assert alarms(GraspMissAlarm(1, 3, FAKE), on_object, [-0.5] * 8) == []
    # The same fingers with FAKE's open command, or a grip that passes through "empty" for fewer steps.
    assert alarms(GraspMissAlarm(1, 3, FAKE), closing, [0.5] * 8) == []
    assert alarms(GraspMissAlarm(1, 3, FAKE), [0.1, 0.1, 0.3, 0.1, 0.1, 0.3], [-0.5] * 6) == []


def test_the_run_counts_normal_steps_only_and_starts_again_when_cleared() -> None:
    alarm = GraspMissAlarm(1, 2, SAWYER)  # MetaWorld: effort 0.6 closes, ~0.3 is closed on nothing
    active = [True, False, True, True, True]
    assert alarms(alarm, [0.29] * 5, [0.6] * 5, active) == [3, 4]
    alarm.clear(np.array([0]))
    assert alarms(alarm, [0.29], [0.6]) == []
    with pytest.raises(ValueError, match="at least 1 step"):
        GraspMissAlarm(1, 0, SAWYER)


def test_the_trigger_fires_on_an_alarm_after_its_backoff_and_says_why() -> None:
    trigger = RecoveryTrigger(2, threshold=0.5, window=1, initial_interval=2, deadline=6)
    fired = []
    for t in range(12):
        alarm = np.array([t >= 1, False])  # rollout 0 alarmed from step 1 on, rollout 1 never
        fire = trigger.update(np.array([0.0, 1.0 if t == 4 else 0.0]), np.array([True, True]), alarm)
        fired += [(t, row, trigger.causes[row]) for row in np.flatnonzero(fire)]
    # Rollout 0 waits out its backoff (T = 2, then 4); rollout 1 fires on its score at step 4. Both clocks
    # pass the deadline of 6 at step 5, which names the later firings (score, then deadline, then alarm).
    assert fired == [(3, 0, "alarm"), (4, 1, "score"), (8, 0, "deadline"), (9, 1, "deadline")]


def test_a_fetch_arm_closing_on_air_retries_with_the_cause_recorded() -> None:
    """Zero uncertainty never crosses C: only the fingers, closed on nothing for 10 steps, fire a retry."""
    policy = scripted_policy([0.0] * 100, move=[0.0, 0.0, 0.3], gripper=FETCH.gripper_close)
    cfg = RecoveryConfig(mode="retry", window=1, initial_interval=0, grasp_miss=10)
    stats = (torch.zeros(9), torch.ones(9))  # the batch carries the raw joints
    controller = IntrospectiveController(
        policy, cfg, 0.5, 1, IDENTITY_STATS, state_stats=stats, embodiment=FETCH
    )
    run_episode(controller, steps=40)
    events = controller.traces[-1].events[0]
    assert events and all(event["cause"] == "grasp_miss" for event in events)
    assert events[0]["step"] >= 10  # the fingers take a few steps to close, then ten more
    without = IntrospectiveController(
        scripted_policy([0.0] * 100, move=[0.0, 0.0, 0.3], gripper=FETCH.gripper_close),
        RecoveryConfig(mode="retry", window=1, initial_interval=0),
        0.5,
        1,
        IDENTITY_STATS,
        state_stats=stats,
        embodiment=FETCH,
    )
    run_episode(without, steps=40)
    assert without.traces[-1].events == [[]]


def test_bad_settings_say_what_to_do() -> None:
    with pytest.raises(ValueError, match="none to fire"):
        RecoveryConfig(mode="none", grasp_miss=10)
    with pytest.raises(ValueError, match="grasp_miss must be >= 0"):
        RecoveryConfig(mode="retry", grasp_miss=-1)
    with pytest.raises(ValueError, match="needs observation.state"):
        IntrospectiveController(
            scripted_policy([0.0], move=[0.0, 0.0, 0.0]),
            RecoveryConfig(mode="retry", grasp_miss=5),
            0.5,
            1,
            IDENTITY_STATS,
            embodiment=FETCH,
        )


def test_the_sawyer_closing_on_air_in_metaworld_reads_closed_on_nothing_and_alarms() -> None:
    """MetaWorld's own env: the hand rises with the grab effort of its policies (0.6) and closes on air; the
    opening it reports falls below the Sawyer's held gap and the alarm rises after its run; opened, it does
    not."""
    from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv

    env = SeededMetaworldEnv("pick-place-v3", split="val")
    try:
        for effort, expected in ((0.6, True), (-1.0, False)):
            observation, _ = env.reset(seed=0)
            alarm, up = GraspMissAlarm(1, 10, SAWYER), []
            for t in range(40):
                observation, *_ = env.step(np.array([0.0, 0.0, 0.5, effort], dtype=np.float32))
                fingers = np.asarray(observation["agent_pos"])[None, list(SAWYER.finger_state_indices)]
                if alarm.update(fingers, np.array([effort]), np.array([True]))[0]:
                    up.append(t)
            assert bool(up) is expected, (effort, fingers)
    finally:
        env.close()
