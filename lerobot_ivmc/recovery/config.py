"""Settings of the recovery loop (Algorithm 1) and its three recovery modes."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

from lerobot_ivmc.envs.task_traits import TaskTraits

# none: Bayesian VMC without recovery; min_unc: the paper's back-track and minimum-uncertainty recovery;
# rand and init: the paper's baselines ("Baselines for Visuomotor Control Recovery"); anchor (beyond the
# paper): act on the beliefs of the policy's most certain steps (`recovery/anchor.py`).
RECOVERY_MODES = ("none", "rand", "init", "min_unc", "anchor", "retry", "reach")
MIN_UNC_MEMORY = ("restore", "reset", "keep")
MIN_UNC_CHOICE = ("foresight", "mean", "random")
ANCHOR_OBJECT = ("memory", "frame")
ANCHOR_GOAL = ("memory", "frame")
ANCHOR_HELD_OFFSET = ("believed", "grasped")
ANCHOR_CARRY_MEMORY = ("keep", "reset")
RANDOM_STREAMS = ("batch", "episode")
REACH_BELIEF = ("look", "start", "now")


@dataclass
class ReachSettings:
    """`--recovery.reach.*`: the settings of `reach` (`strategies/reach.py`), a recovery that knows no task.

    Args:
        belief: where reach believes the object: "look", the mean of the object head's beliefs over
            `belief_steps` steps at the start pose with a fresh memory, after returning there (the scene as
            it is now, seen as at an episode's start); "start", the mean over the episode's first
            `belief_steps` steps (the scene before the policy touched it); "now", the belief of the step
            the trigger fires at.
        belief_steps: the steps the "look" and "start" beliefs average.
        grasp: after arriving above the object, descend to its believed centre and close the fingers before
            handing back (false: hand back above it with open fingers, for an object the task never grasps).
        grasp_tries: with `grasp`, grasps tried while the fingers close on nothing: the first at the
            believed centre, each later one `search_radius` from it in another direction.
        search_radius: metres from the believed centre of the later grasps.
        hover: metres above the believed centre the fingers rise to between grasps.
        settle_steps: steps the fingers are commanded shut in place when a grasp closes them.
        steps: most steps of each move (to the object, or one grasp).
    """

    belief: str = "look"
    belief_steps: int = 10
    grasp: bool = True
    grasp_tries: int = 3
    search_radius: float = 0.03
    hover: float = 0.05
    settle_steps: int = 10
    steps: int = 80

    def __post_init__(self) -> None:
        if self.belief not in REACH_BELIEF:
            raise ValueError(f"--recovery.reach.belief must be one of {REACH_BELIEF}, got {self.belief!r}.")
        for name in ("belief_steps", "steps", "grasp_tries"):
            if getattr(self, name) < 1:
                raise ValueError(f"--recovery.reach.{name} must be >= 1, got {getattr(self, name)}.")
        for name in ("search_radius", "hover"):
            if not 0 <= getattr(self, name) <= 0.5:
                raise ValueError(
                    f"--recovery.reach.{name} is in metres, in [0, 0.5]; got {getattr(self, name)}."
                )
        if self.settle_steps < 0:
            raise ValueError(f"--recovery.reach.settle_steps must be >= 0, got {self.settle_steps}.")


# anchor's goal is the mean of the goals believed at this many least uncertain steps: one step's belief is
# noisy, and fewer steps can all fall after the belief drifted
# (docs/RESULTS.md, "anchor's goal over 30 steps").
ANCHOR_GOAL_STEPS = 30
# Before anchor goes for a pushed object (or one held at the end), the arm looks from the start pose this
# many steps with a fresh memory and anchor reads the frame position head, which a false memory does not
# mislead (docs/RESULTS.md, "push: the frame head" and "pick_reach: the frame head").
LOOK_STEPS = 6
# A carry corrects the believed offset of a held object's centre from the grip point up to the object's
# longest half-size plus this margin (metres): 5 cm for pick_place's cube, 12.5 cm for pick_reach's stick,
# which the grasp holds 7 cm from its centre (a larger belief is shortened to the limit).
HELD_OFFSET_MARGIN = 0.025
# The limit where the object's size is not given: the cube's.
MAX_HELD_OFFSET = 0.05
# The farthest a grasp point may lie from the object's centre along an axis (metres): past the stick's ends.
MAX_GRASP_OFFSET = 0.15


@dataclass
class RecoveryConfig:
    """How a Bayesian VMC rollout detects trouble and recovers (`--recovery.<field>=` on the eval CLI).

    Args:
        mode: the recovery strategy (`recovery/strategies/`): "none", the paper's "rand", "init" and
            "min_unc", and beyond the paper "anchor" (a planner for the Fetch tasks on the policy's
            beliefs), "retry" and "reach" (they know no task: docs/recovery.md).
        threshold: C, the window-sum threshold. None: read from the checkpoint's `recovery_threshold.json`
            (written by `lerobot-ivmc-threshold`); a value given here wins.
        window: steps in the sliding window of uncertainties (the paper: 20, "best avoids noisy peaks").
            None: the window the threshold was picked with (else 20). A threshold is only meaningful for
            the window it was picked with, so another value is refused.
        initial_interval: T_recovery at the start of an episode, in steps; doubled at every recovery
            (binary exponential backoff). The paper leaves it open; 20 = one window, so no recovery fires
            before a full window of evidence, and a second one needs at least 40 more steps.
        reset_window_after_recovery: clear the window sum when a recovery starts and add no uncertainty
            during it, so the next trigger is decided on steps after the recovery only. The paper is
            silent; without it the high uncertainties that fired the trigger keep the sum above C.
        recovery_steps: the paper's maximum of 25 recovery steps: min_unc's steps of following the
            minimum foreseen uncertainty (after the back-track), rand's random moves, init's move budget.
        backtrack_horizon: size of min_unc's FIFO of (uncertainty, memory, end-effector position, step),
            the steps it may back-track over (the paper: 20); also the most steps a back-track may take.
        backtrack_tolerance: the back-track ends when the grip point is this close (metres) to the point of
            minimum uncertainty (or after `backtrack_horizon` steps).
        rand_step_scale: rand's moves are uniform in [-scale, scale] action units per axis (1 unit = 5 cm).
            The paper gives no size; 0.5 (up to 2.5 cm a step, about 7 cm of drift over 25 steps) leaves
            the scene in view and the object within reach.
        init_sphere_radius: init's target is uniform in a ball of this radius (metres) around the grip
            point's position at the start of the episode, the arm's initial pose above the table. The paper
            says only "a sphere above the table".
        move_tolerance: init's move ends when the grip point is this close (metres) to its target.
        retry_steps: retry's most steps back to the start pose (beyond the paper; it uses no task knowledge).
        candidate_noise: min_unc's candidates are the S Monte Carlo samples with N(0, noise^2) added to
            their end-effector moves (action units). None: the noise the checkpoint's foresight head was
            distilled with (`--foresight.action_noise`; 0, the paper's plain samples, for older heads), so
            the head ranks the kind of actions it learned from.
        min_unc_memory: the policy memory min_unc continues with after its back-track. "restore" (the
            paper's Algorithm 1): the memory saved at the point of minimum uncertainty. "reset" (beyond the
            paper): the memory after `reset()`, as init and rand end: a false belief the carried memory
            formed before that point (e.g. "the task is done") goes with it. "keep" (an ablation): the memory
            as it evolved through the back-track, so min_unc is a back-track only.
        min_unc_choice: which action min_unc executes after its back-track. "foresight" (the paper): the
            candidate of lowest foreseen uncertainty. "mean" and "random" (ablations of the foresight
            head): the Monte Carlo mean, i.e. the policy acting as it would without recovery, and one
            candidate drawn uniformly.
        anchor_steps: most steps of one anchor manoeuvre, or of one leg of a push (a carry across the table
            takes about 20).
        anchor_release: anchor lets a carried object go at the believed goal and rises (for tasks that end
            with the object resting at its goal); False: it hands back at the goal, still holding, with the
            memory as it is (for tasks that end holding it). None: from the task (False for pick_reach).
        anchor_grasp: anchor grasps an object it does not hold where the policy believes it; False: it
            pushes the believed object onto the anchored goal with closed fingers and hands back with a
            fresh memory (for tasks whose object is not picked up). None: from the task (False for push).
        anchor_rest_height: height (metres, world z) of the object's centre when it lies on the table, from
            the task's geometry: an object anchor does not hold is re-grasped or pushed at this height, not
            at the height the object head believes (whose errors put the fingers over the object). None:
            from the task; NaN: the believed height.
        anchor_look_steps: before anchor goes for an object it does not hold, the arm rises and returns to
            the grip position the episode started from, the memory is reset there and the arm holds still
            this many steps, so that the object is located as in every demo's first frames, not by the
            memory whose belief failed (push's failures: the cube believed in front of the fingers, or on
            the goal, while the camera shows it elsewhere). 0: act at once on the beliefs of the step the
            trigger fired. None: from the task, `LOOK_STEPS` for an object that is pushed or held at the
            end (pick_reach's stick, whose missed grasps leave the memory believing it in the hand), 0 for
            one that is picked up and let go.
        anchor_goal_steps: anchor's goal is the mean of the goals the policy believed at this many least
            uncertain steps so far (one step's belief is noisy; more steps also reach back to before the
            goal belief drifted toward the object).
        anchor_goal: which head the anchored goal is read from: "memory", the goal head on the LSTM's state;
            "frame" (a policy trained with the frame position head and the goal head): that head's reading of
            each frame alone. None: from the task, "frame" for an object held at the end, else "memory"
            (docs/RESULTS.md, "pick_reach: the frame head").
        anchor_grasp_offset: where anchor closes the fingers on an object it re-grasps, from the object's
            believed centre (metres, world x, y, z). The centre by default (it rescued more on pick_reach's
            validation failures than the demos' grasp point, `[-0.07,0,0]`: docs/RESULTS.md).
        anchor_held_offset: after a re-grasp that holds, the carry places the object by the offset the
            policy believes ("believed", as a carry of an object the policy picked itself does) or by the
            one it was grasped at ("grasped": the object's centre at `-anchor_grasp_offset` from the
            fingers); the two rescued as many on pick_reach's validation failures (docs/RESULTS.md).
        anchor_carry_memory: the memory the policy goes on with after a carry: "reset" (a fresh one, as after
            init's and rand's moves: a belief that stalled the policy goes with it) or "keep". None: from the
            task ("reset" where anchor lets the object go at the goal, else "keep").
        anchor_max_held_offset: the largest believed offset (metres) of a held object's centre from the
            grip point that a carry corrects for (a larger belief is shortened to it). None: from the task,
            the object's longest half-size + `HELD_OFFSET_MARGIN`.
        anchor_object: which of the policy's heads anchor reads the object's position from. "memory": the
            object head on the LSTM's state, which carries what the policy believed before; "frame" (a
            policy trained with the frame position head): that head's reading of the current frame's CNN
            map alone, with no memory to carry a false belief (push's failures: the object believed in
            front of the fingers after they slid past it). None: from the task, "frame" for an object that
            is pushed, "memory" for one that is picked up (where the frame head placed it worse).
        max_videos: at most this many videos of episodes with a recovery, the uncertainty trace drawn under
            the frames (frames are rendered for every episode until they are found; 0 disables).
        random_streams: where a rollout's random draws come from (its Monte Carlo dropout masks, and rand's,
            init's and min_unc's draws). "batch" (the studies' so far): the masks of every rollout of a batch
            from torch's global generator, so an episode's samples depend on the batch size and, after the
            first batch, on how many steps the earlier batches took (which recovery changes); the other
            draws per (seed, batch, row). "episode": every episode its own streams, seeded by (seed,
            episode index): the same episode acts the same whatever the batch size, and a recovery row
            acts exactly as the row without recovery on the same scenes until its own first trigger, so
            the rescued / lost counts hold nothing but the recovery.
        reach: the settings of `reach` (`ReachSettings`).
    """

    mode: str = "none"
    threshold: float | None = None
    window: int | None = None
    initial_interval: int = 20
    reset_window_after_recovery: bool = True
    recovery_steps: int = 25
    backtrack_horizon: int = 20
    backtrack_tolerance: float = 0.01
    rand_step_scale: float = 0.5
    init_sphere_radius: float = 0.1
    move_tolerance: float = 0.01
    retry_steps: int = 60
    candidate_noise: float | None = None
    min_unc_memory: str = "restore"
    min_unc_choice: str = "foresight"
    anchor_steps: int = 40
    anchor_release: bool | None = None
    anchor_grasp: bool | None = None
    anchor_rest_height: float | None = None
    anchor_look_steps: int | None = None
    anchor_goal_steps: int = ANCHOR_GOAL_STEPS
    anchor_object: str | None = None
    anchor_max_held_offset: float | None = None
    anchor_goal: str | None = None
    anchor_grasp_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    anchor_held_offset: str = "believed"
    anchor_carry_memory: str | None = None
    max_videos: int = 4
    random_streams: str = "batch"
    reach: ReachSettings = field(default_factory=ReachSettings)

    def for_task_traits(self, traits: TaskTraits) -> RecoveryConfig:
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
    ) -> RecoveryConfig:
        """These settings with anchor's unset task-dependent ones taken from the task's object handling and
        geometry (the settings themselves for another mode)."""
        if self.mode != "anchor":
            return self
        release = not object_held_at_end if self.anchor_release is None else self.anchor_release
        # A pushed object, or one held at the end, is looked for from the start pose with the frame head.
        looks = not object_picked or object_held_at_end
        return replace(
            self,
            anchor_release=release,
            anchor_grasp=object_picked if self.anchor_grasp is None else self.anchor_grasp,
            anchor_rest_height=(
                object_rest_height if self.anchor_rest_height is None else self.anchor_rest_height
            ),
            anchor_look_steps=(
                (LOOK_STEPS if looks else 0) if self.anchor_look_steps is None else self.anchor_look_steps
            ),
            anchor_object=(
                ("frame" if looks else "memory") if self.anchor_object is None else self.anchor_object
            ),
            anchor_max_held_offset=(
                object_half_length + HELD_OFFSET_MARGIN
                if self.anchor_max_held_offset is None
                else self.anchor_max_held_offset
            ),
            anchor_goal=(
                ("frame" if object_held_at_end else "memory")
                if self.anchor_goal is None
                else self.anchor_goal
            ),
            anchor_carry_memory=(
                ("reset" if release else "keep")
                if self.anchor_carry_memory is None
                else self.anchor_carry_memory
            ),
        )

    def __post_init__(self) -> None:
        for name, allowed in (
            ("mode", RECOVERY_MODES),
            ("min_unc_memory", MIN_UNC_MEMORY),
            ("min_unc_choice", MIN_UNC_CHOICE),
            ("anchor_object", ANCHOR_OBJECT),
            ("anchor_goal", ANCHOR_GOAL),
            ("anchor_held_offset", ANCHOR_HELD_OFFSET),
            ("anchor_carry_memory", ANCHOR_CARRY_MEMORY),
            ("random_streams", RANDOM_STREAMS),
        ):
            value = getattr(self, name)
            if value is not None and value not in allowed:  # None: from the task (`for_task`)
                raise ValueError(f"--recovery.{name} must be one of {allowed}, got {value!r}.")
        if self.threshold is not None and not math.isfinite(self.threshold):
            raise ValueError(
                f"--recovery.threshold must be a finite number, got {self.threshold}: a NaN threshold never "
                "fires, so recovery would silently be off."
            )
        if self.window is not None and self.window < 1:
            raise ValueError(f"--recovery.window must be >= 1 step, got {self.window}.")
        for name in ("initial_interval", "recovery_steps", "backtrack_horizon", "max_videos", "retry_steps"):
            if getattr(self, name) < 0:
                raise ValueError(f"--recovery.{name} must be >= 0, got {getattr(self, name)}.")
        if self.backtrack_horizon < 1 or self.recovery_steps < 1 or self.anchor_steps < 1:
            raise ValueError(
                "--recovery.backtrack_horizon, --recovery.recovery_steps and --recovery.anchor_steps must be "
                ">= 1."
            )
        for name in ("backtrack_tolerance", "rand_step_scale", "init_sphere_radius", "move_tolerance"):
            if getattr(self, name) <= 0:
                raise ValueError(f"--recovery.{name} must be positive, got {getattr(self, name)}.")
        if self.candidate_noise is not None and self.mode != "min_unc":
            raise ValueError(
                f"--recovery.candidate_noise widens min_unc's candidates; it has no effect with "
                f"--recovery.mode={self.mode}: drop it or use --recovery.mode=min_unc."
            )
        if self.candidate_noise is not None and not 0.0 <= self.candidate_noise <= 1.0:
            raise ValueError(
                f"--recovery.candidate_noise is a standard deviation in action units, in [0, 1]; got "
                f"{self.candidate_noise}."
            )
        set_here = [
            f.name
            for f in fields(self)
            if f.name.startswith("anchor_") and _as_tuple(getattr(self, f.name)) != f.default
        ]
        if set_here and self.mode != "anchor":
            raise ValueError(
                f"--recovery.{', '.join(set_here)} set the anchor mode; they have no effect with "
                f"--recovery.mode={self.mode}: drop them or use --recovery.mode=anchor."
            )
        if self.anchor_max_held_offset is not None and not 0 <= self.anchor_max_held_offset < math.inf:
            raise ValueError(
                "--recovery.anchor_max_held_offset is a distance in metres >= 0, got "
                f"{self.anchor_max_held_offset}."
            )
        if len(self.anchor_grasp_offset) != 3 or not all(
            math.isfinite(v) and abs(v) <= MAX_GRASP_OFFSET for v in self.anchor_grasp_offset
        ):
            raise ValueError(
                "--recovery.anchor_grasp_offset is the grasp point's offset from the object's centre, three "
                f"distances in metres within +-{MAX_GRASP_OFFSET} (e.g. '[-0.07,0,0]'); got "
                f"{self.anchor_grasp_offset}."
            )
        if self.anchor_goal_steps < 1:
            raise ValueError(f"--recovery.anchor_goal_steps must be >= 1, got {self.anchor_goal_steps}.")
        if self.anchor_look_steps is not None and self.anchor_look_steps < 0:
            raise ValueError(f"--recovery.anchor_look_steps must be >= 0, got {self.anchor_look_steps}.")
        if self.anchor_rest_height is not None and math.isinf(self.anchor_rest_height):
            raise ValueError(
                f"--recovery.anchor_rest_height is a height in metres (or nan: the believed one), got "
                f"{self.anchor_rest_height}."
            )
        if self.min_unc_choice != "foresight" and self.mode != "min_unc":
            raise ValueError(
                "--recovery.min_unc_choice sets the action min_unc follows after its back-track; it has no "
                f"effect with --recovery.mode={self.mode}: drop it or use --recovery.mode=min_unc."
            )
        if self.min_unc_memory != "restore" and self.mode != "min_unc":
            raise ValueError(
                "--recovery.min_unc_memory sets min_unc's memory after its back-track; it has no effect with "
                f"--recovery.mode={self.mode}: drop it or use --recovery.mode=min_unc."
            )
        if self.reach != ReachSettings() and self.mode != "reach":
            raise ValueError(
                "--recovery.reach.* set the reach mode; they have no effect with "
                f"--recovery.mode={self.mode}: drop them or use --recovery.mode=reach."
            )
        if self.rand_step_scale > 1:
            raise ValueError(
                f"--recovery.rand_step_scale is in action units, at most 1; got {self.rand_step_scale}."
            )


def _as_tuple(value):
    """A list (a draccus-parsed or user-built grasp offset) as a tuple, to compare with a default."""
    return tuple(value) if isinstance(value, list) else value
