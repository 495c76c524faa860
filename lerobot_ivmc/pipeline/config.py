"""The pipeline's config: one nested draccus config whose sections are the stages' own commands' settings.

A preset (`lerobot_ivmc/pipeline/presets/<name>.yaml`: smoke, lite, paper) fills it; every value can be
overridden on the command line (`--train.steps=2000`, `--collect.dataset.num_episodes=500`), and a field
that does not exist is refused by draccus. Section fields carry the names of the flags of the command they
feed: `collect` is `lerobot-ivmc-collect`'s own `RecordDemosConfig`; `train.policy` holds `--policy.*`
fields of `lerobot-ivmc-train`; `foresight` is `lerobot-ivmc-foresight`'s `--foresight.*`; and so on.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

from lerobot_ivmc.datasets.demo_suites import DemoSuite, suite_of
from lerobot_ivmc.datasets.record_config import RecordDemosConfig
from lerobot_ivmc.policies.vmc.configuration_vmc import VMCConfig
from lerobot_ivmc.recovery.config import RANDOM_STREAMS, RECOVERY_MODES, TASK_FREE_MODES
from lerobot_ivmc.recovery.foresight_training import ForesightConfig
from lerobot_ivmc.recovery.threshold import SCORES, THRESHOLD_METHODS, conformal_min_successes

# Shipped inside the package, so `--preset` works wherever the plugin is installed.
PRESETS_DIR = Path(__file__).resolve().parent / "presets"
EXECUTORS = ("local", "ray")
TRAIN_DEVICES = ("auto", "cpu", "cuda")
# The BVMC rows of Table I: alone and with the paper's three recovery modes, then anchor (beyond the paper).
DEFAULT_MODES = ("none", "rand", "init", "min_unc", "anchor")
# Rows that run a recovery mode with flags of their own: anchor's planner fired from the first step the
# trigger may fire (threshold 0), the control that measures what the introspection's timing adds to anchor.
CONTROL_ROWS = {"anchor_control": ("anchor", ("--recovery.threshold=0",))}
# Rows that run reach with its carry to the believed goal (docs/recovery.md): holding the object there, or
# set down and let go; with the memory's heads, or with the frame position head's readings and the held
# object's believed offset unbounded (`_frame`). Which of them a task needs is chosen on validation scenes
# like any mode that knows no task (`--recovery_choice`).
CARRY, RELEASE = "--recovery.reach.carry=true", "--recovery.reach.release=true"
FRAME_READINGS = ("--recovery.reach.object=frame", "--recovery.reach.goal=frame")
ON_FRAMES = (*FRAME_READINGS, "--recovery.reach.max_held_offset=0.5")
# reach's push (an object moved without lifting it) to the believed goal: on the memory's heads, on the frame
# position head's readings, or the object on the frame head's and the goal on the memory's.
PUSH = "--recovery.reach.push=true"
VARIANT_ROWS = {
    "reach_carry": ("reach", (CARRY,)),
    "reach_place": ("reach", (CARRY, RELEASE)),
    "reach_carry_frame": ("reach", (CARRY, *ON_FRAMES)),
    "reach_place_frame": ("reach", (CARRY, RELEASE, *ON_FRAMES)),
    "reach_push": ("reach", (PUSH,)),
    "reach_push_frame": ("reach", (PUSH, *FRAME_READINGS)),
    "reach_push_frame_object": ("reach", (PUSH, FRAME_READINGS[0])),
}
# Triggers beyond the uncertainty score (docs/recovery.md), added to a row that knows no task as
# `<row>_<trigger>`: the deadline the threshold record holds, a missed grasp (the fingers closed on nothing
# for GRASP_MISS_STEPS steps), and `_only` where the score's threshold is out of reach, for a policy whose
# uncertainty does not tell its failures. Chosen on validation scenes like the modes.
GRASP_MISS_STEPS = 30
DEADLINE, GRASP_MISS = "--recovery.deadline=auto", f"--recovery.grasp_miss={GRASP_MISS_STEPS}"
SCORE_OUT_OF_REACH = "--recovery.threshold=1e9"
TRIGGER_VARIANTS = {
    "deadline": (DEADLINE,),
    "grasp_miss": (GRASP_MISS,),
    "deadline_only": (SCORE_OUT_OF_REACH, DEADLINE),
    "grasp_miss_only": (SCORE_OUT_OF_REACH, GRASP_MISS),
    "grasp_miss_deadline_only": (SCORE_OUT_OF_REACH, GRASP_MISS, DEADLINE),
}
TRIGGER_ROWS = {
    f"{row}_{trigger}": (mode, (*own, *flags))
    for row, (mode, own) in {**{m: (m, ()) for m in TASK_FREE_MODES}, **VARIANT_ROWS}.items()
    for trigger, flags in TRIGGER_VARIANTS.items()
}
ROW_FLAGS = {**CONTROL_ROWS, **VARIANT_ROWS, **TRIGGER_ROWS}
STUDY_ROWS = (*RECOVERY_MODES, *ROW_FLAGS)
# The rows `--recovery_choice` may choose among: the modes that know no task, their variants, and "none"
# (no recovery: chosen where every mode loses on validation scenes).
TASK_FREE_ROWS = (*TASK_FREE_MODES, *VARIANT_ROWS, *TRIGGER_ROWS)
CHOICE_ROWS = ("none", *TASK_FREE_ROWS)
POLICY_TYPES = ("vmc", "bvmc")


def row_mode(row: str) -> str:
    """The recovery mode a BVMC row of `--recovery_modes` runs: its own name, or a control or variant
    row's mode."""
    return ROW_FLAGS[row][0] if row in ROW_FLAGS else row


