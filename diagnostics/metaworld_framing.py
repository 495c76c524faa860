"""How well the `framed` render style frames each MetaWorld task: its camera's field of view against
LeRobot's corner2, and the share of the hand's, the object's and the goal's positions over noisy scripted
episodes that fall inside the frame (projected through the camera; a point inside may still be hidden).

    python -m diagnostics.metaworld_framing --tasks pick-place-v3 push-v3 door-open-v3 --episodes 20
"""

import argparse
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from lerobot_ivmc.datasets.expert_attempts import ActionNoise  # noqa: E402
from lerobot_ivmc.datasets.metaworld_attempts import scripted_action  # noqa: E402
from lerobot_ivmc.envs.metaworld import DEMO_EPISODE_STEPS  # noqa: E402
from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv  # noqa: E402
from lerobot_ivmc.envs.metaworld.env_state import HAND_POSITION, OBJECT_POSITION  # noqa: E402

NOISE = 0.1  # the metaworld preset's demo noise
CAMERA = "corner2"


def in_frame(data: mujoco.MjData, camera_id: int, fovy: float, point: np.ndarray) -> bool:
    """Whether `point` (world) projects inside the square frame of the camera."""
    offset = data.cam_xmat[camera_id].reshape(3, 3).T @ (point - data.cam_xpos[camera_id])
    if offset[2] >= 0:  # behind the camera
        return False
    return bool(np.abs(offset[:2] / -offset[2]).max() <= np.tan(np.radians(fovy) / 2))


def field_of_view(env: SeededMetaworldEnv) -> float:
    """The camera's vertical field of view, degrees."""
    model = env.raw_env.model
    return float(model.cam_fovy[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA)])


def coverage(task: str, style: str, episodes: int) -> tuple[float, dict[str, float]]:
    """The camera's field of view (degrees) and, per part, the share of scripted steps it is in frame."""
    env = SeededMetaworldEnv(task, split="train", terminate_on_success=False, render_style=style)
    data = env.raw_env.data
    camera_id = mujoco.mj_name2id(env.raw_env.model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA)
    fovy = field_of_view(env)
    inside = {"hand": [], "object": [], "goal": []}
    for seed in range(episodes):
        observation, _ = env.reset(seed=seed)
        noise = ActionNoise(NOISE, seed)
        for _ in range(DEMO_EPISODE_STEPS):
            state = observation["environment_state"]
            for part, point in (
                ("hand", state[list(HAND_POSITION)]),
                ("object", state[list(OBJECT_POSITION)]),
                ("goal", env.target_position),
            ):
                inside[part].append(in_frame(data, camera_id, fovy, np.asarray(point)))
            action = scripted_action(env, state)
            observation, *_ = env.step(noise(action))
    env.close()
    return fovy, {part: float(np.mean(values)) for part, values in inside.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--tasks", nargs="+", default=["pick-place-v3", "push-v3", "door-open-v3"])
    parser.add_argument("--episodes", type=int, default=20, help="scripted episodes per task")
    args = parser.parse_args()
    steps = f"{DEMO_EPISODE_STEPS} steps, noise {NOISE}"
    print(f"{args.episodes} scripted episodes a task ({steps}); the share of their steps in frame:")
    for task in args.tasks:
        flat = SeededMetaworldEnv(task, render_style="flat")  # corner2 as LeRobot places it
        flat_fovy = field_of_view(flat)
        flat.close()
        fovy, shares = coverage(task, "framed", args.episodes)
        zoom = np.tan(np.radians(flat_fovy) / 2) / np.tan(np.radians(fovy) / 2)
        parts = ", ".join(f"{part} {100 * share:.1f}%" for part, share in shares.items())
        print(f"  {task:20s}: field of view {flat_fovy:.0f} -> {fovy:.1f} deg ({zoom:.2f}x larger); {parts}")


if __name__ == "__main__":
    main()
