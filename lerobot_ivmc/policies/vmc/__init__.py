"""VMC: the deterministic visuomotor controller (James et al. 2017, as adapted by the paper)."""

from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig
from lerobot_ivmc.policies.vmc.modeling_vmc import VMCPolicy
from lerobot_ivmc.policies.vmc.network import VisuomotorNet
from lerobot_ivmc.policies.vmc.processor_vmc import make_vmc_pre_post_processors

__all__ = ["VMCConfig", "VMCPolicy", "VisuomotorNet", "make_vmc_pre_post_processors"]
