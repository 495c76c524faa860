"""Algorithm 1 in a real env with scripted uncertainty: back-track, memory restore, min_unc choice,
rand and init manoeuvres."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from helpers.policies import make_config
from helpers.scripted import IDENTITY_STATS, recorded_changes, run_episode, scripted_policy, to_batch

from lerobot_ivmc.envs import make_task_env
from lerobot_ivmc.envs.fetch_env import EMBODIMENT as FETCH_EMBODIMENT
from lerobot_ivmc.policies import BVMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.controller import IntrospectiveController, memory_row
from lerobot_ivmc.recovery.manoeuvres import BACKTRACK, FOLLOW_MIN_UNC, MOVE_TO_INIT, RANDOM_MOVES
from lerobot_ivmc.recovery.strategy_settings import MinUncSettings


def test_min_unc_backtracks_to_the_least_uncertain_step_and_restores_its_memory() -> None:
    # Step 4 is the least uncertain; step 10 pushes the 1-step window over the threshold.
    stream = [0.2] * 4 + [0.01] + [0.2] * 5 + [1.0] + [0.2] * 100
    policy = scripted_policy(stream, move=[0.0, 0.6, 0.0])
    cfg = RecoveryConfig(mode="min_unc", window=1, initial_interval=0, recovery_steps=3)
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    memories, restores = [], []
    select = controller.select_action

    def recording_select(batch):
        action = select(batch)
        memories.append(policy.get_memory())
        return action

    apply = controller._apply

    def recording_apply(row, change):
        apply(row, change)
        restores.append((controller.step, controller.grip_positions(controller._last_batch), change.memory))

    controller._apply = recording_apply
    controller.select_action = recording_select
    original = IntrospectiveController.grip_positions

    def remember_batch(self, batch):
        self._last_batch = batch
        return original(self, batch)

    controller.grip_positions = remember_batch.__get__(controller)
    grips, _ = run_episode(controller, steps=30)

    events = controller.traces[-1].events[0]
    assert events[0]["step"] == 10 and events[0]["backtrack_to_step"] == 4
    step, grip, memory = restores[0]
    # The robot moved 6 steps along +y from step 4 to 10; it is back within tolerance of step 4 ...
    assert np.linalg.norm(grips[10] - grips[4]) > 0.1
    assert np.linalg.norm(grip[0] - grips[4]) <= cfg.backtrack_tolerance
    # ... and the memory is exactly the one before step 4 (the memory after step 3).
    for restored, saved in zip(memory, memory_row(memories[3], 0), strict=True):
        assert torch.equal(restored, saved)
    phases = np.stack(controller.traces[-1].phase)[:, 0]
    assert (phases[10:step] == BACKTRACK).all() and (phases[step : step + 3] == FOLLOW_MIN_UNC).all()


def test_min_unc_with_min_unc_memory_reset_backtracks_then_resets_the_memory() -> None:
    """`--recovery.min_unc.memory=reset`: the same back-track, then the memory after `reset()` instead of
    the saved one (a false belief formed before the back-track point goes)."""
    stream = [0.2] * 4 + [0.01] + [0.2] * 5 + [1.0] + [0.2] * 100
    policy = scripted_policy(stream, move=[0.0, 0.6, 0.0])
    cfg = RecoveryConfig(
        mode="min_unc", window=1, initial_interval=0, recovery_steps=3, min_unc=MinUncSettings(memory="reset")
    )
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    changes, apply = [], controller._apply

    def recording_apply(row, change):
        apply(row, change)
        changes.append((change, policy.get_memory()))

    controller._apply = recording_apply
    run_episode(controller, steps=20)
    events = controller.traces[-1].events[0]
    assert events[0]["step"] == 10 and events[0]["backtrack_to_step"] == 4
    change, memory_after = changes[0]
    assert change.memory is None  # reset, not restored
    for value, initial in zip(memory_after, policy.initial_memory(1), strict=True):
        assert torch.equal(value, initial)
    with pytest.raises(ValueError, match="min_unc.memory must be one of"):
        MinUncSettings(memory="forget")
    with pytest.raises(ValueError, match="no effect with --recovery.mode=init"):
        RecoveryConfig(mode="init", min_unc=MinUncSettings(memory="reset"))


def test_min_unc_executes_the_candidate_with_the_lowest_foreseen_uncertainty() -> None:
    policy = scripted_policy([0.0], move=[0.0, 0.0, 0.0])
    cfg = RecoveryConfig(mode="min_unc")
    controller = IntrospectiveController(
        policy, cfg, threshold=1.0, window=20, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    env = make_task_env("pick_place", image_size=64)
    observation, _ = env.reset(seed=1)
    prediction = policy.sample(to_batch(observation))
    foreseen = policy.foresee(prediction.embedding, prediction.samples)[0]
    chosen = controller.strategy.policy_action(controller, prediction, 0)
    np.testing.assert_array_equal(chosen, prediction.samples[0, int(foreseen.argmin())].numpy())
    # Against a head patched to prefer candidate 5:
    policy.foresee = lambda e, a: torch.where(torch.arange(a.shape[1]) == 5, 0.0, 1.0)[None]
    chosen_again = controller.strategy.policy_action(controller, prediction, 0)
    np.testing.assert_array_equal(chosen_again, prediction.samples[0, 5].numpy())
    env.close()


def test_min_unc_memory_keep_backtracks_without_touching_the_memory() -> None:
    """`--recovery.min_unc.memory=keep` (the back-track-only ablation): no memory change at all."""
    stream = [0.2] * 4 + [0.01] + [0.2] * 5 + [1.0] + [0.2] * 100
    policy = scripted_policy(stream, move=[0.0, 0.6, 0.0])
    cfg = RecoveryConfig(
        mode="min_unc", window=1, initial_interval=0, recovery_steps=3, min_unc=MinUncSettings(memory="keep")
    )
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    changes = recorded_changes(controller)
    run_episode(controller, steps=20)
    phases = np.stack(controller.traces[-1].phase)[:, 0]
    assert (phases == BACKTRACK).any() and (phases == FOLLOW_MIN_UNC).any()  # it back-tracked, then followed
    assert changes == []


def test_min_unc_choice_mean_and_random_replace_the_foresight_choice() -> None:
    """The ablations of the foresight head: the Monte Carlo mean, or a candidate drawn at random (seeded)."""
    policy = scripted_policy([0.0], move=[0.0, 0.0, 0.0])
    policy.foresee = lambda e, a: torch.where(torch.arange(a.shape[1]) == 5, 0.0, 1.0)[None]  # prefers 5
    env = make_task_env("pick_place", image_size=64)
    observation, _ = env.reset(seed=1)
    prediction = policy.sample(to_batch(observation))
    env.close()

    def choose(choice: str, seed: int = 0) -> np.ndarray:
        cfg = RecoveryConfig(mode="min_unc", min_unc=MinUncSettings(choice=choice))
        controller = IntrospectiveController(
            policy,
            cfg,
            threshold=1.0,
            window=20,
            env_state_stats=IDENTITY_STATS,
            seed=seed,
            embodiment=FETCH_EMBODIMENT,
        )
        return controller.strategy.policy_action(controller, prediction, 0)

    np.testing.assert_array_equal(choose("foresight"), prediction.samples[0, 5].numpy())
    np.testing.assert_array_equal(choose("mean"), prediction.mean_action[0].numpy())
    samples = prediction.samples[0].numpy()
    drawn = [choose("random", seed) for seed in range(6)]
    assert all(any((d == sample).all() for sample in samples) for d in drawn)
    np.testing.assert_array_equal(drawn[0], choose("random", 0))  # seeded
    assert len({tuple(d) for d in drawn}) > 1 or len({tuple(s) for s in samples}) == 1
    with pytest.raises(ValueError, match="min_unc.choice must be one of"):
        MinUncSettings(choice="best")
    with pytest.raises(ValueError, match="no effect with --recovery.mode=rand"):
        RecoveryConfig(mode="rand", min_unc=MinUncSettings(choice="mean"))
    with pytest.raises(ValueError, match=r"random_streams must be one of \('batch', 'episode'\)"):
        RecoveryConfig(random_streams="scene")


def test_min_unc_widens_its_candidates_with_the_noise_the_head_was_distilled_with() -> None:
    policy = scripted_policy([0.0], move=[0.0, 0.0, 0.0])
    policy.config.foresight_action_noise = 0.4
    # A head preferring the largest +x move: with widened candidates it picks a move no sample proposed.
    policy.foresee = lambda e, a: -a[..., 0]
    env = make_task_env("pick_place", image_size=64)
    observation, _ = env.reset(seed=1)
    prediction = policy.sample(to_batch(observation))
    env.close()

    def controller(candidate_noise):
        cfg = RecoveryConfig(mode="min_unc", candidate_noise=candidate_noise)
        return IntrospectiveController(
            policy, cfg, threshold=1.0, window=20, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
        )

    default = controller(None)
    assert default.candidate_noise == 0.4
    chosen = default.strategy.policy_action(default, prediction, 0)
    samples = prediction.samples[0].numpy()
    assert chosen[0] > samples[:, 0].max() + 0.1  # beyond every plain sample
    assert chosen[3] in samples[:, 3]  # the gripper command is a sample's, never perturbed
    # An explicit 0 restores the paper's choice among the plain samples.
    widened_not = controller(0.0)
    plain = widened_not.strategy.policy_action(widened_not, prediction, 0)
    assert any((plain == sample).all() for sample in samples)


@pytest.mark.parametrize("mode, phase", [("rand", RANDOM_MOVES), ("init", MOVE_TO_INIT)])
def test_rand_and_init_move_then_reset_the_memory(mode: str, phase: int) -> None:
    stream = [0.0] * 5 + [1.0] + [0.0] * 100
    policy = scripted_policy(stream, move=[0.0, 0.3, 0.0])
    cfg = RecoveryConfig(mode=mode, window=1, initial_interval=0, recovery_steps=25)
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    changes = []
    apply = controller._apply
    controller._apply = lambda row, change: (changes.append(change), apply(row, change))
    grips, actions = run_episode(controller, steps=40)
    phases = np.stack(controller.traces[-1].phase)[:, 0]
    inside = np.flatnonzero(phases == phase)
    assert inside[0] == 5 and len(changes) == 1 and changes[0].memory is None  # memory reset at the end
    moves = np.array(actions)[inside]
    if mode == "rand":
        assert (
            len(inside) == 25
            and (moves[:, 3] == 0).all()
            and np.abs(moves[:, :3]).max() <= cfg.rand_step_scale
        )
    else:
        assert moves[0, 3] == 1.0  # opens the gripper
        target = np.array(controller.traces[-1].events[0][0]["target"])
        assert np.linalg.norm(target - grips[0]) <= cfg.init_sphere_radius + 1e-4
        end = inside[-1] + 1
        assert np.linalg.norm(grips[end] - target) <= cfg.move_tolerance or len(inside) == cfg.recovery_steps


def run_batch(controller: IntrospectiveController, steps: int, seeds: tuple[int, ...]) -> np.ndarray:
    """Step one pick_place env per seed with the controller, as one batch; the (T, B, 4) actions."""
    envs = [make_task_env("pick_place", image_size=64) for _ in seeds]
    observations = [env.reset(seed=seed)[0] for env, seed in zip(envs, seeds, strict=True)]
    controller.reset()
    actions = []
    for _ in range(steps):
        rows = [to_batch(observation) for observation in observations]
        batch = {key: torch.cat([row[key] for row in rows]) for key in rows[0]}
        actions.append(controller.select_action(batch).numpy())
        observations = [env.step(a)[0] for env, a in zip(envs, actions[-1], strict=True)]
    for env in envs:
        env.close()
    return np.stack(actions)


@pytest.mark.parametrize("mode", ["rand", "init"])
def test_a_rollouts_random_draws_do_not_depend_on_when_the_others_recover(mode: str) -> None:
    """Rollout 0 recovers at step 6 in both runs; rollout 1 at step 3 in one, never in the other. Rollout
    0's recovery is the same: each rollout draws from its own seeded streams."""
    first_draws = {}
    for other_recovers in (True, False):
        stream = [[0.0, 0.0] for _ in range(40)]
        stream[6][0] = 1.0
        if other_recovers:
            stream[3][1] = 1.0
        policy = scripted_policy(stream, move=[0.0, 0.3, 0.0])
        cfg = RecoveryConfig(mode=mode, window=1, initial_interval=0, recovery_steps=10)
        controller = IntrospectiveController(
            policy,
            cfg,
            threshold=0.5,
            window=1,
            env_state_stats=IDENTITY_STATS,
            seed=3,
            embodiment=FETCH_EMBODIMENT,
        )
        actions = run_batch(controller, steps=20, seeds=(0, 1))
        events = controller.traces[-1].events
        assert [e["step"] for e in events[0]] == [6] and len(events[1]) == int(other_recovers)
        first_draws[other_recovers] = (actions[:, 0], events[0])
    np.testing.assert_array_equal(first_draws[True][0], first_draws[False][0])
    assert first_draws[True][1] == first_draws[False][1]