@dataclass
class TrainPolicyConfig:
    """`--policy.*` fields of `lerobot-ivmc-train` the pipeline sets (the type and #fc come per run).

    Args:
        training_mode, chunk_length: as the policies' config fields.
        goal_head: as the policies' field; None follows the policy (on in sequence training).
        image_shift_pad, optimizer_lr, chunk_memory, frame_position_head, gripper_head, gripper_levels:
            the policies' own fields; None leaves the flag out, so the policy's default applies (the
            training's fingerprint holds the resolved policy config, so a changed default redoes it).
    """

    training_mode: str = "sequence"
    chunk_length: int = 100
    goal_head: bool | None = None
    image_shift_pad: int | None = None
    optimizer_lr: float | None = None
    chunk_memory: str | None = None
    frame_position_head: bool | None = None
    gripper_head: str | None = None
    gripper_levels: list[float] | None = None

    def given(self) -> dict:
        """The fields passed to the policies (unset ones left out)."""
        return {name: value for name, value in asdict(self).items() if value is not None}


@dataclass
class TrainStageConfig:
    """`lerobot-ivmc-train`, once per policy type and #fc.

    Args:
        num_fc_layers: the #fc values of Table I to train and evaluate (the paper: 1 and 2).
        steps, batch_size, save_freq, seed: as `lerobot-train`'s flags.
        bf16: train under bf16 autocast (`ACCELERATE_MIXED_PRECISION=bf16`) on a GPU, and on a CPU that
            runs bf16 natively (AVX512-BF16 or AMX); on other CPUs bf16 is emulated, slower than fp32, and
            the study trains in fp32 (the stage's command line in its log shows which). A GPU without bf16
            (before NVIDIA's Ampere) needs --train.bf16=false.
        device: where the trainings run: "cpu", "cuda", or "auto": CUDA where it is present (this machine,
            or with the ray executor a GPU in the cluster), else the CPU. Like the precision, the device
            enters a training's fingerprint: a study begun on one keeps its trainings only on the same.
        policy: policy fields passed as `--policy.<name>=`.
        extra_seeds: further training seeds, for the spread of training: each gets the whole chain of
            every #fc (vmc and bvmc trained and checked, its own foresight head and threshold, every Table
            I row on the same test scenes, detection), and the results hold each row per seed, its mean and
            standard deviation over the seeds, and each recovery row's rescue against its own seed's
            BVMC, pooled over the seeds. The Table I rows themselves stay those of `seed`.
        vmc: train, check and evaluate VMC (Table I's baseline row) beside BVMC; false: BVMC and its
            recovery rows alone, for a study of introspection and recovery that needs no VMC row (VMC's
            training is the longest stage of a chain). BVMC's stages are the whole study's, fingerprints
            included: the same command without it later adds VMC's stages and redoes none.

    Every run trains from `seed` (and again from each of `extra_seeds`); the final checkpoint is the one
    evaluated.
    """

    num_fc_layers: list[int] = field(default_factory=lambda: [1, 2])
    steps: int = 16000
    batch_size: int = 2
    save_freq: int = 4000
    seed: int = 1000
    bf16: bool = True
    device: str = "auto"
    policy: TrainPolicyConfig = field(default_factory=TrainPolicyConfig)
    extra_seeds: list[int] = field(default_factory=list)
    vmc: bool = True

    @property
    def policy_types(self) -> tuple[str, ...]:
        """The policy types the study trains: vmc (unless `vmc` is off), then bvmc."""
        return POLICY_TYPES if self.vmc else ("bvmc",)

    @property
    def seeds(self) -> list[int]:
        """Every training seed: the main one first."""
        return [self.seed, *self.extra_seeds]


