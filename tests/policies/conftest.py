"""Fixtures for the policy tests."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers.policies import build_expert_dataset


@pytest.fixture(scope="session")
def tiny_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Root of a 2-episode, 30-frame-per-episode pick_place dataset at 64x64."""
    return build_expert_dataset(tmp_path_factory.mktemp("data") / "ivmc_pick_place_tiny")