def test_mode_none_records_but_never_recovers() -> None:
    policy = scripted_policy([5.0], move=[0.1, 0.0, 0.0])
    controller = IntrospectiveController(
        policy,
        RecoveryConfig(mode="none"),
        threshold=0.1,
        window=20,
        env_state_stats=IDENTITY_STATS,
        embodiment=FETCH_EMBODIMENT,
    )
    run_episode(controller, steps=25)
    trace = controller.traces[-1]
    assert trace.events == [[]] and len(trace.uncertainty) == 25
    np.testing.assert_allclose(trace.window_sum[-1], [100.0])  # 20 steps x 5.0, nothing cleared


def test_min_unc_without_foresight_head_names_the_command() -> None:
    policy = BVMCPolicy(make_config(BVMCConfig, num_samples=4))
    with pytest.raises(ValueError, match="lerobot-ivmc-foresight"):
        IntrospectiveController(
            policy, RecoveryConfig(mode="min_unc"), 1.0, 20, IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
        )
    with pytest.raises(ValueError, match="recovery.mode"):
        RecoveryConfig(mode="pray")


@pytest.mark.parametrize("max_recoveries, expected", [(0, 4), (1, 1)])
def test_max_recoveries_limits_an_episodes_recoveries(max_recoveries: int, expected: int) -> None:
    """The policy stays uncertain at every step: without a limit retry fires again after each backoff (T = 2,
    4, 8, 16: steps 3, 8, 17 and 34), with `--recovery.max_recoveries=1` once, and the policy acts from then
    on."""
    policy = scripted_policy([1.0], move=[0.0, 0.3, 0.0])
    cfg = RecoveryConfig(mode="retry", window=1, initial_interval=2, max_recoveries=max_recoveries)
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    run_episode(controller, steps=40)
    assert len(controller.traces[-1].events[0]) == expected
    with pytest.raises(ValueError, match="max_recoveries must be >= 0"):
        RecoveryConfig(mode="retry", max_recoveries=-1)