@dataclass
class PerceptionStageConfig:
    """`lerobot-ivmc-perception` after every training, on validation scenes: did the policy learn where the
    object is?

    Args:
        n_scenes: validation scenes (seeds `seed`, `seed + 1`, ...).
        steps: steps measured from each episode's start.
        max_object_error_cm: stop the study when a policy of the main training seed, acting, misjudges the
            object's position by more than this (median, cm), before foresight and evaluations are spent on
            it; 0 only reports. Extra training seeds' policies get the verdict but never stop the study.
    """

    n_scenes: int = 20
    steps: int = 30
    max_object_error_cm: float = 5.0


@dataclass
class EpisodesConfig:
    """How many episodes an evaluation-like stage runs, in batches of `batch_size` parallel envs."""

    n_episodes: int = 100
    batch_size: int = 10


@dataclass
class ForesightStageConfig:
    """`lerobot-ivmc-foresight`: `--eval.batch_size` and `--foresight.*`."""

    batch_size: int = 10
    foresight: ForesightConfig = field(default_factory=ForesightConfig)


@dataclass
class ThresholdStageConfig:
    """`lerobot-ivmc-threshold` on validation scenes: the paper's argmax, or conformal with `alpha`, for the
    `score` every BVMC row's trigger then compares (`--score`: window_sum, time_conditioned or auto)."""

    n_episodes: int = 100
    batch_size: int = 10
    method: str = "argmax"
    alpha: float = 0.1
    score: str = "window_sum"


@dataclass
class RegimeConfig:
    """The data-budget rule (`pipeline/regime.py`): the same rule for every task, for a task BVMC solves at
    full data (pick_reach at `lite`), chosen on validation scenes before any test run. The budget is the
    number of demos or the number of training steps, one of the two.

    Args:
        demo_budgets: demo counts to try after the preset's own, largest first (e.g. [1000, 500, 250]);
            empty (the default): the study trains on all its demos, no rule.
        train_steps: training lengths to try after the preset's own `--train.steps`, longest first (e.g.
            [2000, 1000]), on all the demos: for a task solved even with few demos.
        failure_range: the [low, high] fraction of validation scenes BVMC should fail.
        n_episodes, batch_size: validation scenes of each budget's probe (the threshold's first scenes).
    """

    demo_budgets: list[int] = field(default_factory=list)
    train_steps: list[int] = field(default_factory=list)
    failure_range: list[float] = field(default_factory=lambda: [0.2, 0.4])
    n_episodes: int = 50
    batch_size: int = 10

    @property
    def budget(self) -> str | None:
        """What the rule varies: "demos", "steps", or None when it is off."""
        return "demos" if self.demo_budgets else "steps" if self.train_steps else None


