"""The settings of each recovery strategy, nested under `--recovery.<mode>.*`: `--recovery.min_unc.*`,
`--recovery.retry.*`, `--recovery.anchor.*`, `--recovery.reach.*`. Each validates itself; `RecoveryConfig`
refuses one changed for another mode."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from lerobot_ivmc.envs.task_traits import TaskTraits

MIN_UNC_MEMORY = ("restore", "reset", "keep")
MIN_UNC_CHOICE = ("foresight", "mean", "random")
ANCHOR_OBJECT = ("memory", "frame")
ANCHOR_GOAL = ("memory", "frame")
ANCHOR_HELD_OFFSET = ("believed", "grasped")
ANCHOR_CARRY_MEMORY = ("keep", "reset")
REACH_BELIEF = ("look", "start", "now")
REACH_OBJECT = ("memory", "frame")
REACH_GOAL = ("memory", "frame")

# anchor's goal is the mean of the goals believed at this many least uncertain steps: one step's belief is
# noisy, and fewer steps can all fall after the belief drifted
# (docs/archive/RESULTS_studies.md, "anchor's goal over 30 steps").
ANCHOR_GOAL_STEPS = 30
# Before anchor goes for a pushed object (or one held at the end), the arm looks from the start pose this
# many steps with a fresh memory and anchor reads the frame position head, which a false memory does not
# mislead (docs/archive/RESULTS_studies.md, "push: the frame head" and "pick_reach: the frame head").
LOOK_STEPS = 6
# A carry corrects the believed offset of a held object's centre from the grip point up to the object's
# longest half-size plus this margin (metres): 5 cm for pick_place's cube, 12.5 cm for pick_reach's stick,
# which the grasp holds 7 cm from its centre (a larger belief is shortened to the limit).
HELD_OFFSET_MARGIN = 0.025
# The limit where the object's size is not given: the cube's.
MAX_HELD_OFFSET = 0.05
# The farthest a grasp point may lie from the object's centre along an axis (metres): past the stick's ends.
MAX_GRASP_OFFSET = 0.15


def check_choice(flag: str, value: str | None, allowed: tuple[str, ...]) -> None:
    """Refuse `value` (None: from the task) outside `allowed`, naming `--recovery.<flag>`."""
    if value is not None and value not in allowed:
        raise ValueError(f"--recovery.{flag} must be one of {allowed}, got {value!r}.")


@dataclass
class MinUncSettings:
    """`--recovery.min_unc.*`: the paper's back-track and minimum-uncertainty recovery
    (`strategies/paper.py`).

    Args:
        memory: the policy memory min_unc continues with after its back-track. "restore" (the paper's
            Algorithm 1): the memory saved at the point of minimum uncertainty. "reset" (beyond the paper):
            the memory after `reset()`, as init and rand end: a false belief the carried memory formed
            before that point (e.g. "the task is done") goes with it. "keep" (an ablation): the memory as it
            evolved through the back-track, so min_unc is a back-track only.
        choice: which action min_unc executes after its back-track. "foresight" (the paper): the candidate
            of lowest foreseen uncertainty. "mean" and "random" (ablations of the foresight head): the Monte
            Carlo mean, i.e. the policy acting as it would without recovery, and one candidate drawn
            uniformly.
    """

    memory: str = "restore"
    choice: str = "foresight"

    def __post_init__(self) -> None:
        check_choice("min_unc.memory", self.memory, MIN_UNC_MEMORY)
        check_choice("min_unc.choice", self.choice, MIN_UNC_CHOICE)


@dataclass
class RetrySettings:
    """`--recovery.retry.*`: `retry` (`strategies/retry.py`), a recovery that knows no task.

    Args:
        steps: most steps back to the start pose.
        start_radius: retry returns to a point drawn uniformly in a ball of this radius (metres) around the
            episode's start grip position, from the rollout's own random stream, so a second attempt does
            not begin exactly where the first did; 0: the start position itself.
        commit_sample: after the return, the policy acts with one posterior sample of its network (one
            set of dropout masks, drawn at the trigger from the rollout's stream and kept until the next
            trigger) instead of the Monte Carlo mean, which averages hypotheses that disagree where the
            policy is uncertain; the uncertainty still comes from the S fresh samples. False: the mean.
    """

    steps: int = 60
    start_radius: float = 0.0
    commit_sample: bool = False

    def __post_init__(self) -> None:
        if self.steps < 1:
            raise ValueError(f"--recovery.retry.steps must be >= 1, got {self.steps}.")
        if not 0.0 <= self.start_radius <= 0.5:
            raise ValueError(
                f"--recovery.retry.start_radius is metres around the start grip position, in [0, 0.5]; got "
                f"{self.start_radius}."
            )


@dataclass
class AnchorSettings:
    """`--recovery.anchor.*`: `anchor` (`strategies/belief_anchor.py`), a planner for the Fetch tasks on the
    policy's beliefs. A setting left None is taken from the task (`for_task`).

    Args:
        steps: most steps of one anchor manoeuvre, or of one leg of a push (a carry across the table takes
            about 20).
        release: let a carried object go at the believed goal and rise (for tasks that end with the object
            resting at its goal); False: hand back at the goal, still holding, with the memory as it is (for
            tasks that end holding it). None: from the task (False for pick_reach).
        grasp: grasp an object not held where the policy believes it; False: push the believed object onto
            the anchored goal with closed fingers and hand back with a fresh memory (for tasks whose object
            is not picked up). None: from the task (False for push).
        rest_height: height (metres, world z) of the object's centre when it lies on the table: an object
            not held is re-grasped or pushed at this height, not at the believed one (whose errors put the
            fingers over the object). None: from the task; NaN: the believed height.
        look_steps: before going for an object not held, the arm rises and returns to the grip position the
            episode started from, the memory is reset there and the arm holds still this many steps, so the
            object is located as in every demo's first frames, not by the memory whose belief failed. 0: act
            at once on the beliefs of the step the trigger fired. None: from the task, `LOOK_STEPS` for an
            object that is pushed or held at the end, 0 for one that is picked up and let go.
        goal_steps: the goal is the mean of the goals the policy believed at this many least uncertain steps
            so far (one step's belief is noisy; more steps reach back to before the belief drifted).
        object: which head the object's position is read from: "memory", the object head on the LSTM's
            state; "frame" (a policy trained with the frame position head): that head's reading of the
            current frame alone, with no memory to carry a false belief. None: from the task, "frame" for an
            object that is pushed or held at the end, else "memory".
        max_held_offset: the largest believed offset (metres) of a held object's centre from the grip point
            that a carry corrects for (a larger belief is shortened to it). None: from the task, the
            object's longest half-size + `HELD_OFFSET_MARGIN`.
        goal: which head the goal is read from: "memory" (the goal head on the LSTM's state) or "frame" (the
            frame position head's reading of each frame). None: from the task, "frame" for an object held at
            the end, else "memory".
        grasp_offset: where a re-grasp closes the fingers, from the object's believed centre (metres, world
            x, y, z).
        held_offset: after a re-grasp that holds, the carry places the object by the offset the policy
            believes ("believed") or by the one it was grasped at ("grasped": `-grasp_offset`).
        carry_memory: the memory the policy goes on with after a carry: "reset" (a fresh one) or "keep".
            None: from the task ("reset" where the object is let go at the goal, else "keep").

    The measurements behind each default: docs/recovery.md and docs/RESULTS.md.
    """

    steps: int = 40
    release: bool | None = None
    grasp: bool | None = None
    rest_height: float | None = None
    look_steps: int | None = None
    goal_steps: int = ANCHOR_GOAL_STEPS
    object: str | None = None
    max_held_offset: float | None = None
    goal: str | None = None
    grasp_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    held_offset: str = "believed"
    carry_memory: str | None = None

    def __post_init__(self) -> None:
        if isinstance(self.grasp_offset, list):  # (as draccus parses it)
            self.grasp_offset = tuple(self.grasp_offset)
        check_choice("anchor.object", self.object, ANCHOR_OBJECT)
        check_choice("anchor.goal", self.goal, ANCHOR_GOAL)
        check_choice("anchor.held_offset", self.held_offset, ANCHOR_HELD_OFFSET)
        check_choice("anchor.carry_memory", self.carry_memory, ANCHOR_CARRY_MEMORY)
        if self.steps < 1:
            raise ValueError(f"--recovery.anchor.steps must be >= 1, got {self.steps}.")
        if self.goal_steps < 1:
            raise ValueError(f"--recovery.anchor.goal_steps must be >= 1, got {self.goal_steps}.")
        if self.look_steps is not None and self.look_steps < 0:
            raise ValueError(f"--recovery.anchor.look_steps must be >= 0, got {self.look_steps}.")
        if self.max_held_offset is not None and not 0 <= self.max_held_offset < math.inf:
            raise ValueError(
                f"--recovery.anchor.max_held_offset is a distance in metres >= 0, got {self.max_held_offset}."
            )
        if len(self.grasp_offset) != 3 or not all(
            math.isfinite(v) and abs(v) <= MAX_GRASP_OFFSET for v in self.grasp_offset
        ):
            raise ValueError(
                "--recovery.anchor.grasp_offset is the grasp point's offset from the object's centre, three "
                f"distances in metres within +-{MAX_GRASP_OFFSET} (e.g. '[-0.07,0,0]'); got "
                f"{self.grasp_offset}."
            )
        if self.rest_height is not None and math.isinf(self.rest_height):
            raise ValueError(
                "--recovery.anchor.rest_height is a height in metres (or nan: the believed one), got "
                f"{self.rest_height}."
            )

    def for_traits(self, traits: TaskTraits) -> AnchorSettings:
        """`for_task` with a task's object handling and geometry (`IvmcFetchEnv.traits()`)."""
        return self.for_task(
            traits.object_picked, traits.object_held_at_end, traits.rest_height, traits.half_length
        )

    def for_task(
        self,
        object_picked: bool,
        object_held_at_end: bool,
        object_rest_height: float = math.nan,
        object_half_length: float = MAX_HELD_OFFSET - HELD_OFFSET_MARGIN,
    ) -> AnchorSettings:
        """These settings with the unset (None) ones taken from the task's object handling and geometry."""
        release = not object_held_at_end if self.release is None else self.release
        # A pushed object, or one held at the end, is looked for from the start pose with the frame head.
        looks = not object_picked or object_held_at_end

        def given(value, from_task):
            return from_task if value is None else value

        return replace(
            self,
            release=release,
            grasp=given(self.grasp, object_picked),
            rest_height=given(self.rest_height, object_rest_height),
            look_steps=given(self.look_steps, LOOK_STEPS if looks else 0),
            object=given(self.object, "frame" if looks else "memory"),
            max_held_offset=given(self.max_held_offset, object_half_length + HELD_OFFSET_MARGIN),
            goal=given(self.goal, "frame" if object_held_at_end else "memory"),
            carry_memory=given(self.carry_memory, "reset" if release else "keep"),
        )

    def unresolved(self) -> list[str]:
        """The settings left to the task (None) that `for_task` has not filled."""
        return [f.name for f in fields(self) if getattr(self, f.name) is None]

    def as_flat_dict(self) -> dict:
        """The settings as `anchor_<name>` keys, as the recorded studies' anchor rows hold them."""
        return {f"anchor_{f.name}": getattr(self, f.name) for f in fields(self)}


@dataclass
class ReachSettings:
    """`--recovery.reach.*`: `reach` (`strategies/reach.py`), a recovery that knows no task.

    Args:
        belief: where reach believes the object: "look", the mean of the object head's beliefs over
            `belief_steps` steps at the start pose with a fresh memory, after returning there (the scene as
            it is now, seen as at an episode's start); "start", the mean over the episode's first
            `belief_steps` steps (the scene before the policy touched it); "now", the belief of the step
            the trigger fires at.
        belief_steps: the steps the "look" and "start" beliefs average.
        object: which head the object beliefs come from: "memory", the object head on the memory; "frame",
            the frame position head on each frame alone (no memory to carry a false belief; a policy
            trained with it).
        grasp: after arriving above the object, descend to its believed centre and close the fingers before
            handing back (false: hand back above it with open fingers, for an object the task never grasps;
            with `push`, the push takes the grasp's place).
        grasp_tries: with `grasp`, grasps tried while the fingers close on nothing: the first at the
            believed centre, each later one `search_radius` from it in another direction.
        search_radius: metres from the believed centre of the later grasps.
        hover: metres above the believed centre the fingers rise to between grasps.
        settle_steps: steps the fingers are commanded shut in place when a grasp closes them.
        steps: most steps of each move (to the object, one grasp, or the carry).
        carry: after a grasp that holds (or at once, where the fingers hold the object when the trigger
            fires), carry the object to the goal the policy believed on its `goal_steps` least uncertain
            steps (the goal head: where the object ends in the demos) and hold it there, then hand back
            with a fresh memory (false: hand back after the grasp). Needs a policy with the goal head.
        goal_steps: with `carry` or `push`, the least uncertain normal steps whose goal beliefs are averaged.
        release: with `carry`, set the object down 2 cm above the goal and open the fingers (for a task
            that ends with the object let go; false: hold it at the goal).
        goal: with `carry` or `push`, which head the goal beliefs come from: "memory", the goal head on the
            memory; "frame", the frame position head's goal reading of each frame (a policy trained with it).
        max_held_offset: with `carry`, the most metres the believed centre of a held object may lie from
            the grip point; a longer believed offset is shortened to it (the beliefs drift most in the
            failures the carry rescues).
        push: at the object, push it instead of grasping it (for an object the task moves without lifting
            it): with closed fingers, from behind it on the line from the goal the policy believed on its
            `goal_steps` least uncertain steps, along that line until the object head believes the object
            there; up to `push_legs` legs, each planned from where the object is then believed; then the
            policy again with a fresh memory. Needs a policy with the goal head.
        push_legs: with `push`, the most legs of one recovery.
    """

    belief: str = "look"
    belief_steps: int = 10
    object: str = "memory"
    grasp: bool = True
    grasp_tries: int = 3
    search_radius: float = 0.03
    hover: float = 0.05
    settle_steps: int = 10
    steps: int = 80
    carry: bool = False
    goal_steps: int = ANCHOR_GOAL_STEPS
    release: bool = False
    goal: str = "memory"
    max_held_offset: float = MAX_HELD_OFFSET
    push: bool = False
    push_legs: int = 2

    def __post_init__(self) -> None:
        check_choice("reach.belief", self.belief, REACH_BELIEF)
        check_choice("reach.object", self.object, REACH_OBJECT)
        check_choice("reach.goal", self.goal, REACH_GOAL)
        if not 0 <= self.max_held_offset <= 0.5:
            raise ValueError(
                f"--recovery.reach.max_held_offset is in metres, in [0, 0.5]; got {self.max_held_offset}."
            )
        if self.release and not self.carry:
            raise ValueError(
                "--recovery.reach.release=true lets go of the object the carry brought to the goal: add "
                "--recovery.reach.carry=true or drop the release."
            )
        if self.carry and not self.grasp:
            raise ValueError(
                "--recovery.reach.carry=true carries the object the grasp holds: drop "
                "--recovery.reach.grasp=false or the carry."
            )
        if self.push and self.carry:
            raise ValueError(
                "--recovery.reach.push=true pushes the object to the goal, --recovery.reach.carry=true "
                "grasps and carries it there: choose one."
            )
        for name in ("belief_steps", "steps", "grasp_tries", "goal_steps", "push_legs"):
            if getattr(self, name) < 1:
                raise ValueError(f"--recovery.reach.{name} must be >= 1, got {getattr(self, name)}.")
        for name in ("search_radius", "hover"):
            if not 0 <= getattr(self, name) <= 0.5:
                raise ValueError(
                    f"--recovery.reach.{name} is in metres, in [0, 0.5]; got {getattr(self, name)}."
                )
        if self.settle_steps < 0:
            raise ValueError(f"--recovery.reach.settle_steps must be >= 0, got {self.settle_steps}.")


# Each mode with nested settings, by the field of `RecoveryConfig` that holds them.
STRATEGY_SETTINGS = {
    "min_unc": MinUncSettings,
    "retry": RetrySettings,
    "anchor": AnchorSettings,
    "reach": ReachSettings,
}


def renamed_flag(arg: str) -> str | None:
    """The nested flag that replaces a flat one of earlier versions (`--recovery.anchor_steps=5` ->
    `--recovery.anchor.steps=5`), or None for any other argument."""
    if not arg.startswith("--recovery."):
        return None
    name, sep, value = arg.removeprefix("--recovery.").partition("=")
    for mode, settings in STRATEGY_SETTINGS.items():
        field_name = name.removeprefix(f"{mode}_")
        if field_name != name and field_name in {f.name for f in fields(settings)}:
            return f"--recovery.{mode}.{field_name}{sep}{value}"
    return None
