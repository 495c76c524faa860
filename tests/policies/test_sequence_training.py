"""Sequence training: chunks of demo frames, the LSTM memory carried over the chunk as at rollout."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest
import torch
from helpers.policies import IMAGE_KEY, STATE_DIM, TINY_REPO_ID, make_config
from lerobot.datasets.factory import resolve_delta_timestamps
from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata
from lerobot.policies.factory import get_policy_class, make_policy_config
from lerobot.utils.constants import ACTION, OBS_ENV_STATE, OBS_STATE

from lerobot_ivmc.datasets.frame_cache import FrameCache
from lerobot_ivmc.policies import BVMCPolicy, VMCConfig, VMCPolicy
from lerobot_ivmc.policies.vmc.losses import supervised_losses


def chunk_batch(batch_size: int = 3, length: int = 12, seed: int = 0) -> dict[str, torch.Tensor]:
    """Chunks as LeRobot gives them for forward delta indices; chunk 1 ends its episode after 8 frames."""
    g = torch.Generator().manual_seed(seed)
    lead = (batch_size, length)
    batch = {
        IMAGE_KEY: torch.rand(*lead, 3, 64, 64, generator=g),
        OBS_STATE: torch.randn(*lead, STATE_DIM, generator=g),
        OBS_ENV_STATE: torch.randn(*lead, 6, generator=g),
        ACTION: torch.cat(
            [torch.rand(*lead, 3, generator=g) * 2 - 1, torch.randint(-1, 2, (*lead, 1), generator=g)], dim=-1
        ),
    }
    is_pad = torch.zeros(lead, dtype=torch.bool)
    is_pad[1, 8:] = True
    batch[f"{ACTION}_is_pad"] = is_pad
    batch[f"{OBS_STATE}_is_pad"] = is_pad.clone()
    # Each chunk starts its own episode (as LeRobot gives the first frame's dataset index).
    batch["episode_index"] = torch.arange(batch_size)
    batch["index"] = batch["episode_index"] * 1000
    return batch


def rollout_outputs(policy: VMCPolicy, batch: dict[str, torch.Tensor]) -> list[torch.Tensor]:
    """The four decoded outputs, each (B, T, ...), of a step-by-step rollout from `reset()` with carried
    memory over the batch's T frames."""
    policy.reset()
    steps = []
    with torch.no_grad():
        for t in range(batch[IMAGE_KEY].shape[1]):
            obs = {IMAGE_KEY: batch[IMAGE_KEY][:, t], OBS_STATE: batch[OBS_STATE][:, t]}
            steps.append(policy.net.decode(policy.step_embedding(obs), stochastic=False))
    return [torch.stack([step[i] for step in steps], dim=1) for i in range(4)]


def sequence_policy(cls: type[VMCPolicy] = VMCPolicy, **kwargs) -> VMCPolicy:
    torch.manual_seed(0)
    return cls(make_config(cls.config_class, **{"training_mode": "sequence", "chunk_length": 12, **kwargs}))


def test_sequence_config_asks_lerobot_for_chunks_and_rolls_out_with_carried_memory() -> None:
    config = make_config(VMCConfig, training_mode="sequence", chunk_length=5)
    assert config.observation_delta_indices == [0, 1, 2, 3, 4]
    assert config.action_delta_indices == [0, 1, 2, 3, 4]
    assert config.rollout_memory == "trajectory"
    window = make_config(VMCConfig)
    assert window.observation_delta_indices == [-3, -2, -1, 0] and window.action_delta_indices is None
    assert window.rollout_memory == "window"
    assert (
        make_config(VMCConfig, training_mode="sequence", rollout_memory="window").rollout_memory == "window"
    )


