"""VMC and Bayesian VMC as LeRobot policies: registration, training loss, MC inference, memory, errors."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import torch
from helpers.policies import IMAGE_KEY, make_batch, make_config, observation_batch
from lerobot.configs.types import NormalizationMode
from lerobot.policies.factory import get_policy_class, make_pre_post_processors
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.policies import BVMCConfig, BVMCPolicy, VMCConfig, VMCPolicy
from lerobot_ivmc.policies.vmc.network import random_shift


def make_policy(cls: type[VMCPolicy] = BVMCPolicy, **kwargs) -> VMCPolicy:
    config = make_config(cls.config_class, **kwargs)
    return cls(config)


def test_plugin_discovery_resolves_both_types() -> None:
    """A fresh interpreter: only LeRobot's discovery (as lerobot-train calls it) imports the plugin."""
    code = (
        "from lerobot.utils.import_utils import register_third_party_plugins\n"
        "from lerobot.configs.policies import PreTrainedConfig\n"
        "from lerobot.policies.factory import get_policy_class\n"
        "register_third_party_plugins()\n"
        "for name in ('vmc', 'bvmc'):\n"
        "    print(PreTrainedConfig.get_choice_class(name).__name__, get_policy_class(name).__name__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["VMCConfig", "VMCPolicy", "BVMCConfig", "BVMCPolicy"]
    assert get_policy_class("bvmc") is BVMCPolicy


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_processors_come_from_the_factory_and_leave_the_gripper_alone(cls: type[VMCPolicy]) -> None:
    config = make_config(cls.config_class)
    stats = {
        OBS_STATE: {"mean": torch.full((9,), 2.0), "std": torch.full((9,), 4.0)},
        OBS_ENV_STATE: {"mean": torch.zeros(6), "std": torch.ones(6)},
        ACTION: {"mean": torch.full((4,), 0.5), "std": torch.full((4,), 3.0)},
        IMAGE_KEY: {"mean": torch.zeros(3, 1, 1), "std": torch.ones(3, 1, 1)},
    }
    pre, post = make_pre_post_processors(config, dataset_stats=stats)
    batch = make_batch(2)
    out = pre(dict(batch))
    assert torch.allclose(out[OBS_STATE], (batch[OBS_STATE] - 2.0) / 4.0, atol=1e-5)
    assert torch.equal(out[ACTION], batch[ACTION]), "the action (gripper label) must pass untouched"
    assert torch.equal(out[IMAGE_KEY], batch[IMAGE_KEY]), "images stay in [0, 1]"
    action = torch.tensor([[0.3, -0.2, 0.1, -1.0]])
    assert torch.equal(post(action), action)


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
@pytest.mark.parametrize("num_fc_layers", [1, 2])
def test_forward_gives_a_finite_loss_and_leaves_the_batch_untouched(
    cls: type[VMCPolicy], num_fc_layers: int
) -> None:
    policy = make_policy(cls, num_fc_layers=num_fc_layers)
    batch = make_batch(4)
    copy = {k: v.clone() for k, v in batch.items()}
    loss, info = policy.forward(batch)
    loss.backward()
    assert torch.isfinite(loss)
    assert {"loss_delta_ee", "loss_gripper", "loss_ee_pos", "loss_obj_pos"} <= set(info)
    assert all(isinstance(v, float) for v in info.values())
    assert all(torch.equal(batch[k], copy[k]) for k in batch)
    # single frames (no K axis) work too
    single = make_batch(3, k=None)
    assert torch.isfinite(policy.forward(single)[0])


@pytest.mark.parametrize("rollout_memory", ["window", "trajectory"])
def test_padded_window_equals_a_rollout_from_reset(rollout_memory: str) -> None:
    """Training on a window padded at the episode start sees what the rollout sees after reset()."""
    policy = make_policy(VMCPolicy, rollout_memory=rollout_memory)
    batch = make_batch(1, k=4)
    batch[f"{OBS_STATE}_is_pad"] = torch.tensor([[True, True, False, False]])
    s = policy.net.encode(batch[IMAGE_KEY][0], batch[OBS_STATE][0])[None]
    e_train = policy.net.unroll(s, batch[f"{OBS_STATE}_is_pad"])
    policy.reset()
    for k in (2, 3):
        e_roll = policy.step_embedding({IMAGE_KEY: batch[IMAGE_KEY][:, k], OBS_STATE: batch[OBS_STATE][:, k]})
    torch.testing.assert_close(e_train, e_roll)


def test_window_rollout_memory_sees_exactly_the_training_window() -> None:
    """With rollout_memory="window", step t's embedding is training's embedding of frames t-K+1..t."""
    policy = make_policy(VMCPolicy, rollout_memory="window")
    frames = make_batch(1, k=6, seed=3)
    s = policy.net.encode(frames[IMAGE_KEY][0], frames[OBS_STATE][0])[None]
    policy.reset()
    for t in range(6):
        e_roll = policy.step_embedding(
            {IMAGE_KEY: frames[IMAGE_KEY][:, t], OBS_STATE: frames[OBS_STATE][:, t]}
        )
        e_train = policy.net.unroll(s[:, max(0, t - 3) : t + 1])
        torch.testing.assert_close(e_roll, e_train)
    frames, is_pad = policy.get_memory()
    assert frames.shape[1] == 4 and not is_pad.any()
    with pytest.raises(ValueError, match="rollout_memory"):
        make_config(VMCConfig, rollout_memory="episode")


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_select_action_is_lerobot_compatible(cls: type[VMCPolicy]) -> None:
    policy = make_policy(cls)
    obs = observation_batch(3)
    copy = {k: v.clone() for k, v in obs.items()}
    policy.train()
    action = policy.select_action(obs)
    assert not policy.training
    assert action.shape == (3, 4)
    assert set(action[:, 3].tolist()) <= {-1.0, 0.0, 1.0}
    assert all(torch.equal(obs[k], copy[k]) for k in obs)
    assert policy.predict_action_chunk(obs).shape == (3, 1, 4)


def test_mc_samples_vary_while_vmc_does_not() -> None:
    torch.manual_seed(0)
    obs = observation_batch(2)
    bvmc = make_policy(BVMCPolicy, dropout_init=0.3)
    bvmc.eval()  # sampling is switched by `mc_sampling`, not by the train/eval mode
    pred = bvmc.sample(obs)
    assert pred.delta_ee_samples.shape == (2, 50, 3) and pred.samples.shape == (2, 50, 4)
    assert pred.gripper_values.shape == (2, 50, 3) and pred.embedding.shape == (2, bvmc.config.lstm_dim)
    assert (pred.delta_ee_samples.std(dim=1) > 1e-4).all()
    assert (pred.uncertainty > 0).all()
    torch.testing.assert_close(pred.mean_action[:, :3], pred.delta_ee_samples.mean(dim=1))
    # Without the flag the head is deterministic.
    bvmc.mc_sampling = False
    flat = bvmc.sample(obs)
    assert torch.equal(flat.uncertainty, torch.zeros(2))
    # VMC: repeated steps from the same memory give identical actions.
    vmc = make_policy(VMCPolicy)
    memory = vmc.get_memory()
    first = vmc.select_action(obs)
    vmc.set_memory(memory)
    assert torch.equal(vmc.select_action(obs), first)


def test_training_draws_masks_even_in_eval_mode() -> None:
    policy = make_policy(BVMCPolicy, dropout_init=0.3, image_shift_pad=0)  # only the masks are random
    policy.eval()
    batch = make_batch(4)
    assert policy.forward(batch)[0].item() != policy.forward(batch)[0].item()


@pytest.mark.parametrize("num_fc_layers", [1, 2])
def test_batched_head_equals_separate_full_passes_with_the_same_masks(num_fc_layers: int) -> None:
    torch.manual_seed(0)
    policy = make_policy(BVMCPolicy, num_fc_layers=num_fc_layers, dropout_init=0.3)
    policy.step_embedding(observation_batch(2, seed=1))  # some history in the memory
    obs, num_samples = observation_batch(2, seed=2), 8
    noise = policy.draw_noise(2, num_samples)
    memory = policy.get_memory()
    batched = policy.sample(obs, num_samples, noise=noise)
    memory_after = policy.get_memory()
    deltas, probs = [], []
    for i in range(num_samples):
        policy.set_memory(memory)
        embedding = policy.step_embedding(obs)  # CNN + LSTM + head: a full pass per sample
        d, p = policy.sample_head(embedding, 1, noise=[n[:, i : i + 1] for n in noise])
        deltas.append(d)
        probs.append(p)
    torch.testing.assert_close(batched.delta_ee_samples, torch.cat(deltas, dim=1))
    torch.testing.assert_close(batched.gripper_values, torch.cat(probs, dim=1))
    torch.testing.assert_close(policy.get_memory(), memory_after)


@pytest.mark.parametrize("rollout_memory", ["window", "trajectory"])
def test_memory_save_restore_reproduces_outputs_exactly(rollout_memory: str) -> None:
    policy = make_policy(BVMCPolicy, rollout_memory=rollout_memory)
    for seed in range(3):
        policy.sample(observation_batch(1, seed=seed))
    memory = policy.get_memory()
    obs = observation_batch(1, seed=10)
    noise = policy.draw_noise(1, 50)
    first = policy.sample(obs, noise=noise)
    policy.sample(observation_batch(1, seed=11))  # move on, then back-track
    policy.set_memory(memory)
    again = policy.sample(obs, noise=noise)
    assert torch.equal(first.delta_ee_samples, again.delta_ee_samples)
    assert torch.equal(first.uncertainty, again.uncertainty)
    assert torch.equal(first.embedding, again.embedding)
    # reset() clears the memory: the next step equals a fresh start.
    policy.reset()
    assert policy.get_memory() is None
    fresh = policy.sample(obs, noise=noise)
    policy.reset()
    assert torch.equal(policy.sample(obs, noise=noise).embedding, fresh.embedding)


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_save_and_load_round_trip(cls: type[VMCPolicy], tmp_path: Path) -> None:
    policy = make_policy(cls, num_fc_layers=2, **({"dataset_size": 1234} if cls is BVMCPolicy else {}))
    policy.save_pretrained(tmp_path)
    loaded = cls.from_pretrained(tmp_path)
    assert loaded.config == policy.config
    for key, value in policy.state_dict().items():
        assert torch.equal(value, loaded.state_dict()[key])
    loaded.mc_sampling = policy.mc_sampling = False
    obs = observation_batch(2)
    assert torch.equal(policy.select_action(obs), loaded.select_action(obs))


def feature_without(key: str) -> dict:
    config = make_config(VMCConfig)
    inputs = {k: v for k, v in config.input_features.items() if k != key}
    return {"input_features": inputs, "output_features": config.output_features}


@pytest.mark.parametrize(("missing", "match"), [(IMAGE_KEY, "RGB camera"), (OBS_STATE, "observation.state")])
@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_missing_features_give_clear_errors(cls: type[VMCPolicy], missing: str, match: str) -> None:
    config = cls.config_class(device="cpu", **feature_without(missing))
    with pytest.raises(ValueError, match=match):
        cls(config)


@pytest.mark.parametrize("cls", [VMCPolicy, BVMCPolicy])
def test_without_environment_state_the_auxiliary_heads_are_off_and_asking_for_them_is_refused(
    cls: type[VMCPolicy],
) -> None:
    policy = cls(cls.config_class(device="cpu", **feature_without(OBS_ENV_STATE)))  # heads by default
    assert not policy.config.goal_head and not policy.config.frame_position_head
    assert policy.net.decode(torch.zeros(1, policy.config.lstm_dim), stochastic=False)[2] is None
    windowed = cls(cls.config_class(device="cpu", training_mode="window", **feature_without(OBS_ENV_STATE)))
    loss, info = windowed.forward({k: v for k, v in make_batch(4).items() if k != OBS_ENV_STATE})
    assert torch.isfinite(loss) and "loss_obj_pos" not in info and "loss_delta_ee" in info
    for flag, match in (
        ({"goal_head": True}, "goal_head=true needs auxiliary targets"),
        ({"frame_position_head": True}, "frame_position_head=true needs auxiliary targets"),
        ({"aux_state_indices": [0, 1, 2, 3, 4, 5]}, "aux_state_indices needs"),
    ):
        with pytest.raises(ValueError, match=match):
            cls(cls.config_class(device="cpu", **flag, **feature_without(OBS_ENV_STATE)))


def test_bad_config_values_are_refused() -> None:
    with pytest.raises(ValueError, match="num_fc_layers"):
        BVMCConfig(device="cpu", num_fc_layers=3)
    with pytest.raises(ValueError, match="num_fc_layers"):
        VMCConfig(device="cpu", num_fc_layers=0)
    with pytest.raises(ValueError, match="num_samples"):
        BVMCConfig(device="cpu", num_samples=1)
    with pytest.raises(ValueError, match="IDENTITY"):
        VMCConfig(device="cpu", normalization_mapping={"ACTION": NormalizationMode.MEAN_STD})
    with pytest.raises(ValueError, match="scheduler_decay_steps"):
        VMCConfig(device="cpu", scheduler_decay_steps=-1)
    policy = make_policy(BVMCPolicy)
    with pytest.raises(ValueError, match="at least 2 samples"):
        policy.sample(observation_batch(1), num_samples=1)
    with pytest.raises(ValueError, match="one frame per step"):
        policy.select_action(make_batch(1, k=4))


def test_learning_rate_warms_up_then_decays_over_the_whole_run() -> None:
    config = make_config(VMCConfig, optimizer_lr=1e-3, scheduler_decay_lr=1e-5)
    steps = 2_000  # shorter than scheduler_decay_steps: LeRobot fits warm-up and decay into the run
    optimizer = torch.optim.Adam([torch.nn.Parameter(torch.zeros(1))], lr=config.optimizer_lr)
    scheduler = config.get_scheduler_preset().build(optimizer, steps)
    lrs = []
    for _ in range(steps + 1):
        lrs.append(optimizer.param_groups[0]["lr"])
        optimizer.step()
        scheduler.step()
    peak = max(lrs)
    assert lrs[0] < 0.1 * peak and peak == pytest.approx(1e-3, rel=1e-3)
    assert lrs[steps // 2] < peak and lrs[-1] == pytest.approx(1e-5, rel=1e-3)
    assert make_config(VMCConfig, scheduler_decay_steps=0).get_scheduler_preset() is None


def test_random_shift_moves_each_window_rigidly_within_the_pad() -> None:
    torch.manual_seed(0)
    images = torch.rand(16, 4, 3, 12, 10)
    shifted = random_shift(images, pad=2)
    assert shifted.shape == images.shape
    assert torch.equal(random_shift(images, pad=0), images)
    padded = torch.nn.functional.pad(images.flatten(1, 2), (2, 2, 2, 2), mode="replicate")
    padded = padded.unflatten(1, (4, 3))
    moved = 0
    for b in range(16):
        # Exactly one offset (dy, dx) in [-2, 2]^2 explains all K frames of the window.
        matches = [
            (dy, dx)
            for dy in range(5)
            for dx in range(5)
            if torch.equal(shifted[b], padded[b, :, :, dy : dy + 12, dx : dx + 10])
        ]
        assert matches, f"sample {b} is not a shifted crop of its padded frames"
        moved += matches[0] != (2, 2)
    assert moved > 8, "offsets must vary across samples"


def test_training_loss_augments_the_frames_unless_disabled() -> None:
    batch = make_batch(4)
    for pad, differs in [(4, True), (0, False)]:
        policy = make_policy(VMCPolicy, image_shift_pad=pad)
        torch.manual_seed(0)
        first = policy.forward(batch)[0].item()
        second = policy.forward(batch)[0].item()
        assert (first != second) is differs
    with pytest.raises(ValueError, match="image_shift_pad"):
        make_config(VMCConfig, image_shift_pad=-1)


def test_per_row_generators_give_each_row_its_own_noise() -> None:
    """`draw_noise` with one generator a row: row b is what its generator draws alone, whatever the batch."""
    policy = make_policy(BVMCPolicy, num_fc_layers=2)
    pair = policy.draw_noise(2, 8, [torch.Generator().manual_seed(s) for s in (3, 4)])
    alone = policy.draw_noise(1, 8, [torch.Generator().manual_seed(4)])
    assert all(torch.equal(p[1:], a) for p, a in zip(pair, alone, strict=True))
    assert [tuple(n.shape) for n in pair] == [(2, *s[1:]) for s in policy.net.head.noise_shapes(1, 8)]
    with pytest.raises(ValueError, match="one generator per row: 1 for 2"):
        policy.draw_noise(2, 8, [torch.Generator()])
