"""`reach`, the recovery that knows no task: its path on a synthetic robot (no simulator), its grasp
search, its settings, and in a real env that it reads nothing of the simulator's privileged state."""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace

import numpy as np
import pytest
import torch
from helpers.scripted import FAKE, IDENTITY_STATS, run_episode, scripted_policy

from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH_EMBODIMENT
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.controller import BatchTrace, IntrospectiveController
from lerobot_ivmc.recovery.manoeuvres import REACH, Stop, WaypointPath
from lerobot_ivmc.recovery.strategies import make_strategy
from lerobot_ivmc.recovery.strategy_settings import ReachSettings

TABLE = 0.02  # the synthetic world's table: the grip point cannot go lower


def stub_controller(
    belief: np.ndarray, start: np.ndarray, goal: np.ndarray | None = None, frame: np.ndarray | None = None
) -> SimpleNamespace:
    """What `reach` reads of the controller: a policy whose object head believes `belief` (and its goal head
    `goal`; metres, identity statistics), with `frame` (9,) its frame position head's reading (EE, object,
    goal) if given, the start grip position, the robot and the traces."""
    heads = [belief] if goal is None else [belief, goal]
    decoded = (None, None, None, *(torch.as_tensor(h, dtype=torch.float32)[None] for h in heads))
    policy = SimpleNamespace(
        config=SimpleNamespace(
            aux_indices=(0, 1, 2, 3, 4, 5), goal_head=goal is not None, frame_position_head=frame is not None
        ),
        net=SimpleNamespace(decode=lambda *args, **kwargs: decoded),
        frame_positions=None if frame is None else torch.as_tensor(frame, dtype=torch.float32)[None],
    )
    trace = BatchTrace(events=[[{}]])
    return SimpleNamespace(
        policy=policy,
        object_positions=lambda normalised: normalised.float().numpy().astype(np.float64),
        initial_grip=start[None],
        last_gripper=np.array([FAKE.gripper_open]),
        embodiment=FAKE,
        step=0,
        traces=[trace],
        task_traits=None,
    )