def test_chunk_frames_go_through_the_cnn_once_each_and_padding_never() -> None:
    policy = sequence_policy(BVMCPolicy)
    encoded: list[int] = []
    policy.net.cnn.register_forward_hook(lambda module, args, out: encoded.append(args[0].shape[0]))
    batch = chunk_batch()
    loss, info = policy.forward(batch)
    real = int((~batch[f"{ACTION}_is_pad"]).sum())
    assert encoded == [real] == [3 * 12 - 4]
    assert info["supervised_steps"] == real
    loss.backward()
    assert all(p.grad is not None for p in policy.net.cnn.parameters())


def test_chunk_loss_equals_a_step_by_step_rollout_from_reset_with_carried_memory() -> None:
    policy = sequence_policy(image_shift_pad=0)
    batch = chunk_batch()
    loss, _ = policy.forward(batch)

    real = ~batch[f"{ACTION}_is_pad"]
    outputs = [output[real] for output in rollout_outputs(policy, batch)]
    expected = sum(supervised_losses(outputs, batch[ACTION][real], batch[OBS_ENV_STATE][real]).values())
    torch.testing.assert_close(loss.detach(), expected, rtol=1e-5, atol=1e-6)


def episode_chunks(length: int = 6, seed: int = 0) -> tuple[dict[str, torch.Tensor], ...]:
    """Two episodes of 2 * `length` frames (absolute indices 0.. and 2 * length..), cut into two chunks
    each: the batch of both first chunks, then the batch of both second chunks (LeRobot's `index` is the
    absolute index of a chunk's first frame)."""
    whole = chunk_batch(batch_size=2, length=2 * length, seed=seed)
    for key in (f"{ACTION}_is_pad", f"{OBS_STATE}_is_pad", "index", "episode_index"):
        del whole[key]
    first, second = (
        {k: v[:, part] for k, v in whole.items()} for part in (slice(0, length), slice(length, None))
    )
    episodes = torch.tensor([0, 1])
    first.update(index=torch.tensor([0, 2 * length]), episode_index=episodes)
    second.update(index=torch.tensor([length, 3 * length]), episode_index=episodes)
    return whole, first, second


def rollout_loss(policy: VMCPolicy, whole: dict[str, torch.Tensor], frames: slice) -> torch.Tensor:
    """The supervised loss on `frames` of a step-by-step rollout from `reset()` over the whole episodes."""
    outputs = [output[:, frames].flatten(0, 1) for output in rollout_outputs(policy, whole)]
    labels = (whole[ACTION][:, frames].flatten(0, 1), whole[OBS_ENV_STATE][:, frames].flatten(0, 1))
    return sum(supervised_losses(outputs, *labels).values())


def test_a_chunk_mid_episode_starts_from_the_stored_state_of_the_frame_before_it() -> None:
    """Truncated back-propagation with stored states: the second half of each episode, trained after the
    first, has the same loss as a rollout carried from the episode's start; from zero memory it does not."""
    whole, first, second = episode_chunks()
    policy = sequence_policy(image_shift_pad=0, chunk_length=6)
    assert policy.config.chunk_memory == "stored"
    policy.forward(first)
    loss, _ = policy.forward(second)
    loss.backward()
    expected = rollout_loss(policy, whole, slice(6, None))
    torch.testing.assert_close(loss.detach(), expected, rtol=1e-5, atol=1e-6)
    assert len(policy.stored_states) == 2 * 12

    zero = sequence_policy(image_shift_pad=0, chunk_length=6, chunk_memory="zero")
    zero.forward(first)
    zero_loss, _ = zero.forward(second)
    assert len(zero.stored_states) == 0
    assert not torch.allclose(zero_loss.detach(), expected, rtol=1e-5, atol=1e-6)


