"""The embodiment layer: recovery's moves in a robot's own action scale and gripper commands."""

from __future__ import annotations

import numpy as np
from helpers.scripted import FAKE

from lerobot_ivmc.envs.embodiment import HOLD
from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH
from lerobot_ivmc.envs.metaworld.embodiment import SAWYER
from lerobot_ivmc.recovery.manoeuvres import MoveToInit, RandomMoves


def test_a_move_is_scaled_by_the_robots_metres_per_action_unit() -> None:
    grip, target = np.zeros(3), np.array([0.01, -0.03, 0.0])
    np.testing.assert_allclose(FAKE.move_towards(grip, target, FAKE.gripper_open), [0.5, -1.0, 0.0, 0.5])
    # MetaWorld's mocap target leads the hand: a quarter of the way a step, within the action's limit.
    np.testing.assert_allclose(SAWYER.move_towards(grip, target)[:3], [0.25, -0.75, 0.0])
    np.testing.assert_allclose(FETCH.move_towards(grip, target)[:3], [0.2, -0.6, 0.0])
    assert np.isnan(FAKE.move_towards(grip, target)[3])  # the fingers left as they are


def test_init_opens_the_fingers_with_the_robots_own_command_and_reaches_its_target() -> None:
    rng = np.random.default_rng(0)
    move = MoveToInit(
        np.array([0.1, 0.0, 0.2]), radius=0.0, steps=50, tolerance=0.001, rng=rng, embodiment=FAKE
    )
    grip = np.zeros(3)
    for _ in range(20):
        if move.advance(grip) is not None:
            break
        action = move.act(grip, lambda: None)
        assert action[3] == FAKE.gripper_open
        grip = grip + action[:3] * FAKE.metres_per_action_unit
    assert move.finished and np.allclose(grip, [0.1, 0.0, 0.2], atol=0.001)


def test_holding_the_fingers_repeats_the_last_command_where_the_robot_has_no_no_op() -> None:
    last = np.array([SAWYER.gripper_close, SAWYER.gripper_open])
    np.testing.assert_array_equal(SAWYER.hold(last), last)
    np.testing.assert_array_equal(FETCH.hold(np.array([-1.0, 1.0])), [0.0, 0.0])
    # Fetch remembers the last command other than its no-op; the Sawyer every command.
    np.testing.assert_array_equal(FETCH.remember(np.array([-1.0, 1.0]), np.array([0.0, -1.0])), [-1.0, -1.0])
    np.testing.assert_array_equal(SAWYER.remember(last, np.array([0.3, -1.0])), [0.3, -1.0])
    moves = RandomMoves(3, 1.0, np.random.default_rng(0))
    assert np.isnan(moves.act(np.zeros(3), lambda: None)[3]) and np.isnan(HOLD)


def test_retry_opens_rises_returns_to_the_start_and_hands_back_with_a_fresh_memory() -> None:
    from lerobot_ivmc.recovery.manoeuvres import ReturnToStart

    start, grip = np.array([0.0, 0.6, 0.2]), np.array([0.1, 0.7, 0.05])
    move = ReturnToStart(grip, start, steps=100, tolerance=0.005, embodiment=SAWYER)
    path = []
    for _ in range(100):
        change = move.advance(grip)
        if change is not None:
            break
        action = move.act(grip, lambda: None)
        assert action[3] == SAWYER.gripper_open
        grip = grip + action[:3] * SAWYER.metres_per_action_unit
        path.append(grip.copy())
    assert move.finished and change.memory is None  # a fresh memory
    assert np.allclose(grip, start, atol=0.005)
    rise = [p for p in path if p[2] < start[2] - 0.005]
    assert all(np.allclose(p[:2], [0.1, 0.7]) for p in rise)  # straight up first, then across


def test_the_fingers_hold_something_only_between_closed_on_nothing_and_open() -> None:
    assert FETCH.holds(np.array([0.024, 0.025])) and not FETCH.holds(np.array([0.001, 0.0]))
    assert SAWYER.holds(np.array([0.45])) and not SAWYER.holds(np.array([0.29]))
    assert not SAWYER.holds(np.array([1.0])) and not FAKE.holds(np.array([0.9]))


def test_a_command_nearer_close_than_open_closes_the_fingers() -> None:
    # MetaWorld's grab effort of 0.6 and a continuous gripper's 0.97 close the Sawyer as 1 does.
    assert SAWYER.closes(1.0) and SAWYER.closes(0.6) and SAWYER.closes(0.97)
    assert not SAWYER.closes(-1.0) and not SAWYER.closes(-0.4)
    assert FETCH.closes(FETCH.gripper_close) and not FETCH.closes(FETCH.gripper_open)


def retry_target(start_radius: float, seed: int) -> np.ndarray:
    """The point `retry` returns to from (0.1, 0.7, 0.05) on the synthetic robot, the rollout's draws
    seeded by `seed`."""
    from types import SimpleNamespace

    from lerobot_ivmc.recovery.config import RecoveryConfig
    from lerobot_ivmc.recovery.strategies import make_strategy
    from lerobot_ivmc.recovery.strategy_settings import RetrySettings

    strategy = make_strategy(RecoveryConfig(mode="retry", retry=RetrySettings(start_radius=start_radius)))
    rng = np.random.default_rng(seed)
    ctx = SimpleNamespace(initial_grip=np.array([[0.0, 0.6, 0.2]]), embodiment=FAKE, draws=lambda row: (rng,))
    manoeuvre, event = strategy.begin(ctx, 0, np.array([0.1, 0.7, 0.05]), None)
    np.testing.assert_allclose(event["target"], manoeuvre.target.round(4))
    return manoeuvre.target


def test_retry_with_a_start_radius_returns_near_the_start_as_its_rollouts_stream_draws() -> None:
    start = np.array([0.0, 0.6, 0.2])
    np.testing.assert_array_equal(retry_target(0.0, seed=1), start)  # the start itself
    near = [retry_target(0.1, seed) for seed in range(5)]
    assert all(0 < np.linalg.norm(point - start) <= 0.1 for point in near)
    assert len({tuple(point) for point in near}) == 5  # another stream, another point
    np.testing.assert_array_equal(retry_target(0.1, seed=3), near[3])  # the same stream, the same point
