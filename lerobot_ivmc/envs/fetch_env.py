"""Base gymnasium env for the three Fetch tasks: step/reset/observation written once, tasks fill in hooks.

Control (25 Hz, 20 physics substeps of 2 ms): the action is a 4-vector
``[dx, dy, dz, gripper]``. The first three move the end effector by ``0.05 m * clip(d, -1, 1)`` through
the Fetch mocap weld (fixed, downward gripper orientation). ``gripper`` is a discrete command:
-1 closes, +1 opens, 0 keeps the current finger target (no-op). Values in [-1, 1] are rounded to the
nearest command, so any sample of the Box action space is valid; values outside it are an error.

Observation (LeRobot keys, understood by `lerobot.envs.utils.preprocess_observation`):
``pixels`` {camera: (H, W, 3) uint8}, ``agent_pos`` (9,) = 7 arm joints + 2 finger joints,
``environment_state`` (6,) = end-effector position + object position, the policy's auxiliary targets.
"""

from __future__ import annotations

import logging
import os
from typing import Any, ClassVar

# Headless rendering: EGL works without a display (Mesa on CPU machines). Respect a user's choice.
os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium as gym  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from gymnasium.utils import EzPickle  # noqa: E402
from gymnasium_robotics.utils import mujoco_utils  # noqa: E402

from lerobot_ivmc.envs import scene_model  # noqa: E402
from lerobot_ivmc.envs.camera import OBS_TYPES, check_image_size  # noqa: E402
from lerobot_ivmc.envs.embodiment import Embodiment
from lerobot_ivmc.envs.offscreen import StyledRenderers  # noqa: E402
from lerobot_ivmc.envs.render_styles import DEFAULT_RENDER_STYLE, check_render_style  # noqa: E402
from lerobot_ivmc.envs.scenes import Grid, Scene, cell_jitter, scenes_of_split  # noqa: E402
from lerobot_ivmc.envs.task_traits import PushContact, TaskTraits  # noqa: E402

logger = logging.getLogger(__name__)

ARM_JOINTS = (
    "robot0:shoulder_pan_joint",
    "robot0:shoulder_lift_joint",
    "robot0:upperarm_roll_joint",
    "robot0:elbow_flex_joint",
    "robot0:forearm_roll_joint",
    "robot0:wrist_flex_joint",
    "robot0:wrist_roll_joint",
)
FINGER_JOINTS = ("robot0:l_gripper_finger_joint", "robot0:r_gripper_finger_joint")
FINGER_GEOMS = ("robot0:l_gripper_finger_link", "robot0:r_gripper_finger_link")
GRIP_SITE = "robot0:grip"
GRIPPER_CLOSE, GRIPPER_NOOP, GRIPPER_OPEN = -1, 0, 1
POSITION_SCALE = 0.05  # metres per unit of action, as in gymnasium-robotics Fetch
# The Fetch arm as recovery sees it: the grip point first in `environment_state`, the fingers last in
# `agent_pos`.
EMBODIMENT = Embodiment(
    name="fetch",
    metres_per_action_unit=POSITION_SCALE,
    gripper_open=GRIPPER_OPEN,
    gripper_close=GRIPPER_CLOSE,
    gripper_noop=GRIPPER_NOOP,
    grip_state_indices=(0, 1, 2),
    finger_state_indices=tuple(range(len(ARM_JOINTS), len(ARM_JOINTS) + len(FINGER_JOINTS))),
    # The two finger joints sum to ~0 closed on nothing, ~0.1 open, ~0.048 on the cube, ~0.025 on the stick.
    held_gap=(0.01, 0.09),
)
DELTA_EE_DIM = 3  # action = [dx, dy, dz, gripper]
N_SUBSTEPS = 20  # 20 x 2 ms = 25 Hz control
_FINGER_OPEN, _FINGER_CLOSED = 0.05, 0.0  # finger position targets (actuator ctrlrange is [0, 0.2])
_GRIPPER_QUAT = np.array([1.0, 0.0, 1.0, 0.0])  # fingers pointing down, as in Fetch
# Where the mocap (welded to the gripper link, 2 cm above the grip point) may go: never lower than a
# fingertip resting on the table, and inside the box the camera sees, so that a policy that overshoots
# cannot lose sight of its own gripper. The experts' waypoints all lie inside it.
_WORKSPACE_LOW = np.array([1.08, 0.46, scene_model.TABLE_TOP_Z + 0.04])
_WORKSPACE_HIGH = np.array([1.50, 1.04, scene_model.TABLE_TOP_Z + 0.20])
# The arm's initial configuration, taken from gymnasium-robotics' FetchPickAndPlace setup.
_INITIAL_QPOS = {"robot0:slide0": 0.405, "robot0:slide1": 0.48, "robot0:slide2": 0.0}
# Fixed shuffle of a split's scenes that seeds index into (see `reset`).
_SCENE_ORDER_SEED = 7
_INITIAL_GRIPPER_OFFSET = np.array([-0.498, 0.005, -0.431 + 0.2])


