"""Each recovery strategy's settings are nested under `--recovery.<mode>.*`, validate themselves, are refused
for another mode, and the flat flags of earlier versions are refused with their replacements."""

from __future__ import annotations

import sys
from pathlib import Path

import draccus
import pytest

from lerobot_ivmc.recovery.config import RecoveryConfig
from lerobot_ivmc.recovery.strategy_settings import (
    STRATEGY_SETTINGS,
    AnchorSettings,
    MinUncSettings,
    ReachSettings,
    RetrySettings,
    renamed_flag,
)
from lerobot_ivmc.scripts import lerobot_ivmc_eval


def test_nested_flags_reach_each_strategy_s_settings() -> None:
    args = ["--mode=anchor", "--anchor.steps=5", "--anchor.object=frame", "--anchor.grasp_offset=[-0.07,0,0]"]
    anchor = draccus.parse(config_class=RecoveryConfig, args=args)
    assert anchor.anchor == AnchorSettings(steps=5, object="frame", grasp_offset=(-0.07, 0.0, 0.0))
    min_unc = draccus.parse(config_class=RecoveryConfig, args=["--mode=min_unc", "--min_unc.memory=reset"])
    assert min_unc.min_unc == MinUncSettings(memory="reset")
    retry = draccus.parse(config_class=RecoveryConfig, args=["--mode=retry", "--retry.steps=30"])
    assert retry.retry == RetrySettings(steps=30) and retry.anchor == AnchorSettings()


@pytest.mark.parametrize(
    ("mode", "settings"),
    [
        ("min_unc", MinUncSettings(choice="mean")),
        ("retry", RetrySettings(steps=10)),
        ("anchor", AnchorSettings(look_steps=2)),
        ("reach", ReachSettings(belief="now")),
    ],
)
def test_a_strategy_s_settings_are_refused_with_another_mode(mode: str, settings) -> None:
    assert getattr(RecoveryConfig(mode=mode, **{mode: settings}), mode) == settings
    for other in ("none", "rand", *(m for m in STRATEGY_SETTINGS if m != mode)):
        with pytest.raises(
            ValueError, match=rf"--recovery\.{mode}\.\* set the {mode} mode; .*--recovery\.mode={mode}"
        ):
            RecoveryConfig(mode=other, **{mode: settings})


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: MinUncSettings(memory="forget"), "--recovery.min_unc.memory must be one of"),
        (lambda: RetrySettings(steps=0), "--recovery.retry.steps must be >= 1"),
        (lambda: RetrySettings(start_radius=-0.1), "--recovery.retry.start_radius is metres"),
        (lambda: AnchorSettings(steps=0), "--recovery.anchor.steps must be >= 1"),
        (lambda: AnchorSettings(object="camera"), "--recovery.anchor.object must be one of"),
        (lambda: ReachSettings(hover=2.0), "--recovery.reach.hover is in metres"),
    ],
)
def test_each_strategy_s_settings_validate_themselves(make, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        make()


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("--recovery.anchor_steps=5", "--recovery.anchor.steps=5"),
        ("--recovery.anchor_grasp_offset=[-0.07,0,0]", "--recovery.anchor.grasp_offset=[-0.07,0,0]"),
        ("--recovery.min_unc_memory=reset", "--recovery.min_unc.memory=reset"),
        ("--recovery.min_unc_choice=mean", "--recovery.min_unc.choice=mean"),
        ("--recovery.retry_steps=30", "--recovery.retry.steps=30"),
    ],
)
def test_a_flat_flag_of_earlier_versions_is_refused_with_its_replacement(
    old: str, new: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    """`lerobot-ivmc-eval` ends with one line naming the nested flag, before it loads anything."""
    monkeypatch.setattr(
        sys, "argv", ["lerobot-ivmc-eval", f"--policy.path={tmp_path}", "--env.type=ivmc", old]
    )
    with pytest.raises(SystemExit) as refused:
        lerobot_ivmc_eval.main()
    err = capsys.readouterr().err
    assert refused.value.code == 2 and err.strip().splitlines() == [
        f"error: {old} is now {new}: each recovery mode's settings are nested under it."
    ]


def test_flags_that_kept_their_names_are_not_taken_for_renamed_ones() -> None:
    for arg in (
        "--recovery.mode=anchor",
        "--recovery.recovery_steps=5",
        "--recovery.candidate_noise=0.3",
        "--recovery.anchor.steps=5",
        "--recovery.min_unc.memory=reset",
        "--policy.anchor_steps=5",
    ):
        assert renamed_flag(arg) is None, arg


def test_a_deadline_needs_a_mode_to_fire_and_a_non_negative_age() -> None:
    assert RecoveryConfig(mode="retry", deadline=80).deadline == 80
    with pytest.raises(ValueError, match="deadline fires a recovery"):
        RecoveryConfig(mode="none", deadline=80)
    with pytest.raises(ValueError, match="deadline must be >= 0"):
        RecoveryConfig(mode="retry", deadline=-1)