@pytest.mark.parametrize("commit_sample", [False, True])
def test_retry_hands_back_to_the_mean_or_to_one_committed_posterior_sample(commit_sample: bool) -> None:
    """After its return to the start, retry's rollout acts with the Monte Carlo mean, or with
    `commit_sample` with the head under the one set of dropout masks drawn at the trigger, every step."""
    from lerobot_ivmc.policies.bvmc.modeling_bvmc import mean_action
    from lerobot_ivmc.recovery.manoeuvres import RETRY
    from lerobot_ivmc.recovery.strategy_settings import RetrySettings

    move = [0.0, 0.3, 0.0]
    policy = scripted_policy([0.0] * 5 + [1.0] + [0.0] * 100, move=move)
    embeddings, sample = [], policy.sample
    policy.sample = lambda *args, **kwargs: embeddings.append(sample(*args, **kwargs)) or embeddings[-1]
    retry = RetrySettings(steps=20, commit_sample=commit_sample)
    cfg = RecoveryConfig(mode="retry", window=1, initial_interval=0, retry=retry)
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    _, actions = run_episode(controller, steps=40)
    actions = np.array(actions)
    returning = np.flatnonzero(np.stack(controller.traces[-1].phase)[:, 0] == RETRY)
    after = np.arange(returning[-1] + 1, 40)
    assert returning[0] == 5 and len(after) >= 10
    np.testing.assert_allclose(actions[:5, :3], [move] * 5)  # the mean until the trigger
    if not commit_sample:
        np.testing.assert_allclose(actions[after, :3], [move] * len(after))
        return
    noise = controller.strategy.committed[0]
    for t in after:
        with torch.no_grad():
            delta_ee, gripper_values = policy.sample_head(embeddings[t].embedding, 1, noise)
        expected = mean_action(delta_ee, gripper_values, policy.config.gripper)[0].numpy()
        np.testing.assert_allclose(actions[t], expected, atol=1e-6)
    assert not np.allclose(actions[after, :3], [move] * len(after))