class IvmcFetchEnv(gym.Env, EzPickle):
    """A Fetch manipulation task on a table. Subclasses set the class constants and the task hooks.

    Args:
        obs_type: "pixels_agent_pos" (camera image + proprioception + auxiliary state) or "state" (no image,
            much faster; for the scripted expert and tests of the dynamics).
        image_size: height and width of the observed camera image, in pixels.
        render_size: height and width of `render()` frames (videos), in pixels.
        split: which scene setups `reset` draws from: "train", "val", "test" or "all".
        terminate_on_success: end the episode when the task succeeds (evaluation); demos keep going.
        render_mode: only "rgb_array" is supported.
        render_style: how camera images and `render()` frames are drawn, a key of `RENDER_STYLES`.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 25}

    task: ClassVar[str]
    task_description: ClassVar[str]
    subtasks: ClassVar[tuple[str, ...]]  # milestone names in order; the last one is task success
    object_shape: ClassVar[scene_model.ObjectShape]
    object_grid: ClassVar[Grid]
    target_grid: ClassVar[Grid]
    target_radius: ClassVar[float] = 0.03
    # How the task treats its object, for recovery that moves it (`recovery/anchor.py`): whether it is
    # picked up at all, and whether the task ends with it still held (else it ends resting at the goal).
    object_picked: ClassVar[bool] = True
    object_held_at_end: ClassVar[bool] = False
    push_contact: ClassVar[PushContact | None] = None  # how the fingers push the object, where pushed

    @classmethod
    def traits(cls) -> TaskTraits:
        """What recovery may know of the task (`envs/task_traits.py`)."""
        return TaskTraits(
            cls.object_picked,
            cls.object_held_at_end,
            cls.object_shape.rest_height,
            max(cls.object_shape.half_size),
            cls.push_contact,
        )

    def __init__(
        self,
        obs_type: str = "pixels_agent_pos",
        image_size: int = 64,
        render_size: int = 256,
        split: str = "train",
        terminate_on_success: bool = True,
        render_mode: str | None = "rgb_array",
        render_style: str = DEFAULT_RENDER_STYLE,
    ):
        EzPickle.__init__(
            self, obs_type, image_size, render_size, split, terminate_on_success, render_mode, render_style
        )
        if obs_type not in OBS_TYPES:
            raise ValueError(f"Unknown obs_type {obs_type!r}; choose one of {OBS_TYPES}.")
        for name, size in (("image_size", image_size), ("render_size", render_size)):
            check_image_size(name, size)
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"Unsupported render_mode {render_mode!r}; only 'rgb_array' is available.")
        check_render_style("render_style", render_style, framing=False)
        self.obs_type = obs_type
        self.image_size = int(image_size)
        self.render_size = int(render_size)
        self.split = split
        self.scenes = scenes_of_split(self.all_scenes(), split)
        self._scene_order = np.random.default_rng(_SCENE_ORDER_SEED).permutation(len(self.scenes))
        self.terminate_on_success = terminate_on_success
        self.render_mode = render_mode
        self.render_style = render_style

        self.model = scene_model.build_model(self.object_shape, self.target_radius)
        self.data = mujoco.MjData(self.model)
        self.renderers = StyledRenderers(self.model, render_style)
        self._object_geom = self.model.geom(scene_model.OBJECT_BODY).id
        self._finger_geoms = tuple(self.model.geom(name).id for name in FINGER_GEOMS)
        self._target_body = self.model.body(scene_model.TARGET_BODY).id
        self._initial_state = self._settle_robot()
        # The mocap moves the gripper link; the grip point sits at a fixed offset from it.
        grip_offset = self.data.site(GRIP_SITE).xpos - self.data.body("robot0:gripper_link").xpos
        self.grip_workspace = (_WORKSPACE_LOW + grip_offset, _WORKSPACE_HIGH + grip_offset)

        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(4,), dtype=np.float32)
        self.observation_space = self._make_observation_space()
        self.scene: Scene | None = None
        self.progress: dict[str, bool] = {}
        self._finger_target = _FINGER_OPEN

    # ----------------------------------------------------------------------------------------- task hooks
    @classmethod
    def is_valid_scene(cls, scene: Scene) -> bool:
        """Whether an (object cell, target cell) pair is a scene of this task."""
        return cls.object_grid != cls.target_grid or scene.object_cell != scene.target_cell

    def _subtask_status(self) -> dict[str, bool]:
        """Which milestones hold in the current physics state (latched by the caller)."""
        raise NotImplementedError

    # ------------------------------------------------------------------------------------------- scenes
    @classmethod
    def all_scenes(cls) -> tuple[Scene, ...]:
        pairs = (Scene(o, t) for o in range(cls.object_grid.size) for t in range(cls.target_grid.size))
        return tuple(scene for scene in pairs if cls.is_valid_scene(scene))

    # ------------------------------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Start an episode on a scene of `split`.

        `options["scene_index"]` picks a scene directly. Otherwise seed ``s`` picks scene ``s mod n`` of a
        fixed shuffle of the split's ``n`` scenes, so seeds 0..n-1 visit every scene once (evaluation on
        distinct held-out scenes), and seeds from n on revisit them with the object and target moved within
        their grid cells by an offset drawn from the seed (`scenes.cell_jitter`); an unseeded reset draws a
        scene from the env's random generator.
        """
        super().reset(seed=seed)
        options = options or {}
        object_offset = target_offset = np.zeros(2)
        if "scene_index" in options:
            index = int(options["scene_index"])
            if not 0 <= index < len(self.scenes):
                raise ValueError(
                    f"scene_index {index} is out of range: split {self.split!r} has "
                    f"{len(self.scenes)} scenes."
                )
        elif seed is not None:
            index = int(self._scene_order[seed % len(self.scenes)])
            object_offset, target_offset = cell_jitter(seed, len(self.scenes))
        else:
            index = int(self.np_random.integers(len(self.scenes)))
        self.scene = self.scenes[index]

        mujoco.mj_setState(self.model, self.data, self._initial_state, mujoco.mjtState.mjSTATE_INTEGRATION)
        object_xy = self.object_grid.jittered_position(self.scene.object_cell, object_offset)
        target_xy = self.target_grid.jittered_position(self.scene.target_cell, target_offset)
        qpos = [*object_xy, self.object_shape.rest_height, 1.0, 0.0, 0.0, 0.0]
        mujoco_utils.set_joint_qpos(self.model, self.data, "object0:joint", qpos)
        self.model.body_pos[self._target_body] = [*target_xy, scene_model.TABLE_TOP_Z]
        self._finger_target = _FINGER_OPEN
        mujoco.mj_forward(self.model, self.data)

        self.progress = dict.fromkeys(self.subtasks, False)
        self._update_progress()
        return self._get_obs(), self._get_info()

    def step(self, action: np.ndarray) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        if self.scene is None:
            raise RuntimeError("Call reset() before step().")
        delta, gripper = _parse_action(action)
        if gripper == GRIPPER_CLOSE:
            self._finger_target = _FINGER_CLOSED
        elif gripper == GRIPPER_OPEN:
            self._finger_target = _FINGER_OPEN
        self.data.ctrl[:] = self._finger_target

        mujoco_utils.reset_mocap2body_xpos(self.model, self.data)
        self.data.mocap_pos[0] = np.clip(
            self.data.mocap_pos[0] + POSITION_SCALE * delta, _WORKSPACE_LOW, _WORKSPACE_HIGH
        )
        self.data.mocap_quat[0] = _GRIPPER_QUAT
        mujoco.mj_step(self.model, self.data, nstep=N_SUBSTEPS)

        self._update_progress()
        success = self.progress[self.subtasks[-1]]
        terminated = bool(success and self.terminate_on_success)
        return self._get_obs(), float(success), terminated, False, self._get_info()

    def render(self) -> np.ndarray:
        """An RGB frame of the front camera at `render_size` (for videos)."""
        return self._render(self.render_size)

    def close(self) -> None:
        self.renderers.close()

    # ------------------------------------------------------------------------------------ state readout
    @property
    def grip_position(self) -> np.ndarray:
        """World position of the point between the fingertips, (3,)."""
        return self.data.site(GRIP_SITE).xpos.copy()

    @property
    def object_position(self) -> np.ndarray:
        """World position of the object's centre, (3,)."""
        return self.data.body(scene_model.OBJECT_BODY).xpos.copy()

    @property
    def object_rotation(self) -> np.ndarray:
        """World rotation matrix of the object, (3, 3)."""
        return self.data.body(scene_model.OBJECT_BODY).xmat.reshape(3, 3).copy()

    @property
    def target_position(self) -> np.ndarray:
        """World position of the target disc's centre on the table, (3,)."""
        return self.model.body_pos[self._target_body].copy()

    @property
    def finger_positions(self) -> np.ndarray:
        return np.array([mujoco_utils.get_joint_qpos(self.model, self.data, j)[0] for j in FINGER_JOINTS])

    def is_grasped(self) -> bool:
        """Both fingers touch the object (read from the contact arrays at once: a Python loop over the
        contacts cost 0.6 ms a step)."""
        ncon = self.data.ncon
        geom1, geom2 = self.data.contact.geom1[:ncon], self.data.contact.geom2[:ncon]
        others = np.concatenate([geom2[geom1 == self._object_geom], geom1[geom2 == self._object_geom]])
        return len(set(others.tolist()) & set(self._finger_geoms)) == 2

    def object_lift(self) -> float:
        """Height of the object's centre above where it rests on the table, in metres."""
        return float(self.object_position[2] - self.object_shape.rest_height)

    # ------------------------------------------------------------------------------------ snapshots
    def get_snapshot(self) -> dict[str, Any]:
        """Everything `step` depends on: the full physics state, the finger target and the milestones.

        `set_snapshot` returns the env to it exactly (same observations and rewards for the same actions),
        e.g. to try several actions from one state.
        """
        spec = mujoco.mjtState.mjSTATE_INTEGRATION  # physics, controls, mocap and warm start
        physics = np.empty(mujoco.mj_stateSize(self.model, spec))
        mujoco.mj_getState(self.model, self.data, physics, spec)
        return {
            "physics": physics,
            # `step` moves the mocap from the body poses mj_step left behind (computed before its last
            # integration); recomputing them would shift every later step slightly.
            "body_pose": (self.data.xpos.copy(), self.data.xquat.copy()),
            "target_position": self.model.body_pos[self._target_body].copy(),
            "finger_target": self._finger_target,
            "progress": dict(self.progress),
            "scene": self.scene,
        }

    def set_snapshot(self, snapshot: dict[str, Any]) -> None:
        """Restore a state saved by `get_snapshot`."""
        mujoco.mj_setState(self.model, self.data, snapshot["physics"], mujoco.mjtState.mjSTATE_INTEGRATION)
        self.model.body_pos[self._target_body] = snapshot["target_position"]
        self._finger_target = snapshot["finger_target"]
        self.progress = dict(snapshot["progress"])
        self.scene = snapshot["scene"]
        mujoco.mj_forward(self.model, self.data)
        self.data.xpos[:], self.data.xquat[:] = snapshot["body_pose"]

    # -------------------------------------------------------------------------------------------- helpers
    def _settle_robot(self) -> np.ndarray:
        """Put the arm in its start pose (as gymnasium-robotics' Fetch does) and snapshot the physics."""
        for name, value in _INITIAL_QPOS.items():
            mujoco_utils.set_joint_qpos(self.model, self.data, name, value)
        mujoco_utils.reset_mocap_welds(self.model, self.data)
        mujoco.mj_forward(self.model, self.data)
        gripper_target = _INITIAL_GRIPPER_OFFSET + self.data.site(GRIP_SITE).xpos
        self.data.mocap_pos[0] = gripper_target
        self.data.mocap_quat[0] = _GRIPPER_QUAT
        self.data.ctrl[:] = _FINGER_OPEN
        for _ in range(10):
            mujoco.mj_step(self.model, self.data, nstep=N_SUBSTEPS)
        size = mujoco.mj_stateSize(self.model, mujoco.mjtState.mjSTATE_INTEGRATION)
        state = np.empty(size)
        mujoco.mj_getState(self.model, self.data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
        return state

    def _update_progress(self) -> None:
        for name, reached in self._subtask_status().items():
            # A Python bool: a numpy one (a comparison of positions) makes gymnasium's vector env collect
            # `is_success` in an object array, where LeRobot's rollout then fails on a parked env's None.
            self.progress[name] = bool(self.progress[name] or reached)

    def _make_observation_space(self) -> gym.spaces.Dict:
        spaces: dict[str, gym.Space] = {
            "agent_pos": gym.spaces.Box(-np.inf, np.inf, shape=(9,), dtype=np.float64),
            "environment_state": gym.spaces.Box(-np.inf, np.inf, shape=(6,), dtype=np.float64),
        }
        if self.obs_type == "pixels_agent_pos":
            image = gym.spaces.Box(0, 255, shape=(self.image_size, self.image_size, 3), dtype=np.uint8)
            spaces["pixels"] = gym.spaces.Dict({scene_model.CAMERA_NAME: image})
        return gym.spaces.Dict(spaces)

    def _get_obs(self) -> dict[str, Any]:
        joints = [
            mujoco_utils.get_joint_qpos(self.model, self.data, j)[0] for j in ARM_JOINTS + FINGER_JOINTS
        ]
        obs: dict[str, Any] = {
            "agent_pos": np.asarray(joints, dtype=np.float64),
            "environment_state": np.concatenate([self.grip_position, self.object_position]),
        }
        if self.obs_type == "pixels_agent_pos":
            obs["pixels"] = {scene_model.CAMERA_NAME: self._render(self.image_size)}
        return obs

    def _get_info(self) -> dict[str, Any]:
        return {
            "is_success": self.progress[self.subtasks[-1]],
            "subtasks": dict(self.progress),
            "scene_object_cell": self.scene.object_cell,
            "scene_target_cell": self.scene.target_cell,
        }

    def _render(self, size: int) -> np.ndarray:
        return self.renderers.frame(self.data, scene_model.CAMERA_NAME, size)


def _parse_action(action: np.ndarray) -> tuple[np.ndarray, int]:
    """Validate an action; return the clipped end-effector delta (3,) and the gripper command."""
    action = np.asarray(action, dtype=np.float64)
    if action.shape != (4,):
        raise ValueError(f"Action must have shape (4,) = [dx, dy, dz, gripper], got {action.shape}.")
    if not np.all(np.isfinite(action)):
        raise ValueError(f"Action must be finite, got {action}.")
    gripper = action[3]
    if abs(gripper) > 1.0 + 1e-6:
        raise ValueError(
            f"Gripper command must be -1 (close), 0 (no-op) or +1 (open), got {gripper}. "
            "Values in [-1, 1] are rounded to the nearest command."
        )
    return np.clip(action[:3], -1.0, 1.0), int(np.rint(gripper))
