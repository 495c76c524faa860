"""How reliably anchor's push legs (`recovery/anchor.py`) put push's cube on its target, as a function of
how wrong the beliefs they are planned from are.

From the start pose of `--scenes` push scenes, the legs are planned as the controller plans them (one leg
at a time, each from the object believed after the last, at most `PUSH_LEGS`), with the object belief the
cube's true position plus independent Gaussian errors of `--noise` metres on x and y (fresh for each leg)
and the goal belief the target plus one such error. Prints, per noise level, the scenes whose cube ended
on the target and the steps taken. The trained heads' errors are what a real recovery meets
(`diagnostics/anchor_beliefs.py` measures them on pick_place).

    MUJOCO_GL=egl python -m diagnostics.push_legs --scenes 20 --noise 0 0.01 0.02
"""

from __future__ import annotations

import argparse

import numpy as np

from lerobot_ivmc.envs import make_task_env
from lerobot_ivmc.recovery.anchor import PUSH_LEGS, on_goal, push_to_goal
from lerobot_ivmc.recovery.config import RecoveryConfig

MAX_STEPS = 200  # an evaluation episode's length


def push_scene(env, seed: int, noise: float, rng: np.random.Generator) -> tuple[bool, int]:
    """Push from the start pose of scene `seed`: (the cube ended on the target, steps taken)."""
    env.reset(seed=seed)
    cfg = RecoveryConfig()

    def believed(position: np.ndarray) -> np.ndarray:
        return position + np.array([*rng.normal(0.0, noise, 2), 0.0])

    goal = believed(env.target_position)
    moves = push_to_goal(
        env.grip_position, believed(env.object_position), goal, cfg.anchor.steps, cfg.move_tolerance
    )
    for step in range(MAX_STEPS):
        moves.advance(env.grip_position)
        if moves.finished:
            obj = believed(env.object_position)
            if not moves.then_push or on_goal(obj, goal):
                return False, step
            moves = push_to_goal(
                env.grip_position, obj, goal, cfg.anchor.steps, cfg.move_tolerance, moves.then_push
            )
            moves.advance(env.grip_position)
        *_, info = env.step(moves.act(env.grip_position, lambda: None))
        if info["is_success"]:
            return True, step + 1
    return False, MAX_STEPS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", type=int, default=20, help="push scenes (reset seeds 0..n-1)")
    parser.add_argument("--noise", type=float, nargs="+", default=[0.0, 0.01, 0.02], help="metres")
    parser.add_argument("--seed", type=int, default=0, help="seed of the belief errors")
    args = parser.parse_args()
    env = make_task_env("push", image_size=64)
    print(f"push legs (at most {PUSH_LEGS}) from the start pose, {args.scenes} scenes")
    print("| belief error (m, per axis) | cube on target | steps, median (max) |")
    print("|---|---|---|")
    for noise in args.noise:
        rng = np.random.default_rng(args.seed)
        results = [push_scene(env, seed, noise, rng) for seed in range(args.scenes)]
        successes = sum(success for success, _ in results)
        steps = [steps for _, steps in results]
        print(f"| {noise:g} | {successes} / {args.scenes} | {np.median(steps):.0f} ({max(steps)}) |")
    env.close()


if __name__ == "__main__":
    main()
