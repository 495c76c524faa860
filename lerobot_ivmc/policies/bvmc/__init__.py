"""Bayesian VMC: concrete dropout after the LSTM, Monte Carlo sampling and the paper's uncertainty."""

from lerobot_ivmc.policies.bvmc.configuration_bvmc import BVMCConfig
from lerobot_ivmc.policies.bvmc.modeling_bvmc import BVMCPolicy, MCPrediction
from lerobot_ivmc.policies.bvmc.processor_bvmc import make_bvmc_pre_post_processors
from lerobot_ivmc.policies.bvmc.uncertainty import trace_cov_uncertainty, weighted_norm_direction

__all__ = [
    "BVMCConfig",
    "BVMCPolicy",
    "MCPrediction",
    "make_bvmc_pre_post_processors",
    "trace_cov_uncertainty",
    "weighted_norm_direction",
]
