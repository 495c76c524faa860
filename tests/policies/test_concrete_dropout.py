"""Concrete dropout: masks, the regulariser, and learning the dropout probability."""

from __future__ import annotations

import logging
import math
from types import SimpleNamespace

import pytest
import torch
from helpers.policies import make_batch, make_config

from lerobot_ivmc.policies import BVMCPolicy
from lerobot_ivmc.policies.bvmc.concrete_dropout import ConcreteDropout, ConcreteDropoutHead


def test_initial_probability_and_identity_without_sampling() -> None:
    layer = ConcreteDropout(16, init_p=0.1)
    assert layer.p.item() == pytest.approx(0.1)
    x = torch.randn(4, 16)
    assert torch.equal(layer(x, stochastic=False), x)


def test_masks_are_per_element_nearly_binary_and_unbiased() -> None:
    torch.manual_seed(0)
    layer = ConcreteDropout(64, init_p=0.3, temperature=0.1)
    x = torch.ones(2000, 64)
    y = layer(x, stochastic=True)
    keep = y * (1 - 0.3)  # the relaxed keep mask
    # Elements differ within a row (not one shared scalar mask, the reference notebook's pitfall).
    assert keep[0].std() > 0.1
    # Temperature 0.1: most masks are close to 0 or 1, and the drop rate is about p.
    assert ((keep < 0.05) | (keep > 0.95)).float().mean() > 0.8
    assert (keep < 0.5).float().mean().item() == pytest.approx(0.3, abs=0.02)
    # Inverted dropout keeps the expectation.
    assert y.mean().item() == pytest.approx(1.0, abs=0.03)


def test_given_noise_fixes_the_mask() -> None:
    layer = ConcreteDropout(8)
    x, u = torch.randn(3, 8), torch.rand(3, 8)
    assert torch.equal(layer(x, True, u), layer(x, True, u.clone()))


def test_regularizer_formula() -> None:
    head = ConcreteDropoutHead(
        8, 4, num_layers=1, init_p=0.2, temperature=0.1, weight_reg=1e-3, dropout_reg=0.5
    )
    w = head.linears[0].weight
    p = 0.2
    want = 1e-3 * w.square().sum().item() / (1 - p) + 0.5 * 8 * (p * math.log(p) + (1 - p) * math.log(1 - p))
    assert head.regularization().item() == pytest.approx(want, rel=1e-5)


def test_dataset_size_scales_regularisers() -> None:
    config = make_config(dataset_size=1000, length_scale=0.1)
    head = BVMCPolicy(config).net.head
    assert head.weight_reg == pytest.approx(0.1**2 / 1000)
    assert head.dropout_reg == pytest.approx(2 / 1000)


def test_n_from_the_dataset_metadata_says_how_to_set_it_for_a_subset(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # Plain lerobot-train passes the whole dataset's metadata, also when --dataset.episodes picks a subset.
    caplog.set_level(logging.INFO)
    policy = BVMCPolicy(make_config(dataset_size=None), dataset_meta=SimpleNamespace(total_frames=600))
    assert policy.config.dataset_size == 600
    assert "--policy.dataset_size" in caplog.text and "lerobot-ivmc-train" in caplog.text
    # Right for the usual whole-dataset training: a note, not a warning on every stock lerobot-train.
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_dropout_probabilities_move_during_training() -> None:
    torch.manual_seed(0)
    policy = BVMCPolicy(make_config(num_fc_layers=2, dataset_size=100, optimizer_lr=1e-2))
    policy.eval()  # LeRobot's in-training eval leaves the policy in eval mode: training must not care
    before = policy.dropout_probabilities()
    optimizer = torch.optim.Adam(policy.get_optim_params(), lr=1e-2)
    batch = make_batch(batch_size=8)
    for _ in range(5):
        loss, info = policy.forward(batch)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
    after = policy.dropout_probabilities()
    assert len(before) == 2 and "dropout_p_1" in info
    assert all(abs(a - b) > 1e-3 for a, b in zip(after, before, strict=True)), (before, after)
