"""LeRobot policy types of the plugin: ``vmc`` and ``bvmc`` (registered when this package is imported)."""

from lerobot_ivmc.policies.bvmc import BVMCConfig, BVMCPolicy, MCPrediction
from lerobot_ivmc.policies.vmc import VMCConfig, VMCPolicy

__all__ = ["BVMCConfig", "BVMCPolicy", "MCPrediction", "VMCConfig", "VMCPolicy"]