def test_stored_states_never_cross_episodes_and_stay_out_of_checkpoints(tmp_path: Path) -> None:
    """A chunk whose previous frame belongs to another episode, or was never trained on, starts from zero
    memory; the stored states are training state, not weights."""
    whole, first, second = episode_chunks()
    policy = sequence_policy(image_shift_pad=0, chunk_length=6)
    policy.forward(second)  # frames 6..11 of episode 0, 18..23 of episode 1: nothing stored before them
    zero = sequence_policy(image_shift_pad=0, chunk_length=6, chunk_memory="zero")
    torch.testing.assert_close(policy.forward(second)[0], zero.forward(second)[0])
    # Episode 1's first chunk starts at index 12, right after episode 0's last (stored) frame 11.
    start_of_episode_1 = {k: v[1:] for k, v in first.items()}
    torch.testing.assert_close(
        policy.forward(start_of_episode_1)[0],
        rollout_loss(policy, {k: v[1:] for k, v in whole.items()}, slice(0, 6)),
    )
    policy.save_pretrained(tmp_path)
    reloaded = VMCPolicy.from_pretrained(tmp_path)
    assert len(reloaded.stored_states) == 0
    assert set(reloaded.state_dict()) == set(zero.state_dict())


def test_lerobot_batches_carry_what_stored_chunk_memory_needs(tiny_dataset: Path) -> None:
    """Through LeRobot's own sampler, dataloader and preprocessor (as `lerobot-train` feeds the policy), the
    chunks' `index` and `episode_index` reach `forward`: one epoch stores a state for every frame."""
    from lerobot.datasets.sampler import EpisodeAwareSampler
    from lerobot.policies.factory import make_pre_post_processors

    config = make_config(VMCConfig, training_mode="sequence", chunk_length=10)
    meta = LeRobotDatasetMetadata(TINY_REPO_ID, root=tiny_dataset)
    dataset = FrameCache(
        LeRobotDataset(
            TINY_REPO_ID, root=tiny_dataset, delta_timestamps=resolve_delta_timestamps(config, meta)
        ),
        absolute_indices=True,
    )
    sampler = EpisodeAwareSampler(
        meta.episodes["dataset_from_index"],
        meta.episodes["dataset_to_index"],
        drop_n_last_frames=config.drop_n_last_frames,
        shuffle=True,
    )
    preprocessor, _ = make_pre_post_processors(config, dataset_stats=meta.stats)
    policy = VMCPolicy(config, dataset_meta=meta)
    with torch.no_grad():
        for batch in torch.utils.data.DataLoader(dataset, batch_size=8, sampler=sampler):
            policy.forward(preprocessor(batch))
    assert len(policy.stored_states) == meta.total_frames
    # Chunks of whole demos all start at an episode's start (zero memory): nothing is stored for them.
    whole = make_config(VMCConfig, training_mode="sequence", chunk_length=30)
    whole_policy = VMCPolicy(whole, dataset_meta=meta)
    whole_dataset = FrameCache(
        LeRobotDataset(
            TINY_REPO_ID, root=tiny_dataset, delta_timestamps=resolve_delta_timestamps(whole, meta)
        )
    )
    batch = torch.utils.data.default_collate([whole_dataset[0], whole_dataset[30]])
    with torch.no_grad():
        whole_policy.forward(make_pre_post_processors(whole, dataset_stats=meta.stats)[0](batch))
    assert len(whole_policy.stored_states) == 0


def test_bf16_autocast_trains_on_any_cpu_close_to_fp32() -> None:
    """`ACCELERATE_MIXED_PRECISION=bf16` autocasts the forward; CPUs without native bf16 have no bf16 LSTM
    kernel (oneDNN fails to build one): the fused LSTM then runs in fp32 and training still works."""
    policy = sequence_policy(BVMCPolicy, image_shift_pad=0)
    batch = chunk_batch()
    torch.manual_seed(1)
    fp32, _ = policy.forward(batch)
    torch.manual_seed(1)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        bf16, _ = policy.forward(batch)
    bf16.backward()
    assert torch.isfinite(bf16) and policy.net.lstm.weight_ih.grad is not None
    assert bf16.item() == pytest.approx(fp32.item(), rel=0.05)
    # Chunks that start mid-episode from stored states, under autocast too.
    _, first, second = episode_chunks()
    stored = sequence_policy(BVMCPolicy, image_shift_pad=0, chunk_length=6)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        stored.forward(first)
        loss, _ = stored.forward(second)
    loss.backward()
    assert torch.isfinite(loss) and len(stored.stored_states) == 24


