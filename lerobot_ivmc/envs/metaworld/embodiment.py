"""MetaWorld's Sawyer as recovery sees it (`envs.embodiment.Embodiment`)."""

from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.envs.metaworld.env_state import GRIPPER_OPENING, HAND_POSITION

# MetaWorld moves the mocap hand by 1 cm per action unit (`SawyerXYZEnv.action_scale`); its last action entry
# is a grab effort, -1 opening the fingers and +1 closing them, with nothing that keeps them as they are. The
# action moves the mocap target, which the hand follows a few steps late: a quarter of the way a step (as
# MetaWorld's scripted policies' gains of 10-25 command) arrives without overshooting. The gripper opening
# reads 1 open, ~0.3 closed on nothing and ~0.4-0.5 closed on pick-place's puck.
SAWYER = Embodiment(
    name="sawyer",
    metres_per_action_unit=0.01,
    gripper_open=-1.0,
    gripper_close=1.0,
    gripper_noop=None,
    grip_state_indices=HAND_POSITION,
    finger_state_indices=(GRIPPER_OPENING,),
    held_gap=(0.32, 0.9),
    approach_gain=0.25,
)
