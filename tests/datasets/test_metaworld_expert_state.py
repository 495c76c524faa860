"""MetaWorld's door policies shift the handle position they parse from the state in place: the demos must
record the state as the env gave it, and demos recorded before the collector gave the policy a copy are
kept apart from new ones and from the auxiliary heads."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import metaworld.policies
import numpy as np
import pytest

import lerobot_ivmc.envs.metaworld as mw
from lerobot_ivmc.datasets import staging
from lerobot_ivmc.datasets.collect_config import CollectConfig
from lerobot_ivmc.datasets.collect_root import older_expert
from lerobot_ivmc.datasets.collection_record import collection_spec
from lerobot_ivmc.datasets.demo_suites import STATE_COPY_KEY
from lerobot_ivmc.datasets.metaworld_attempts import run_scripted_episode
from lerobot_ivmc.datasets.training_dataset import check_environment_state
from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv


def test_the_policies_listed_as_editing_their_state_are_those_that_do() -> None:
    """Every scripted policy LeRobot maps a task to, on random states: the ones that change the array they
    are given are exactly `STATE_EDITING_POLICIES` (what names the copy in a collection's spec)."""
    rng = np.random.default_rng(0)
    editing = set()
    for name in sorted(set(mw._lerobot_metaworld_config()["TASK_POLICY_MAPPING"].values())):
        policy = getattr(metaworld.policies, name)()
        for _ in range(10):
            state = rng.uniform(-0.3, 1.0, 39)
            before = state.copy()
            policy.get_action(state)
            if not np.array_equal(state, before):
                editing.add(name)
    assert editing == mw.STATE_EDITING_POLICIES


def test_door_open_demos_record_the_handle_where_the_env_has_it() -> None:
    """On door-open-v3 the state each demo step records is the env's (its handle where MuJoCo has it), not
    the scripted policy's shifted copy (5 cm off in x on every step it acted)."""
    assert mw.expert_edits_state("door-open-v3")
    env = SeededMetaworldEnv("door-open-v3", split="train", terminate_on_success=False)
    recorded, handle = [], []

    def on_step(observation: dict, action: np.ndarray) -> None:
        recorded.append(observation["environment_state"][4:7].copy())
        handle.append(env.object_position)

    run_scripted_episode(env, seed=3, episode_steps=20, action_noise=0.1, on_step=on_step)
    env.close()
    np.testing.assert_array_equal(np.stack(recorded), np.stack(handle))


def test_door_demos_recorded_before_the_copy_are_kept_apart(tmp_path: Path) -> None:
    """A door-open-v3 collection names the copy in its spec (push-v3's spec is unchanged, so its datasets
    still resume); one without it is refused on resume and for training the auxiliary heads, with what to
    do."""

    def spec(task: str) -> dict:
        return CollectConfig(task=task, num_episodes=1, root=tmp_path / task, action_noise=0.1).spec()

    assert spec("door-open-v3")[STATE_COPY_KEY] is True and STATE_COPY_KEY not in spec("push-v3")
    assert older_expert(spec("door-open-v3")) is None and older_expert(spec("push-v3")) is None
    old = {key: value for key, value in spec("door-open-v3").items() if key != STATE_COPY_KEY}
    assert "edited it in place" in older_expert(old)

    root = tmp_path / "old"
    (root / staging.COLLECTION_INFO_PATH).parent.mkdir(parents=True)
    staging.write_json(root / staging.COLLECTION_INFO_PATH, {"spec": old, "num_episodes": 1})
    with pytest.raises(ValueError, match="edited it in place.*Collect the demos again.*new --dataset.root"):
        check_environment_state(SimpleNamespace(aux_state_indices=None), collection_spec(root), root)
    # a policy without auxiliary heads trains on them
    check_environment_state(SimpleNamespace(), collection_spec(root), root)
    staging.write_json(root / staging.COLLECTION_INFO_PATH, {"spec": spec("door-open-v3"), "num_episodes": 1})
    check_environment_state(SimpleNamespace(aux_state_indices=None), collection_spec(root), root)