def test_padded_frames_do_not_change_the_loss() -> None:
    policy = sequence_policy(image_shift_pad=0)
    batch = chunk_batch()
    other = {key: value.clone() for key, value in batch.items()}
    for key in (IMAGE_KEY, OBS_STATE, OBS_ENV_STATE, ACTION):
        other[key][1, 8:] = other[key][1, 8:] * 3 + 1  # padding past the episode's end
    torch.testing.assert_close(policy.forward(batch)[0], policy.forward(other)[0])


def test_chunks_from_the_dataset_stop_at_their_episode_end(tiny_dataset: Path) -> None:
    config = make_config(VMCConfig, training_mode="sequence", chunk_length=10, image_shift_pad=0)
    meta = LeRobotDatasetMetadata(TINY_REPO_ID, root=tiny_dataset)
    dataset = LeRobotDataset(
        TINY_REPO_ID, root=tiny_dataset, delta_timestamps=resolve_delta_timestamps(config, meta)
    )
    cached = FrameCache(dataset)
    last_of_first = int(meta.episodes["length"][0]) - 1
    item = cached[last_of_first - 4]  # five real frames left in episode 0
    assert item[f"{ACTION}_is_pad"].tolist() == [False] * 5 + [True] * 5
    # Past the end LeRobot repeats episode 0's last frame: nothing of episode 1 enters the chunk.
    last = cached[last_of_first]
    assert torch.equal(item[IMAGE_KEY][5:], last[IMAGE_KEY][:1].expand(5, -1, -1, -1))
    torch.testing.assert_close(item[IMAGE_KEY], dataset[last_of_first - 4][IMAGE_KEY])
    # The chunk that starts episode 1 starts from zero memory, whatever shares its batch: its outputs
    # alone equal its outputs batched after the end of episode 0.
    policy = VMCPolicy(config)
    first_of_second = cached[last_of_first + 1]
    alone = {k: v[None] for k, v in first_of_second.items() if isinstance(v, torch.Tensor)}
    pair = {k: torch.stack([item[k], first_of_second[k]]) for k in alone}
    with torch.no_grad():
        outputs_alone = policy._sequence_outputs(alone)[0]
        outputs_pair = policy._sequence_outputs(pair)[0]
        # Again, now that the state of episode 0's last frame is stored: it must not leak into episode 1.
        outputs_again = policy._sequence_outputs(pair)[0]
    assert len(policy.stored_states) == 5 + 10
    for single, batched, again in zip(outputs_alone, outputs_pair, outputs_again, strict=True):
        torch.testing.assert_close(batched[5:], single)  # 5 real frames of episode 0 come first
        torch.testing.assert_close(again[5:], single)


def test_bad_chunk_lengths_and_padding_are_refused(tiny_dataset: Path) -> None:
    with pytest.raises(ValueError, match="chunk_length must be >= 1"):
        make_config(VMCConfig, training_mode="sequence", chunk_length=0)
    with pytest.raises(ValueError, match="training_mode must be one of"):
        make_config(VMCConfig, training_mode="episodes")
    with pytest.raises(ValueError, match="chunk_memory must be one of"):
        make_config(VMCConfig, training_mode="sequence", chunk_memory="carried")
    meta = LeRobotDatasetMetadata(TINY_REPO_ID, root=tiny_dataset)
    with pytest.raises(ValueError, match=r"exceeds the shortest episode.*at most 30"):
        VMCPolicy(make_config(VMCConfig, training_mode="sequence", chunk_length=31), dataset_meta=meta)
    policy = sequence_policy()
    batch = chunk_batch()
    batch[f"{ACTION}_is_pad"][0, 0] = True  # padding before a real frame
    with pytest.raises(ValueError, match="padded only after their episode's end"):
        policy.forward(batch)
    with pytest.raises(ValueError, match="expects chunks"):
        policy.forward({k: v[:, 0] if v.dim() > 1 else v for k, v in chunk_batch().items()})
    # Stored chunk memory needs each chunk's dataset position, one per chunk.
    no_position = {k: v for k, v in chunk_batch().items() if k != "index"}
    with pytest.raises(ValueError, match="needs each chunk's dataset position.*chunk_memory=zero"):
        policy.forward(no_position)
    per_frame = chunk_batch()
    per_frame["index"] = per_frame["index"][:, None].expand(-1, 12)
    with pytest.raises(ValueError, match=r"one value per chunk \(3\)"):
        policy.forward(per_frame)
    assert sequence_policy(chunk_memory="zero").forward(no_position)[0].isfinite()


