"""The model card LeRobot's `push_model_to_hub` writes names the paper, the task and a bvmc's threshold."""

from __future__ import annotations

from helpers.policies import THRESHOLD_RECORD, make_config
from huggingface_hub import ModelCard

from lerobot_ivmc.policies import BVMCConfig, VMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy
from lerobot_ivmc.policies.vmc.modeling_vmc import VMCPolicy


def test_the_model_card_names_the_paper_the_task_and_the_threshold(monkeypatch) -> None:
    monkeypatch.setattr(ModelCard, "validate", lambda self, *a, **k: None)  # (asks huggingface.co)
    policy = BVMCPolicy(make_config(BVMCConfig, num_samples=8, trained_task="pick_place"))
    card = str(policy.generate_model_card("local/ivmc_pick_place", "bvmc", None, None))
    assert "library_name: lerobot" in card  # LeRobot's own template, then ours
    assert "Introspective Visuomotor Control" in card and "arXiv:2103.11881" in card
    assert "pick_place demos" in card and "No recovery threshold yet" in card
    policy.threshold_record = THRESHOLD_RECORD
    card = str(policy.generate_model_card("local/ivmc_pick_place", "bvmc", None, None))
    assert "Recovery threshold C = 2.5 (argmax, window 20) picked on 1 val episodes of pick_place" in card
    vmc_card = str(VMCPolicy(make_config(VMCConfig)).generate_model_card("local/x", "vmc", None, None))
    assert "a dataset not made by lerobot-ivmc-collect" in vmc_card and "threshold" not in vmc_card
