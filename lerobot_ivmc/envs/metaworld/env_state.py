"""The layout of MetaWorld's 39-D state (`observation.environment_state`), kept apart from MetaWorld so that
configs and dataset features read it without loading the simulator."""

STATE_DIM = 39
# `observation.state` of `lerobot/metaworld_mt50` and LeRobot's env: hand xyz and the gripper opening.
AGENT_POS_DIM = 4
HAND_POSITION = (0, 1, 2)
GRIPPER_OPENING = 3
# The first object's position (a task's second object follows its quaternion, at 11:14).
OBJECT_POSITION = (4, 5, 6)
# What the policies' auxiliary heads learn on MetaWorld data: the hand, then the first object.
AUX_STATE_INDICES = (*HAND_POSITION, *OBJECT_POSITION)
STATE_NAMES = (
    ["hand_x", "hand_y", "hand_z", "gripper_opening"]
    + [f"object_{k}" for k in range(14)]
    + ["prev_hand_x", "prev_hand_y", "prev_hand_z", "prev_gripper_opening"]
    + [f"prev_object_{k}" for k in range(14)]
    + ["goal_x", "goal_y", "goal_z"]
)