@pytest.mark.parametrize("name", ["vmc", "bvmc"])
def test_policy_init_annotates_config_with_the_config_class(name: str) -> None:
    """LeRobot's own policy-class check: the `config` annotation of `__init__` is the config class."""
    policy_cls = get_policy_class(name)
    config_cls = make_policy_config(name).__class__
    assert policy_cls.name == name
    assert issubclass(config_cls, inspect.signature(policy_cls.__init__).parameters["config"].annotation)


def test_lerobot_train_samples_chunks_only_where_they_fit(tiny_dataset: Path) -> None:
    """`lerobot-train` builds this sampler when the config has `drop_n_last_frames`: whole-episode chunks
    start at episode starts only, so every frame weighs the same; window training samples every frame."""
    from lerobot.datasets.sampler import EpisodeAwareSampler

    meta = LeRobotDatasetMetadata(TINY_REPO_ID, root=tiny_dataset)
    starts = list(meta.episodes["dataset_from_index"])
    for length, expected in ((30, starts), (25, [s + i for s in starts for i in range(6)])):
        config = make_config(VMCConfig, training_mode="sequence", chunk_length=length)
        sampler = EpisodeAwareSampler(
            meta.episodes["dataset_from_index"],
            meta.episodes["dataset_to_index"],
            drop_n_last_frames=config.drop_n_last_frames,
        )
        assert list(sampler) == expected
    assert not hasattr(make_config(VMCConfig, training_mode="window"), "drop_n_last_frames")


def test_goal_head_learns_the_object_position_at_each_demo_end() -> None:
    """The goal head's target is the object's position on the chunk's last real frame (chunk 1 ends after 8
    frames), the same on every frame of the chunk; the paper's four losses stay as they were."""
    batch = chunk_batch()
    policy = sequence_policy(image_shift_pad=0, goal_head=True)
    plain = sequence_policy(image_shift_pad=0)
    plain.load_state_dict({k: v for k, v in policy.state_dict().items() if "goal" not in k})
    _, info = policy.forward(batch)
    _, plain_info = plain.forward(batch)
    for name in ("loss_delta_ee", "loss_gripper", "loss_ee_pos", "loss_obj_pos"):
        assert info[name] == pytest.approx(plain_info[name], rel=1e-6)

    outputs, _, targets, _ = policy._sequence_outputs(batch)
    object_end = batch[OBS_ENV_STATE][:, [11, 7, 11], 3:].diagonal(dim1=0, dim2=1).T  # last real frames
    real = ~batch[f"{ACTION}_is_pad"]
    expected = object_end[:, None].expand(-1, 12, -1)[real]
    torch.testing.assert_close(targets[:, 6:], expected)
    assert info["loss_goal_pos"] == pytest.approx(
        torch.nn.functional.mse_loss(outputs[4], expected).item(), rel=1e-5
    )
    with torch.no_grad():  # acting never uses it: the same actions as the net without the head
        policy.reset(), plain.reset()
        obs = {IMAGE_KEY: batch[IMAGE_KEY][:, 0], OBS_STATE: batch[OBS_STATE][:, 0]}
        assert torch.equal(policy.select_action(obs), plain.select_action(obs))


