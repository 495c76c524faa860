"""Why reach's grasps on MetaWorld's Sawyer seldom hold the object: the grasp itself, or where it aims?

`tolerance`: reach's grasp (`recovery/manoeuvres.py`'s `WaypointPath`, the Sawyer embodiment) aimed at the
object's true start position plus an offset, on validation scenes; per scene whether the fingers then read
as holding (`Embodiment.holds`) and whether a 10 cm lift raises the object.
`aims`: for an evaluation with `--recovery.mode=reach`, how far each episode's first grasp target (the
object belief after the look) lies from the object's start position in the table plane (the object may
have moved since; in an early failure it seldom has). Analysis only: the truth is read from the simulator.

    python -m diagnostics.sawyer_grasp tolerance --task push-v3 --offsets 0,0,0 0.02,0,0 0.03,0,0
    python -m diagnostics.sawyer_grasp aims --task push-v3 --eval_info <out>/eval_info.json
"""

import argparse
import json
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from lerobot_ivmc.envs.metaworld.embodiment import SAWYER  # noqa: E402
from lerobot_ivmc.envs.metaworld.env import SeededMetaworldEnv  # noqa: E402
from lerobot_ivmc.envs.metaworld.env_state import GRIPPER_OPENING, HAND_POSITION, OBJECT_POSITION  # noqa: E402
from lerobot_ivmc.recovery.manoeuvres import REACH, Stop, WaypointPath, above  # noqa: E402

HAND, OBJECT = list(HAND_POSITION), list(OBJECT_POSITION)
HOVER, SETTLE_STEPS, LIFT_STEPS = 0.05, 10, 30  # reach's defaults; steps of the lift


def grasp_once(env: SeededMetaworldEnv, seed: int, offset: np.ndarray) -> tuple[bool, float]:
    """Grasp scene `seed`'s object at its start position + `offset` (metres) as reach does; whether the
    fingers read as holding, and how far (metres) the object rose with the lift."""
    state = env.reset(seed=seed)[0]["environment_state"]
    grip, obj = state[HAND].copy(), state[OBJECT].copy()
    point = obj + offset
    opened, closed = SAWYER.gripper_open, SAWYER.gripper_close
    stops = [
        Stop(above(point, grip[2]), opened),
        Stop(above(point, obj[2] + HOVER), opened),
        Stop(point, opened),
        Stop(point, closed, hold=SETTLE_STEPS),
    ]
    path = WaypointPath(stops, 200, 0.01, SAWYER, REACH, point)
    while True:
        path.advance(grip)
        if path.finished:
            break
        state = env.step(path.act(grip, lambda: None))[0]["environment_state"]
        grip = state[HAND].copy()
    holds, start_z = SAWYER.holds(state[[GRIPPER_OPENING]]), state[OBJECT[2]]
    for _ in range(LIFT_STEPS):
        state = env.step(SAWYER.move_towards(grip, grip + [0.0, 0.0, 0.1], closed))[0]["environment_state"]
        grip = state[HAND].copy()
    return holds, float(state[OBJECT[2]] - start_z)


def tolerance(task: str, offsets: list[str], scenes: int) -> None:
    env = SeededMetaworldEnv(task, split="val", image_size=16, render_style="framed")
    for text in offsets:
        offset = np.array([float(v) for v in text.split(",")])
        results = [grasp_once(env, seed, offset) for seed in range(scenes)]
        held = sum(h for h, _ in results)
        lifted = sum(rise > 0.02 for _, rise in results)
        print(f"{task} offset {offset} m: fingers read holding {held} of {scenes}, object lifted {lifted}")


def aims(task: str, eval_info: str) -> None:
    info = json.load(open(eval_info))
    env = SeededMetaworldEnv(task, split=info["run"]["split"], image_size=16, render_style="framed")
    errors = []
    for episode in info["per_episode"]:
        first = next((r for r in episode["recoveries"] if "target" in r and not r.get("holding")), None)
        if first is None:
            continue
        obj = env.reset(seed=episode["seed"])[0]["environment_state"][OBJECT]
        errors.append(100 * float(np.linalg.norm(np.array(first["target"])[:2] - obj[:2])))
        print(f"episode {episode['episode_ix']} step {first['step']}: {errors[-1]:.1f} cm")
    errors = np.array(errors)
    print(
        f"{len(errors)} grasps aimed: median {np.median(errors):.1f} cm from the object's start, "
        f"{int((errors < 2).sum())} within 2 cm, {int((errors < 3).sum())} within 3 cm"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    tol = sub.add_parser("tolerance")
    tol.add_argument("--task", default="push-v3")
    tol.add_argument("--offsets", nargs="+", default=["0,0,0"])
    tol.add_argument("--scenes", type=int, default=10)
    aim = sub.add_parser("aims")
    aim.add_argument("--task", default="push-v3")
    aim.add_argument("--eval_info", required=True)
    args = parser.parse_args()
    if args.command == "tolerance":
        tolerance(args.task, args.offsets, args.scenes)
    else:
        aims(args.task, args.eval_info)


if __name__ == "__main__":
    main()
