"""MetaWorld's Sawyer as recovery sees it (`envs.embodiment.Embodiment`)."""

from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.envs.metaworld.env_state import GRIPPER_OPENING, HAND_POSITION

# MetaWorld moves the mocap hand by 1 cm per action unit (`SawyerXYZEnv.action_scale`); its last action entry
# is a grab effort, -1 opening the fingers and +1 closing them, with nothing that keeps them as they are.
SAWYER = Embodiment(
    name="sawyer",
    metres_per_action_unit=0.01,
    gripper_open=-1.0,
    gripper_close=1.0,
    gripper_noop=None,
    grip_state_indices=HAND_POSITION,
    finger_state_indices=(GRIPPER_OPENING,),
)