@pytest.mark.parametrize(
    ("training_mode", "goal_head"), [("sequence", False), ("sequence", True), ("window", False)]
)
def test_frame_position_head_reads_positions_from_each_frames_cnn_map_alone(
    training_mode: str, goal_head: bool
) -> None:
    """Its losses are the MSE of a linear read-out of each real frame's CNN map against that frame's EE and
    object positions (with the goal head, also the object's at the chunk's end); they train the CNN, never
    the LSTM or the state path, and acting ignores it."""
    batch = chunk_batch()
    if training_mode == "window":  # 4-frame windows, the last frame's action the label
        batch = {k: v[:, :4] for k, v in batch.items() if k not in ("index", "episode_index")}
        batch[ACTION] = batch[ACTION][:, -1]
        del batch[f"{ACTION}_is_pad"], batch[f"{OBS_STATE}_is_pad"]
    kwargs = {"training_mode": training_mode, "image_shift_pad": 0, "goal_head": goal_head}
    policy = sequence_policy(frame_position_head=True, **kwargs)
    plain = sequence_policy(**kwargs)
    plain.load_state_dict({k: v for k, v in policy.state_dict().items() if "frame_position" not in k})
    loss, info = policy.forward(batch)
    _, plain_info = plain.forward(batch)
    for name in ("loss_delta_ee", "loss_gripper", "loss_ee_pos", "loss_obj_pos"):
        assert info[name] == pytest.approx(plain_info[name], rel=1e-6)

    real = torch.ones(batch[ACTION].shape[:2], dtype=torch.bool)
    if training_mode == "sequence":
        real = ~batch[f"{ACTION}_is_pad"]
    frames, aux = batch[IMAGE_KEY][real], batch[OBS_ENV_STATE][real]
    with torch.no_grad():
        read_out = policy.net.frame_position_decoder(policy.net.cnn(frames).flatten(1))
    mse = torch.nn.functional.mse_loss
    assert info["loss_frame_ee_pos"] == pytest.approx(mse(read_out[:, :3], aux[:, :3]).item(), rel=1e-5)
    assert info["loss_frame_obj_pos"] == pytest.approx(mse(read_out[:, 3:6], aux[:, 3:]).item(), rel=1e-5)
    if goal_head:  # chunk 1 ends after 8 frames, the others after 12
        object_end = batch[OBS_ENV_STATE][[0, 1, 2], [11, 7, 11], 3:]
        goal = object_end[:, None].expand(-1, 12, -1)[real]
        assert info["loss_frame_goal_pos"] == pytest.approx(mse(read_out[:, 6:], goal).item(), rel=1e-5)
    else:
        assert read_out.shape[1] == 6 and "loss_frame_goal_pos" not in info

    policy.zero_grad()
    _, _, _, (predicted, targets) = getattr(policy, f"_{training_mode}_outputs")(batch)
    mse(predicted, targets).backward()
    assert policy.net.cnn[0].weight.grad.abs().sum() > 0
    assert all(p.grad is None for p in policy.net.lstm.parameters())
    with torch.no_grad():  # acting never uses it
        policy.reset(), plain.reset()
        obs = {IMAGE_KEY: batch[IMAGE_KEY][:, 0], OBS_STATE: batch[OBS_STATE][:, 0]}
        assert torch.equal(policy.select_action(obs), plain.select_action(obs))


def test_goal_head_needs_whole_demo_chunks(tiny_dataset: Path) -> None:
    with pytest.raises(ValueError, match="goal_head needs whole demos.*training_mode=sequence"):
        make_config(VMCConfig, goal_head=True)
    meta = LeRobotDatasetMetadata(TINY_REPO_ID, root=tiny_dataset)
    with pytest.raises(ValueError, match=r"every chunk must be a whole demo.*chunk_length=30"):
        VMCPolicy(
            make_config(VMCConfig, training_mode="sequence", chunk_length=20, goal_head=True),
            dataset_meta=meta,
        )
    config = make_config(VMCConfig, training_mode="sequence", chunk_length=30, goal_head=True)
    assert VMCPolicy(config, dataset_meta=meta).net.goal_decoder is not None