def test_retry_commit_sample_is_refused_for_a_policy_that_draws_no_masks() -> None:
    from lerobot_ivmc.recovery.strategy_settings import RetrySettings

    policy = scripted_policy([0.0], move=[0.0, 0.0, 0.0])
    policy.mc_sampling = False
    cfg = RecoveryConfig(mode="retry", retry=RetrySettings(commit_sample=True))
    with pytest.raises(ValueError, match="mc_sampling=false"):
        IntrospectiveController(
            policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
        )


def test_a_deadline_retries_a_rollout_whose_uncertainty_never_crosses_c() -> None:
    from lerobot_ivmc.recovery.manoeuvres import RETRY

    policy = scripted_policy([0.0] * 100, move=[0.0, 0.3, 0.0])
    cfg = RecoveryConfig(mode="retry", window=1, initial_interval=0, deadline=8)
    controller = IntrospectiveController(
        policy, cfg, threshold=0.5, window=1, env_state_stats=IDENTITY_STATS, embodiment=FETCH_EMBODIMENT
    )
    run_episode(controller, steps=30)
    phases = np.stack(controller.traces[-1].phase)[:, 0]
    events = [event["step"] for event in controller.traces[-1].events[0]]
    first_return_end = 7 + int(np.argmax(phases[7:] != RETRY))  # the policy's first step after the return
    # The eighth normal step fires; the fresh policy's eighth step after the return fires again.
    assert events[0] == 7 and events[1] == first_return_end + 7