def drive(strategy, ctx, steps: int, world: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> tuple:
    """Fire `strategy` at the first step on the synthetic robot, from `ctx`'s start grip position with open
    fingers, until it hands back (at most `steps` steps); `world(grip, action)` moves the world after each
    action and returns the finger reading. Returns the manoeuvres in order, the grip path and the gripper
    commands."""
    strategy.start_batch(1)
    grip, fingers = ctx.initial_grip[0].copy(), np.array([1.0])
    strategy.observe(ctx, SimpleNamespace(embedding=None), np.zeros(1), np.ones(1, dtype=bool))
    manoeuvre, _ = strategy.begin(ctx, 0, grip, fingers[None])
    manoeuvres, path, commands = [manoeuvre], [], []
    for _ in range(steps):
        ctx.step += 1
        manoeuvre.advance(grip)
        if manoeuvre.finished:
            manoeuvre = strategy.follow(ctx, 0, manoeuvre, grip, fingers[None])
            if manoeuvre is None:
                break
            manoeuvres.append(manoeuvre)
            continue
        strategy.observe(ctx, SimpleNamespace(embedding=None), np.zeros(1), np.zeros(1, dtype=bool))
        action = manoeuvre.act(grip, lambda: None)
        grip = grip + action[:3] * FAKE.metres_per_action_unit
        grip[2] = max(grip[2], TABLE)
        fingers = world(grip, action)
        path.append(grip.copy())
        commands.append(float(action[3]))
    return manoeuvres, path, commands


def run_reach(settings: ReachSettings, belief, obj, steps: int = 400, goal=None) -> tuple[list, list, list]:
    """Fire `reach` at the first step on the synthetic robot and world (an object at `obj` is held when
    the fingers close within 1 cm of it); return the manoeuvres in order, the grip path and the gripper
    commands, until it hands back."""
    strategy = make_strategy(RecoveryConfig(mode="reach", reach=settings))
    start, obj = np.array([0.0, 0.0, 0.2]), np.asarray(obj, dtype=np.float64)
    goal = None if goal is None else np.asarray(goal, dtype=np.float64)
    ctx = stub_controller(np.asarray(belief, dtype=np.float64), start, goal)
    hand = {"closed": False, "fingers": np.array([1.0])}

    def world(grip: np.ndarray, action: np.ndarray) -> np.ndarray:
        if action[3] == FAKE.gripper_close and not hand["closed"]:  # shut: on the object or on nothing
            hand["closed"] = True
            hand["fingers"] = np.array([0.5 if np.linalg.norm(grip[:2] - obj[:2]) < 0.01 else 0.0])
        elif action[3] == FAKE.gripper_open:
            hand["closed"], hand["fingers"] = False, np.array([1.0])
        return hand["fingers"]

    return drive(strategy, ctx, steps, world)


def test_reach_looks_from_the_start_then_grasps_around_the_belief_until_the_fingers_hold() -> None:
    belief, obj = np.array([0.1, 0.05, 0.0]), np.array([0.13, 0.05, 0.0])  # believed 3 cm short in x
    manoeuvres, path, commands = run_reach(ReachSettings(grasp_tries=3, search_radius=0.03), belief, obj)
    kinds = [type(m).__name__ for m in manoeuvres]
    assert kinds == ["ToStart", "Look", "Grasp", "Grasp"]  # the first grasp closed on nothing
    first, second = manoeuvres[2], manoeuvres[3]
    np.testing.assert_allclose(first.target, belief)
    np.testing.assert_allclose(second.target, belief + [0.03, 0.0, 0.0])  # the search's first direction
    assert commands[0] == FAKE.gripper_open and commands[-1] == FAKE.gripper_close
    # The table stops the descent 2 cm above the object's centre: the stop counts as reached (stalled).
    assert min(p[2] for p in path) == TABLE and np.linalg.norm(path[-1][:2] - obj[:2]) < 0.01
    assert all(m.phase == REACH for m in manoeuvres)


def test_reach_hands_back_after_its_last_try_whatever_the_fingers_hold() -> None:
    belief, obj = np.array([0.1, 0.05, 0.0]), np.array([0.3, 0.3, 0.0])  # nowhere near
    manoeuvres, _, _ = run_reach(ReachSettings(grasp_tries=2), belief, obj)
    assert [type(m).__name__ for m in manoeuvres] == ["ToStart", "Look", "Grasp", "Grasp"]


def test_reach_without_grasp_stops_above_the_belief_at_the_start_height() -> None:
    belief = np.array([0.1, 0.05, 0.0])
    settings = ReachSettings(belief="now", grasp=False)
    manoeuvres, path, commands = run_reach(settings, belief, belief)
    assert len(manoeuvres) == 1 and set(commands) == {FAKE.gripper_open}
    np.testing.assert_allclose(path[-1], [0.1, 0.05, 0.2], atol=0.011)


@pytest.mark.parametrize("release", [False, True])
def test_reach_carries_what_its_grasp_holds_to_the_believed_goal(release: bool) -> None:
    """With `carry`, a grasp that holds is followed by a carry that brings the object, where the grasp
    holds it from the grip point, onto the goal the goal head believes; `release` sets it down there and
    lets go, else the fingers stay closed to the end."""
    obj, goal = np.array([0.1, 0.05, 0.0]), np.array([-0.1, 0.2, 0.05])
    settings = ReachSettings(carry=True, release=release)
    manoeuvres, path, commands = run_reach(settings, obj, obj, goal=goal)
    assert [type(m).__name__ for m in manoeuvres] == ["ToStart", "Look", "Grasp", "WaypointMoves"]
    # The table held the grip point 2 cm above the object's centre at the grasp: so it is carried.
    place = goal - (obj - np.array([obj[0], obj[1], TABLE]))
    if release:  # set down 2 cm above the goal, let go there, then rise
        opened = commands.index(FAKE.gripper_open, commands.index(FAKE.gripper_close))
        np.testing.assert_allclose(path[opened], place + [0.0, 0.0, 0.02], atol=0.011)
        assert commands[-1] == FAKE.gripper_open and path[-1][2] > path[opened][2] + 0.04
    else:  # closed from the grasp to the end, the object on the goal
        grasped = commands.index(FAKE.gripper_close)
        assert set(commands[grasped:]) == {FAKE.gripper_close}
        np.testing.assert_allclose(path[-1], place, atol=0.011)
    np.testing.assert_allclose(path[-1][:2], goal[:2], atol=0.011)


def test_reach_carry_needs_the_goal_head_and_a_grasp() -> None:
    strategy = make_strategy(RecoveryConfig(mode="reach", reach=ReachSettings(carry=True)))
    no_goal = stub_controller(np.zeros(3), np.zeros(3)).policy
    with pytest.raises(ValueError, match="needs a policy trained with --policy.goal_head=true"):
        strategy.check(no_goal, IDENTITY_STATS)
    with pytest.raises(ValueError, match="reach.carry=true carries the object the grasp holds"):
        ReachSettings(carry=True, grasp=False)
    with pytest.raises(ValueError, match="add --recovery.reach.carry=true"):
        ReachSettings(release=True)


def test_a_waypoint_path_hands_back_with_a_fresh_memory() -> None:
    path = WaypointPath(
        [Stop(np.array([0.0, 0.0, 0.1]), FAKE.gripper_open)], 50, 0.005, FAKE, REACH, np.zeros(3)
    )
    grip = np.zeros(3)
    for _ in range(50):
        change = path.advance(grip)
        if path.finished:
            break
        grip = grip + path.act(grip, lambda: None)[:3] * FAKE.metres_per_action_unit
    assert path.finished and change is not None and change.memory is None


def test_reach_settings_validate_themselves_and_belong_to_reach() -> None:
    with pytest.raises(ValueError, match="--recovery.reach.grasp_tries must be >= 1"):
        ReachSettings(grasp_tries=0)
    with pytest.raises(ValueError, match="--recovery.reach.belief must be one of"):
        ReachSettings(belief="later")
    with pytest.raises(ValueError, match="--recovery.reach.\\* set the reach mode"):
        RecoveryConfig(mode="retry", reach=ReachSettings(grasp=False))


def test_reach_reads_nothing_of_the_simulators_privileged_state() -> None:
    """The same episode with the object's true position withheld from the controller's input acts the
    same: reach reads the grip point, the fingers and the policy's heads only."""

    def actions(withhold: bool) -> np.ndarray:
        stream = [0.0] * 12 + [1.0] + [0.0] * 100
        policy = scripted_policy(stream, move=[0.0, 0.3, 0.0])
        cfg = RecoveryConfig(mode="reach", window=1, initial_interval=0, reach=ReachSettings(belief_steps=3))
        controller = IntrospectiveController(
            policy,
            cfg,
            threshold=0.5,
            window=1,
            env_state_stats=IDENTITY_STATS,
            state_stats=(torch.zeros(9), torch.ones(9)),
            embodiment=FETCH_EMBODIMENT,
        )
        if withhold:  # the policy's input keeps its camera and joints; the object entries become zeros
            select = controller.select_action

            def blind(batch, **kwargs):
                batch = dict(batch)
                batch["observation.environment_state"] = batch["observation.environment_state"].clone()
                batch["observation.environment_state"][:, 3:] = 0.0
                return select(batch, **kwargs)

            controller.select_action = blind
        _, taken = run_episode(controller, steps=60)
        phases = np.stack(controller.traces[-1].phase)[:, 0]
        assert (phases == REACH).sum() > 10
        return np.array(taken)

    np.testing.assert_array_equal(actions(False), actions(True))


def test_reach_carries_at_once_what_the_hand_holds_when_the_trigger_fires() -> None:
    """Holding the object at the trigger (the fingers rest apart after a "close"), carry goes straight to
    the goal with the object where the object head places it in the hand, without a look or a grasp."""
    obj, goal, grip = np.array([0.0, 0.0, 0.17]), np.array([-0.1, 0.2, 0.05]), np.array([0.0, 0.0, 0.2])
    strategy = make_strategy(RecoveryConfig(mode="reach", reach=ReachSettings(carry=True)))
    ctx = stub_controller(obj, grip, goal)
    ctx.last_gripper = np.array([FAKE.gripper_close])
    strategy.start_batch(1)
    strategy.observe(ctx, SimpleNamespace(embedding=None), np.zeros(1), np.ones(1, dtype=bool))
    carry, event = strategy.begin(ctx, 0, grip, np.array([[0.5]]))
    assert type(carry).__name__ == "WaypointMoves" and event["holding"] is True
    np.testing.assert_allclose(carry.target, goal + [0.0, 0.0, 0.03])  # the grip 3 cm above the object


@pytest.mark.parametrize("source", ["memory", "frame"])
def test_reach_carry_reads_the_heads_it_is_told_and_bounds_the_held_offset(source: str) -> None:
    """`reach.object` and `reach.goal` pick the memory's heads or the frame position head's reading of the
    frame; the believed centre of the held object lies 8 cm from the grip point, which `max_held_offset`
    shortens to its length (5 cm by default) or keeps whole (15 cm)."""
    grip = np.array([0.0, 0.0, 0.2])
    memory_obj, memory_goal = np.array([0.0, 0.0, 0.17]), np.array([-0.1, 0.2, 0.05])
    frame_obj, frame_goal = np.array([0.08, 0.0, 0.2]), np.array([0.1, -0.2, 0.05])
    frame = np.concatenate([grip, frame_obj, frame_goal])
    targets = {}
    for bound in (0.05, 0.15):
        settings = ReachSettings(carry=True, object=source, goal=source, max_held_offset=bound)
        strategy = make_strategy(RecoveryConfig(mode="reach", reach=settings))
        ctx = stub_controller(memory_obj, grip, memory_goal, frame=frame)
        ctx.last_gripper = np.array([FAKE.gripper_close])
        strategy.check(ctx.policy, IDENTITY_STATS)
        strategy.start_batch(1)
        strategy.observe(ctx, SimpleNamespace(embedding=None), np.zeros(1), np.ones(1, dtype=bool))
        targets[bound] = strategy.begin(ctx, 0, grip, np.array([[0.5]]))[0].target
    if source == "memory":  # 3 cm below the grip: within both bounds
        for target in targets.values():
            np.testing.assert_allclose(target, memory_goal + [0.0, 0.0, 0.03])
    else:
        np.testing.assert_allclose(targets[0.15], frame_goal - [0.08, 0.0, 0.0], atol=1e-6)
        np.testing.assert_allclose(targets[0.05], frame_goal - [0.05, 0.0, 0.0], atol=1e-6)


def test_reach_frame_readings_need_the_frame_position_head() -> None:
    policy = stub_controller(np.zeros(3), np.zeros(3), np.zeros(3)).policy
    for name in ("object", "goal"):
        settings = ReachSettings(carry=True, **{name: "frame"})
        strategy = make_strategy(RecoveryConfig(mode="reach", reach=settings))
        with pytest.raises(ValueError, match=f"pass --recovery.reach.{name}=memory"):
            strategy.check(policy, IDENTITY_STATS)
    with pytest.raises(ValueError, match="--recovery.reach.max_held_offset is in metres"):
        ReachSettings(max_held_offset=-0.1)
    with pytest.raises(ValueError, match="--recovery.reach.goal must be one of"):
        ReachSettings(goal="later")


def run_push(settings: ReachSettings, obj, goal, steps: int = 300) -> tuple[list, np.ndarray, list, list]:
    """Fire `reach` with `push` at the first step on the synthetic robot in a world whose object (a disc
    of 3 cm radius, its centre at the grip point's height) is pushed by the grip point and is always
    believed where it is; return the manoeuvres, where the object ends, the grip path and the commands."""
    strategy = make_strategy(RecoveryConfig(mode="reach", reach=settings))
    start, obj = np.array([0.0, 0.0, 0.2]), np.asarray(obj, dtype=np.float64).copy()
    ctx = stub_controller(obj, start, np.asarray(goal, dtype=np.float64))
    beliefs = ctx.policy.net.decode()
    ctx.policy.net.decode = lambda *args, **kwargs: (*beliefs[:3], torch.as_tensor(obj)[None], beliefs[4])

    def world(grip: np.ndarray, action: np.ndarray) -> np.ndarray:
        gap = obj[:2] - grip[:2]
        if grip[2] < obj[2] + 0.01 and np.linalg.norm(gap) < 0.03:  # the fingers push the disc ahead
            obj[:2] = grip[:2] + 0.03 * gap / np.linalg.norm(gap)
        return np.array([1.0])

    manoeuvres, path, commands = drive(strategy, ctx, steps, world)
    return manoeuvres, obj, path, commands


@pytest.mark.parametrize("goal", [[-0.1, 0.2, 0.03], [0.25, -0.05, 0.03]])
def test_reach_push_pushes_the_object_onto_the_believed_goal_with_closed_fingers(goal) -> None:
    """With `push`, after the look the closed fingers come down behind the object on the line from the
    goal and push it along that line until it is believed on the goal, then hand back."""
    obj = np.array([0.1, 0.05, 0.03])
    manoeuvres, pushed, path, commands = run_push(ReachSettings(push=True), obj, goal)
    kinds = [type(m).__name__ for m in manoeuvres]
    assert kinds[:2] == ["ToStart", "Look"] and set(kinds[2:]) == {"PushAlongBelief"} and len(kinds) <= 4
    np.testing.assert_allclose(pushed[:2], np.asarray(goal)[:2], atol=0.015)
    pushing = commands[commands.index(FAKE.gripper_close) :]
    assert set(pushing) == {FAKE.gripper_close}  # closed from the first push step to the hand-back
    assert path[-1][2] > obj[2] + 0.04  # lifted off the object before handing back


def test_reach_push_leaves_an_object_believed_on_the_goal_and_needs_the_goal_head() -> None:
    obj = np.array([0.1, 0.05, 0.03])
    manoeuvres, pushed, _, _ = run_push(ReachSettings(push=True), obj, obj + [0.005, 0.0, 0.0])
    assert len(manoeuvres) == 3 and np.linalg.norm(pushed[:2] - obj[:2]) < 0.01  # one leg, no push needed
    strategy = make_strategy(RecoveryConfig(mode="reach", reach=ReachSettings(push=True)))
    with pytest.raises(ValueError, match="reach.push=true takes the object to the goal"):
        strategy.check(stub_controller(np.zeros(3), np.zeros(3)).policy, IDENTITY_STATS)
    with pytest.raises(ValueError, match="choose one"):
        ReachSettings(push=True, carry=True)