@dataclass
class ExecutorConfig:
    """Where the stages run. None of it enters a stage's fingerprint: a study begun with one executor
    resumes with the other.

    Args:
        type: "local": one stage after the other on this machine (the default); "ray": each stage as a Ray
            task once the stages it reads (and the perception check that gates it) have finished, side by
            side where the cluster's resources allow (`pip install 'lerobot_policy_ivmc[ray]'`).
        address: the Ray cluster to join ("auto", "ray://<head>:10001"); None starts a local one on this
            machine. The study's folder must be on a filesystem every node of the cluster sees.
        num_cpus: CPUs of the local Ray cluster (None: all of this machine's).
        train_cpus: CPUs a training takes (its torch threads); at most the CPUs of the cluster's largest
            node.
        train_gpus: share of one GPU a training on CUDA takes (0.5: two trainings share a GPU).
        eval_cpus: CPUs each perception check, foresight, threshold, evaluation and detection takes.
    """

    type: str = "local"
    address: str | None = None
    num_cpus: int | None = None
    train_cpus: float = 2.0
    train_gpus: float = 0.5
    eval_cpus: float = 1.0


@dataclass
class PipelineConfig:
    """The whole study for one task.

    Args:
        task: push, pick_place or pick_reach, or a MetaWorld v3 task (e.g. pick-place-v3: the MetaWorld
            suite, `--preset=metaworld`; docs/metaworld.md).
        preset: the preset this config started from (recorded, so a folder never mixes presets).
        output_dir: the study's folder (data, checkpoints, evals, results); default
            ``outputs/pipeline/<task>_<preset>``.
        seed: the seed of every evaluation (test scenes are seeds seed..seed+n-1: the same scenes for
            every row).
        episode_length: steps before an evaluation episode is cut (the paper: 200).
        collect: `lerobot-ivmc-collect`'s config (its `env.task` is set from `task`).
        train: the training runs.
        perception: the check after each training that the policy learned where the object is.
        foresight: distillation of the uncertainty foresight head.
        threshold: threshold picking on validation scenes.
        eval: the Table I evaluations on test scenes (VMC, and BVMC with each of `recovery_modes`).
        recovery_modes: the BVMC rows: "none" (plain BVMC), "rand", "init", "min_unc" (the paper's) and,
            beyond the paper, "anchor" (a policy trained with the goal head; the Fetch tasks), "retry" and
            "reach" (no task knowledge), and "anchor_control" (anchor's planner fired from the first step
            the trigger may fire: `--recovery.threshold=0`).
        recovery_choice: modes of `recovery_modes` that know no task, among which each chain chooses on
            validation scenes: each runs on the threshold's validation scenes, and the one that rescues
            most of them net of those it loses (ties: fewer lost, then the listed order) gives the row
            "chosen" its test episodes (`pipeline/recovery_choice.py`). "none" may be listed: no recovery,
            0 rescued and 0 lost, chosen where every mode loses more than it rescues. A row with a trigger
            beyond the score (`<row>_deadline`, `_grasp_miss`, `_deadline_only`, `_grasp_miss_only`,
            `_grasp_miss_deadline_only`: TRIGGER_VARIANTS) is a candidate like a mode. Empty: no choice.
        fig3: the Fig. 3 evaluation (BVMC without recovery, many test episodes) and detection metrics.
        regime: the data-budget rule (off unless `--regime.demo_budgets` or `--regime.train_steps` lists
            budgets).
        executor: where the stages run: one after the other here (local), or side by side on Ray.
        async_envs: foresight, threshold and evaluation stages step each sub-env in its own process
            (`--eval.use_async_envs`; the same episodes as in one process). Off by default: on 2 cores, 10
            sub-env processes evaluated 100 pick_place episodes in 118.7 s against 107.2 s in one process
            (benchmarks/bench_eval.py, docs/benchmarks.md "Benchmarks"); machines with more cores than that
            gain.
        random_streams: the BVMC rollouts' random draws (`--recovery.random_streams` of the threshold, the
            BVMC rows, Fig. 3 and the data-budget probes): "batch" (the default, as the recorded studies
            drew them) or "episode" (each episode its own streams: a recovery row acts as plain BVMC on the
            same scene until its first trigger, and results do not depend on the batch size).
        dry_run: list each stage as the same command would find it (done, to run, to resume, or to redo
            because its settings or an upstream stage changed) and run nothing.
    """

    task: str = ""
    preset: str = ""
    output_dir: Path | None = None
    seed: int = 0
    episode_length: int = 200
    collect: RecordDemosConfig = field(default_factory=RecordDemosConfig)
    train: TrainStageConfig = field(default_factory=TrainStageConfig)
    perception: PerceptionStageConfig = field(default_factory=PerceptionStageConfig)
    foresight: ForesightStageConfig = field(default_factory=ForesightStageConfig)
    threshold: ThresholdStageConfig = field(default_factory=ThresholdStageConfig)
    eval: EpisodesConfig = field(default_factory=EpisodesConfig)
    recovery_modes: list[str] = field(default_factory=lambda: list(DEFAULT_MODES))
    recovery_choice: list[str] = field(default_factory=list)
    fig3: EpisodesConfig = field(default_factory=lambda: EpisodesConfig(n_episodes=800))
    regime: RegimeConfig = field(default_factory=RegimeConfig)
    executor: ExecutorConfig = field(default_factory=ExecutorConfig)
    async_envs: bool = False
    random_streams: str = "batch"
    dry_run: bool = False

    def __post_init__(self) -> None:
        self.validate()

    @property
    def anchor_rows(self) -> list[str]:
        """The rows of `recovery_modes` that run anchor (anchor and its control row)."""
        return [row for row in self.recovery_modes if row_mode(row) == "anchor"]

    def validate(self) -> None:
        """Refuse values no stage could run, with what to pass instead."""
        if self.task:
            try:
                suite = suite_of(self.task)
            except ValueError as error:
                raise ValueError(f"--task: {error}") from None
            # The suite's defaults for what the preset leaves unset (a Fetch preset sets both).
            c = self.collect
            c.env.render_style = c.env.render_style or suite.default_render_style
            c.dataset.episode_steps = c.dataset.episode_steps or suite.default_episode_steps
            if suite.name != "ivmc" and self.anchor_rows:
                raise ValueError(
                    f"--recovery_modes: {', '.join(self.anchor_rows)}: anchor is a planner for the Fetch "
                    f"tasks; drop them for {self.task}."
                )
        bad_fc = [n for n in self.train.num_fc_layers if n not in (1, 2)]
        if bad_fc or not self.train.num_fc_layers:
            raise ValueError(
                f"--train.num_fc_layers must list #fc values from (1, 2), got {self.train.num_fc_layers}."
            )
        if self.dry_run and self.regime.budget:
            raise ValueError(
                "--dry_run lists the stages of one study, and the data-budget rule (--regime.*) chooses its "
                "study as it runs: drop --regime.* and pass the chosen study's flags and --output_dir."
            )
        if self.random_streams not in RANDOM_STREAMS:
            raise ValueError(
                f"--random_streams must be one of {RANDOM_STREAMS}, got {self.random_streams!r}."
            )
        bad_modes = [m for m in self.recovery_modes if m not in STUDY_ROWS]
        if bad_modes or not self.recovery_modes:
            raise ValueError(
                f"--recovery_modes must be taken from {(*RECOVERY_MODES, *CONTROL_ROWS, *VARIANT_ROWS)} or a "
                f"row with a trigger (`<row>_<trigger>`, triggers {tuple(TRIGGER_VARIANTS)}); got "
                f"{self.recovery_modes}{f', unknown {bad_modes}' if bad_modes else ''}."
            )
        self.validate_recovery_choice()
        if self.anchor_rows and self.train.policy.goal_head is False:
            raise ValueError(
                f"--recovery_modes: {', '.join(self.anchor_rows)} read the policy's goal head: drop "
                f"--train.policy.goal_head=false or the rows {self.anchor_rows}."
            )
        if self.perception.max_object_error_cm < 0:
            raise ValueError(
                "--perception.max_object_error_cm must be >= 0 (0 only reports), got "
                f"{self.perception.max_object_error_cm}."
            )
        seeds = self.train.seeds
        if any(not 0 <= seed < 2**32 for seed in seeds):
            raise ValueError(f"Training seeds must be in [0, 2**32), got --train.seed / extra_seeds {seeds}.")
        if self.train.extra_seeds and "none" not in self.recovery_modes:
            raise ValueError(
                "--train.extra_seeds compares each seed's recovery rows with its own BVMC without recovery, "
                "which needs 'none' in --recovery_modes."
            )
        if len(set(seeds)) != len(seeds):
            raise ValueError(
                f"--train.extra_seeds must differ from each other and from --train.seed={self.train.seed}, "
                f"got {self.train.extra_seeds}."
            )
        self.validate_stage_values()
        self.validate_regime()
        self.validate_executor()
        for name, value in (
            ("train.steps", self.train.steps),
            ("train.batch_size", self.train.batch_size),
            ("train.save_freq", self.train.save_freq),
            ("eval.batch_size", self.eval.batch_size),
            ("fig3.batch_size", self.fig3.batch_size),
            ("threshold.batch_size", self.threshold.batch_size),
            ("foresight.batch_size", self.foresight.batch_size),
            ("eval.n_episodes", self.eval.n_episodes),
            ("fig3.n_episodes", self.fig3.n_episodes),
            ("threshold.n_episodes", self.threshold.n_episodes),
            ("perception.n_scenes", self.perception.n_scenes),
            ("perception.steps", self.perception.steps),
            ("collect.dataset.num_episodes", self.collect.dataset.num_episodes),
        ):
            if value <= 0:
                raise ValueError(f"--{name} must be positive, got {value}.")

    def validate_recovery_choice(self) -> None:
        """Refuse a choice the chosen row could not be measured for: candidates that know a task, that
        have no test row, or a choice without BVMC's own row to count rescues against."""
        choice = self.recovery_choice
        if not choice:
            return
        unknown = [m for m in choice if m not in CHOICE_ROWS]
        if unknown or len(set(choice)) != len(choice):
            raise ValueError(
                "--recovery_choice chooses among distinct modes that know no task (none, rand, init, "
                f"min_unc, retry, reach, their variants and triggers: lerobot_ivmc/pipeline/config.py); got "
                f"{choice}{f', unknown {unknown}' if unknown else ''}."
            )
        if choice == ["none"]:
            raise ValueError(
                "--recovery_choice=[none] has nothing to choose: list the modes to choose among."
            )
        missing = [m for m in [*choice, "none"] if m not in self.recovery_modes]
        if missing:
            raise ValueError(
                f"--recovery_choice needs test rows of its modes and of BVMC without recovery: add {missing} "
                "to --recovery_modes."
            )

    def validate_regime(self) -> None:
        """Refuse budgets and ranges the data-budget rule cannot use."""
        r = self.regime
        if len(r.failure_range) != 2 or not 0 <= r.failure_range[0] < r.failure_range[1] <= 1:
            raise ValueError(
                f"--regime.failure_range must be [low,high] with 0 <= low < high <= 1, got {r.failure_range}."
            )
        if r.demo_budgets and r.train_steps:
            raise ValueError(
                "--regime.demo_budgets and --regime.train_steps each set the budget the rule varies; "
                "give one."
            )
        if not (r.demo_budgets or r.train_steps):
            return
        if r.demo_budgets:
            flag, given = "demo_budgets", r.demo_budgets
            base_flag, base = "collect.dataset.num_episodes", self.collect.dataset.num_episodes
        else:
            flag, given, base_flag, base = "train_steps", r.train_steps, "train.steps", self.train.steps
        budgets = [base, *given]
        if any(b <= 0 for b in budgets) or any(a <= b for a, b in zip(budgets, budgets[1:], strict=False)):
            raise ValueError(
                f"--regime.{flag} must be positive and decreasing, each below --{base_flag}={base}, "
                f"got {given}."
            )
        if not 0 < r.batch_size <= r.n_episodes:
            raise ValueError(
                f"--regime.batch_size must be in [1, --regime.n_episodes={r.n_episodes}], got {r.batch_size}."
            )

    def validate_executor(self) -> None:
        """Refuse executors, devices and resource shares that cannot run."""
        e = self.executor
        if e.type not in EXECUTORS:
            raise ValueError(f"--executor.type must be one of {EXECUTORS}, got {e.type!r}.")
        if self.train.device not in TRAIN_DEVICES:
            raise ValueError(f"--train.device must be one of {TRAIN_DEVICES}, got {self.train.device!r}.")
        if e.type == "local" and (e.address is not None or e.num_cpus is not None):
            raise ValueError(
                "--executor.address and --executor.num_cpus set the Ray cluster: add --executor.type=ray or "
                "drop them."
            )
        if e.num_cpus is not None and e.num_cpus < 1:
            raise ValueError(f"--executor.num_cpus must be >= 1, got {e.num_cpus}.")
        if e.train_cpus <= 0 or e.eval_cpus <= 0:
            raise ValueError(
                f"--executor.train_cpus and --executor.eval_cpus must be positive, got {e.train_cpus} and "
                f"{e.eval_cpus}."
            )
        if not 0 < e.train_gpus <= 1:
            raise ValueError(
                f"--executor.train_gpus is the share of one GPU a training takes, in (0, 1]; got "
                f"{e.train_gpus}."
            )

    def validate_stage_values(self) -> None:
        """Refuse values a later stage would refuse, before hours of earlier stages are spent."""
        policy = self.train.policy
        demo_steps = self.collect.dataset.episode_steps
        if demo_steps is None:  # no task yet (the command refuses that): the checks below need its suite
            return
        self.suite.check_episode_steps("--collect.dataset.episode_steps", demo_steps)
        if not 1 <= policy.chunk_length <= demo_steps:
            raise ValueError(
                f"--train.policy.chunk_length must be in [1, {demo_steps}] (the demos' length, "
                f"--collect.dataset.episode_steps), got {policy.chunk_length}."
            )
        # The policy config's own checks (training mode, shift, ...), on the fields the trainings will get.
        try:
            resolved = VMCConfig(device="cpu", **policy.given())
        except ValueError as error:
            raise ValueError(f"--train.policy.{error}") from error
        if resolved.goal_head and policy.chunk_length != demo_steps:  # (sequence mode: checked above)
            raise ValueError(
                "The goal head (--train.policy.goal_head, on by default in sequence training) needs whole "
                f"demos: --train.policy.chunk_length={demo_steps} (--collect.dataset.episode_steps), or "
                "--train.policy.goal_head=false."
            )
        if self.threshold.method not in THRESHOLD_METHODS:
            raise ValueError(
                f"--threshold.method must be one of {THRESHOLD_METHODS}, got {self.threshold.method!r}."
            )
        if self.threshold.score not in SCORES:
            raise ValueError(f"--threshold.score must be one of {SCORES}, got {self.threshold.score!r}.")
        if not 0 < self.threshold.alpha < 1:
            raise ValueError(f"--threshold.alpha must be in (0, 1), got {self.threshold.alpha}.")
        if self.episode_length <= 0:
            raise ValueError(f"--episode_length must be positive, got {self.episode_length}.")
        if self.perception.steps > self.episode_length:
            raise ValueError(
                f"--perception.steps={self.perception.steps} is longer than an episode "
                f"(--episode_length={self.episode_length})."
            )
        # LeRobot's eval config refuses more parallel envs than episodes.
        for name, episodes in (("threshold", self.threshold), ("eval", self.eval), ("fig3", self.fig3)):
            if episodes.batch_size > episodes.n_episodes:
                raise ValueError(
                    f"--{name}.batch_size={episodes.batch_size} is more than --{name}.n_episodes="
                    f"{episodes.n_episodes}: lower the batch size or run more episodes."
                )
        if self.threshold.method == "conformal":
            needed = conformal_min_successes(self.threshold.alpha)
            if self.threshold.n_episodes < needed:
                raise ValueError(
                    f"A conformal threshold at --threshold.alpha={self.threshold.alpha} needs at least "
                    f"{needed} successful validation episodes: --threshold.n_episodes="
                    f"{self.threshold.n_episodes} cannot give them. Run more, or raise the alpha."
                )
        # The study sets these from --task, its folder and its own logs: another value would be ignored.
        c = self.collect
        if c.env.task and c.env.task != self.task:
            raise ValueError(
                f"--collect.env.task={c.env.task!r} differs from --task={self.task!r}: the study collects "
                "demos of its own task; drop --collect.env.task."
            )
        if c.dataset.root is not None:
            raise ValueError(
                "--collect.dataset.root is set by the study (<output_dir>/data); drop it, or pass "
                "--output_dir to put the study elsewhere."
            )

    @property
    def suite(self) -> DemoSuite:
        """The suite of the study's task (the Fetch tasks or MetaWorld)."""
        return suite_of(self.task)

    @property
    def root(self) -> Path:
        """The study's folder."""
        return Path(self.output_dir or Path("outputs") / "pipeline" / f"{self.task}_{self.preset}")
