"""The study's stages: each one a command of this project, its own output folder and the file that marks it
done. `build_stages` turns a `PipelineConfig` into the ordered list the runner executes.

collect, then for each #fc a chain per training seed (the main one, then each extra one): train vmc and
bvmc, each checked right after its training (did it learn where the object is?) -> foresight -> threshold
-> evals of the Table I rows on the same test scenes -> Fig. 3 episodes -> detection metrics. (The
results table is written by the runner.)
"""

from __future__ import annotations

import json
import shutil
import sys
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from lerobot.configs.policies import PreTrainedConfig

from lerobot_ivmc.constants import EVAL_INFO_FILE, LAST_PRETRAINED_MODEL, PRETRAINED_MODEL_DIR
from lerobot_ivmc.envs import task_env_class
from lerobot_ivmc.evaluation.perception_check import RECORD_FILE as PERCEPTION_RECORD
from lerobot_ivmc.hardware import cpu_has_native_bf16
from lerobot_ivmc.pipeline.config import ROW_FLAGS, PipelineConfig, row_mode
from lerobot_ivmc.pipeline.stage_names import (
    COLLECT_STAGE,
    chain_folder,
    choice_stage_name,
    detect_stage_name,
    eval_stage_name,
    fig3_stage_name,
    foresight_stage_name,
    perception_stage_name,
    threshold_stage_name,
    train_stage_name,
)
from lerobot_ivmc.recovery.strategy_settings import (
    MAX_HELD_OFFSET,
    AnchorSettings,
    ReachSettings,
    RetrySettings,
)

CHECKPOINT = LAST_PRETRAINED_MODEL
# The `--env.type` of each suite's tasks.
ENV_TYPES = {"ivmc": "ivmc", "metaworld": "meta_world"}
CUDA = "cuda"
TRAIN_CONFIG = CHECKPOINT / "train_config.json"


@dataclass(frozen=True)
class StageResources:
    """What a stage takes while it runs, for an executor that runs stages side by side (not in the stage's
    fingerprint): CPUs (its threads), a share of a GPU, and memory in bytes (0: not reserved)."""

    cpus: float = 1.0
    gpus: float = 0.0
    memory: int = 0


@dataclass
class Stage:
    """One step of the study.

    Attributes:
        name: unique name, also of its log file and record.
        argv: the command (console script name first).
        output: the folder the stage owns: removed before the stage is redone.
        done_file: a file the command writes last; the stage counts as done only if it exists.
        depends: names of the stages whose outputs it reads.
        env: environment variables for the command.
        resume_argv: the command that continues a killed run of the same config from its partial output
            (the collector resumes itself, so its own command; a training continues from its last
            checkpoint). None: a killed stage is redone from a clean folder.
        resume_marker: a file the partial output must hold for `resume_argv` to apply (a training's last
            checkpoint); None if any partial output will do.
        settings: what decides the outputs beyond the command line (a training's policy config with the
            defaults of the fields the command leaves out), so that a changed default redoes the stage.
        after: stages that must finish first although it reads nothing of theirs (the perception check
            that gates a chain); not in the fingerprint.
        resources: what it takes while it runs (for the ray executor); not in the fingerprint.
    """

    name: str
    argv: list[str]
    output: Path
    done_file: Path
    depends: list[str] = field(default_factory=list)
    env: dict[str, str] = field(default_factory=dict)
    resume_argv: list[str] | None = None
    resume_marker: Path | None = None
    settings: dict = field(default_factory=dict)
    after: list[str] = field(default_factory=list)
    resources: StageResources = field(default_factory=StageResources)

    @property
    def prerequisites(self) -> list[str]:
        """Every stage that must finish before this one starts."""
        return [*self.depends, *self.after]

    def can_resume(self) -> bool:
        """Whether a killed run of this stage's config can be continued rather than redone."""
        return self.resume_argv is not None and (self.resume_marker is None or self.resume_marker.exists())


def console_script(name: str) -> str:
    """Path of one of this environment's console scripts (next to the interpreter), else from PATH."""
    script = Path(sys.executable).with_name(name)
    if script.exists():
        return str(script)
    found = shutil.which(name)
    if found is None:
        raise FileNotFoundError(f"{name} is not installed in this environment: pip install -e . first.")
    return found


def flags(prefix: str, values: dict) -> list[str]:
    """`--<prefix><key>=<value>` for every entry (lists as draccus reads them, booleans lower case)."""
    out = []
    for key, value in values.items():
        if isinstance(value, bool):
            value = str(value).lower()
        elif isinstance(value, (list, tuple)):
            value = "[" + ",".join(str(v) for v in value) + "]"
        out.append(f"--{prefix}{key}={value}")
    return out


def build_stages(cfg: PipelineConfig) -> list[Stage]:
    """The ordered stages of the study of `cfg.task` in `cfg.root`."""
    chain = chain_flags(cfg)
    stages = [collect_stage(cfg, chain.data, chain.repo_id)]
    # One #fc after the other, so that a long study has the first #fc's rows while the next one trains; in
    # an #fc, the main training seed's chain first, then each extra seed's.
    for fc in cfg.train.num_fc_layers:
        stages += chain_stages(cfg, fc, None, chain)
        for train_seed in cfg.train.extra_seeds:
            stages += chain_stages(cfg, fc, train_seed, chain)
    for stage in stages:
        stage.resources = stage_resources(cfg, stage)
    return stages


# Memory a training takes beside its frame cache (the process, torch, the batch), in bytes.
TRAINING_BASE_MEMORY = 2 * 2**30


def stage_resources(cfg: PipelineConfig, stage: Stage) -> StageResources:
    """What `stage` takes while it runs: the collector its workers, a training `executor.train_cpus` (and
    `train_gpus` of a GPU on CUDA) and the memory of its frame cache (every demo frame as uint8), the others
    `executor.eval_cpus`."""
    e, command = cfg.executor, stage.argv[0]
    if command == "lerobot-ivmc-collect":
        return StageResources(cpus=max(1, cfg.collect.num_workers))
    if command == "lerobot-ivmc-train":
        c = cfg.collect
        frames = c.dataset.num_episodes * c.dataset.episode_steps * c.env.image_size**2 * 3
        on_gpu = f"--policy.device={CUDA}" in stage.argv
        return StageResources(e.train_cpus, e.train_gpus if on_gpu else 0.0, frames + TRAINING_BASE_MEMORY)
    return StageResources(cpus=e.eval_cpus)


def train_device(cfg: PipelineConfig) -> str:
    """The trainings' device: `train.device`, with "auto" resolved on this machine (CUDA if present)."""
    if cfg.train.device != "auto":
        return cfg.train.device
    import torch

    return CUDA if torch.cuda.is_available() else "cpu"


def mixed_precision(cfg: PipelineConfig, device: str) -> str:
    """`ACCELERATE_MIXED_PRECISION` of the trainings: bf16 where `train.bf16` and the device runs it
    natively (a GPU, or a CPU with AVX512-BF16 or AMX), else "no"."""
    native = device == CUDA or cpu_has_native_bf16()
    return "bf16" if cfg.train.bf16 and native else "no"


def collect_stage(cfg: PipelineConfig, data: Path, repo_id: str) -> Stage:
    """`lerobot-ivmc-collect` of the study's demos into `data`."""
    c = cfg.collect
    task = cfg.task
    collect = [
        "lerobot-ivmc-collect",
        f"--env.task={task}",
        *flags(
            "env.",
            {"split": c.env.split, "image_size": c.env.image_size, "render_style": c.env.render_style},
        ),
        f"--dataset.root={data}",
        f"--dataset.repo_id={c.dataset.repo_id or repo_id}",
        *flags(
            "dataset.",
            {
                "num_episodes": c.dataset.num_episodes,
                "video": c.dataset.video,
                "push_to_hub": c.dataset.push_to_hub,
                "private": c.dataset.private,
            },
        ),
        # Only when not the suite's default, so the studies of 100-step Fetch demos keep their fingerprints.
        *(
            [f"--dataset.episode_steps={c.dataset.episode_steps}"]
            if c.dataset.episode_steps != cfg.suite.default_episode_steps
            else []
        ),
        *flags("", {"num_workers": c.num_workers, "seed": c.seed, "action_noise": c.action_noise}),
        # Only when not the default, so the studies of held demos keep their fingerprints.
        *([f"--expert_after_success={c.expert_after_success}"] if c.expert_after_success != "hold" else []),
        "--progress=false",
    ]
    # The collector resumes its own staged demos: a killed collection reruns its command.
    return Stage(
        COLLECT_STAGE,
        collect,
        data,
        data / "meta" / "info.json",
        resume_argv=collect,
    )


@dataclass
class ChainFlags:
    """What every chain of a study shares: the demos and the env flags of its stages."""

    data: Path
    repo_id: str
    env_flags: list[str]
    eval_env_flags: list[str]
    async_flag: str
    bvmc_flags: list[str]  # of every stage that rolls the bvmc out under the recovery controller


def chain_flags(cfg: PipelineConfig) -> ChainFlags:
    """The study's demos (`<root>/data`) and the env flags of its stages."""
    c = cfg.collect
    # The camera of the demos is the camera of every later stage: the policies are refused in another.
    env_flags = [
        f"--env.type={ENV_TYPES[cfg.suite.name]}",
        f"--env.task={cfg.task}",
        f"--env.episode_length={cfg.episode_length}",
        *flags("env.", {"image_size": c.env.image_size, "render_style": c.env.render_style}),
    ]
    # Evaluation-like stages: sub-envs in parallel processes or not; no LeRobot eval videos (never read).
    async_flag = f"--eval.use_async_envs={str(cfg.async_envs).lower()}"
    eval_env_flags = [*env_flags, async_flag, "--max_episodes_rendered=0"]
    # Only when not the default, so that the studies made with a batch's draws keep their fingerprints.
    streams = [] if cfg.random_streams == "batch" else [f"--recovery.random_streams={cfg.random_streams}"]
    data = cfg.root.resolve() / "data"
    return ChainFlags(
        data, c.dataset.repo_id or f"local/ivmc_{cfg.task}", env_flags, eval_env_flags, async_flag, streams
    )


def chain_stages(cfg: PipelineConfig, fc: int, train_seed: int | None, chain: ChainFlags) -> list[Stage]:
    """The whole chain of one training seed (None: the main one) and #fc: vmc and bvmc trained and checked,
    foresight, threshold, the Table I rows on the test scenes, the Fig. 3 episodes and detection. Stages of
    an extra seed carry its suffix (`foresight_fc1_seed2000`); those of the main seed have none."""
    stages, gates = [], []
    for training in train_stages(cfg, fc, chain.data, chain.repo_id, train_seed):
        stages.append(training)
        if cfg.suite.name != "ivmc":  # the perception check reads the Fetch tasks' object position
            continue
        check = perception_stage(cfg, training, chain.env_flags, gate=train_seed is None)
        stages.append(check)
        gates += [check.name] if train_seed is None else []
    foresight = foresight_stage(cfg, fc, train_seed, chain)
    threshold = threshold_stage(cfg, fc, train_seed, chain, foresight)
    rows = row_stages(cfg, fc, train_seed, chain, threshold)
    # The main seed's checks stop the study before foresight and evaluations are spent on its policies: the
    # stages that do not already wait for them through foresight wait for them explicitly.
    for stage in [foresight, *rows]:
        if threshold.name not in stage.depends:
            stage.after = list(gates)
    choices = choice_stages(cfg, fc, train_seed, chain, threshold)
    stages += [foresight, threshold, *rows, *choices]
    detect = detect_stage(cfg, fc, train_seed, stages, threshold)
    # The chain's last stage in every order, so that its end is the chain's (the results are written then).
    detect.after = [stage.name for stage in [*rows, *choices] if stage.name not in detect.depends]
    return [*stages, detect]


def foresight_stage(cfg: PipelineConfig, fc: int, train_seed: int | None, chain: ChainFlags) -> Stage:
    """`lerobot-ivmc-foresight`: the chain's bvmc with its foresight head distilled."""
    root = cfg.root.resolve()
    folder = chain_folder(fc, train_seed)
    bvmc = root / "train" / f"bvmc_{folder}" / CHECKPOINT
    foresight = root / "foresight" / folder
    f = cfg.foresight
    distillation = asdict(f.foresight)
    # At 0 (the paper's plain samples) the flag is left out, so older studies keep their fingerprints.
    if distillation["action_noise"] == 0:
        del distillation["action_noise"]
    return Stage(
        foresight_stage_name(fc, train_seed),
        [
            "lerobot-ivmc-foresight",
            f"--policy.path={bvmc}",
            *chain.env_flags,
            *flags("foresight.", distillation),
            f"--eval.batch_size={f.batch_size}",
            f"--eval.n_episodes={f.batch_size}",
            chain.async_flag,
            f"--seed={cfg.seed}",
            f"--output_dir={foresight}",
        ],
        output=foresight,
        done_file=foresight / PRETRAINED_MODEL_DIR / "model.safetensors",
        depends=[train_stage_name("bvmc", fc, train_seed)],
    )


def threshold_stage(
    cfg: PipelineConfig, fc: int, train_seed: int | None, chain: ChainFlags, foresight: Stage
) -> Stage:
    """`lerobot-ivmc-threshold` on validation scenes: the checkpoint every BVMC row evaluates."""
    threshold = cfg.root.resolve() / "threshold" / chain_folder(fc, train_seed)
    th = cfg.threshold
    return Stage(
        threshold_stage_name(fc, train_seed),
        [
            "lerobot-ivmc-threshold",
            f"--policy.path={foresight.output / PRETRAINED_MODEL_DIR}",
            *chain.eval_env_flags,
            "--env.split=val",
            f"--eval.n_episodes={th.n_episodes}",
            f"--eval.batch_size={th.batch_size}",
            f"--method={th.method}",
            f"--alpha={th.alpha}",
            # Only when not the paper's, so that the studies picked on it keep their fingerprints.
            *([f"--score={th.score}"] if th.score != "window_sum" else []),
            *chain.bvmc_flags,
            f"--seed={cfg.seed}",
            f"--output_dir={threshold}",
        ],
        output=threshold,
        done_file=threshold / PRETRAINED_MODEL_DIR / "recovery_threshold.json",
        depends=[foresight.name],
    )


def row_stages(
    cfg: PipelineConfig, fc: int, train_seed: int | None, chain: ChainFlags, threshold: Stage
) -> list[Stage]:
    """The Table I rows on the test scenes (VMC, BVMC with each recovery mode) and, when it needs more
    episodes than a row, the Fig. 3 evaluation."""
    root = cfg.root.resolve()
    folder = chain_folder(fc, train_seed)
    seed = f"--seed={cfg.seed}"
    bvmc = threshold.output / PRETRAINED_MODEL_DIR
    vmc = root / "train" / f"vmc_{folder}" / CHECKPOINT
    rows = [("vmc", vmc, None, train_stage_name("vmc", fc, train_seed))] if cfg.train.vmc else []
    rows += [("bvmc", bvmc, mode, threshold.name) for mode in cfg.recovery_modes]
    # anchor reads a pushed object, or one held at the end, where the frame position head places it (and the
    # latter's goal too): a policy without that head reads them from the memory's heads instead.
    anchor_flags = []
    task = task_env_class(cfg.task) if cfg.anchor_rows else None
    if task is not None and cfg.train.policy.frame_position_head is False:
        if not task.object_picked or task.object_held_at_end:
            anchor_flags.append("--recovery.anchor.object=memory")
        if task.object_held_at_end:
            anchor_flags.append("--recovery.anchor.goal=memory")
    stages = []
    for policy_type, checkpoint, mode, source in rows:
        name = eval_stage_name(policy_type, fc, mode, train_seed)
        out = root / "eval" / name.removeprefix("eval_")
        episodes = cfg.eval
        stages.append(
            eval_stage(
                name,
                checkpoint,
                out,
                chain.eval_env_flags,
                episodes.n_episodes,
                episodes.batch_size,
                seed,
                row_mode(mode) if mode else None,
                source,
                recovery_flags=bvmc_row_flags(mode, chain, anchor_flags),
                task=cfg.task,
            )
        )
    fig3 = fig3_stage_name(cfg, fc, train_seed)
    if fig3 != eval_stage_name("bvmc", fc, "none", train_seed):
        out = root / "fig3" / folder
        episodes = cfg.fig3
        stages.append(
            eval_stage(
                fig3,
                bvmc,
                out,
                chain.eval_env_flags,
                episodes.n_episodes,
                episodes.batch_size,
                seed,
                "none",
                threshold.name,
                recovery_flags=chain.bvmc_flags,
            )
        )
    return stages


def choice_stages(
    cfg: PipelineConfig, fc: int, train_seed: int | None, chain: ChainFlags, threshold: Stage
) -> list[Stage]:
    """Each `--recovery_choice` mode on the threshold's validation scenes, with the threshold's checkpoint:
    what the chosen row is chosen by (`recovery_choice.py`)."""
    th = cfg.threshold
    folder = cfg.root.resolve() / "choice" / chain_folder(fc, train_seed)
    return [
        eval_stage(
            choice_stage_name(fc, mode, train_seed),
            threshold.output / PRETRAINED_MODEL_DIR,
            folder / mode,
            chain.eval_env_flags,
            th.n_episodes,
            th.batch_size,
            f"--seed={cfg.seed}",
            row_mode(mode),
            threshold.name,
            split="val",
            recovery_flags=bvmc_row_flags(mode, chain, []),
            task=cfg.task,
        )
        for mode in cfg.recovery_choice
        if mode != "none"  # no recovery: the threshold's own validation run
    ]


def bvmc_row_flags(row: str | None, chain: ChainFlags, anchor_flags: list[str]) -> list[str]:
    """The recovery flags of a Table I row: none for VMC's (`row` None), the chain's for a BVMC row,
    `anchor_flags` for anchor's rows and a control or variant row's own flags."""
    if row is None:
        return []
    own = ROW_FLAGS[row][1] if row in ROW_FLAGS else ()
    return [*chain.bvmc_flags, *(anchor_flags if row_mode(row) == "anchor" else []), *own]


def detect_stage(
    cfg: PipelineConfig, fc: int, train_seed: int | None, chain_so_far: list[Stage], threshold: Stage
) -> Stage:
    """`lerobot-ivmc-detect` on the Fig. 3 episodes with the chain's threshold."""
    fig3 = fig3_stage_name(cfg, fc, train_seed)
    detection = cfg.root.resolve() / "detection" / chain_folder(fc, train_seed)
    return Stage(
        detect_stage_name(fc, train_seed),
        [
            "lerobot-ivmc-detect",
            f"--eval_dir={stage_output(chain_so_far, fig3)}",
            f"--threshold_path={threshold.output / PRETRAINED_MODEL_DIR}",
            f"--alpha={cfg.threshold.alpha}",
            f"--output_dir={detection}",
        ],
        output=detection,
        done_file=detection / "detection.json",
        depends=[fig3, threshold.name],
    )


def train_stages(
    cfg: PipelineConfig, fc: int, data: Path, repo_id: str, train_seed: int | None = None
) -> list[Stage]:
    """`lerobot-ivmc-train` of vmc and bvmc with `fc` fully connected layers on the collected demos, from
    the main training seed or from `train_seed`, one of the extra ones."""
    t = cfg.train
    device = train_device(cfg)
    # lerobot-ivmc-train checks the style against the dataset's record; here it also enters the fingerprint.
    policy_fields = {**t.policy.given(), "render_style": cfg.collect.env.render_style}
    stages = []
    for policy_type in t.policy_types:
        name = train_stage_name(policy_type, fc, train_seed)
        out = cfg.root.resolve() / "train" / f"{policy_type}_{chain_folder(fc, train_seed)}"
        stages.append(
            Stage(
                name,
                [
                    "lerobot-ivmc-train",
                    f"--policy.type={policy_type}",
                    f"--policy.device={device}",
                    f"--policy.num_fc_layers={fc}",
                    *flags("policy.", policy_fields),
                    f"--dataset.repo_id={repo_id}",
                    f"--dataset.root={data}",
                    *flags(
                        "",
                        {
                            "batch_size": t.batch_size,
                            "steps": t.steps,
                            "seed": t.seed if train_seed is None else train_seed,
                        },
                    ),
                    f"--save_freq={min(t.save_freq, t.steps)}",
                    "--num_workers=0",
                    "--eval_freq=0",
                    "--policy.push_to_hub=false",
                    "--wandb.enable=false",
                    f"--output_dir={out}",
                ],
                output=out,
                done_file=out / CHECKPOINT / "model.safetensors",
                depends=[COLLECT_STAGE],
                env={"ACCELERATE_MIXED_PRECISION": mixed_precision(cfg, device)},
                # LeRobot's own resume: steps, schedule, optimiser and RNG states from the last checkpoint.
                resume_argv=["lerobot-ivmc-train", f"--config_path={out / TRAIN_CONFIG}", "--resume=true"],
                resume_marker=out / TRAIN_CONFIG,
                settings=resolved_policy_config(policy_type, fc, policy_fields),
            )
        )
    return stages


# Policy fields a training takes from its dataset, not from its command or the defaults: their input (the
# collect stage) is in the fingerprint already. As settings they would change every training's fingerprint
# when such a field is added (`trained_task` did), redoing the trainings of every study begun before.
FROM_THE_DATASET = ("trained_task", "aux_state_indices")
# Fields added since studies were recorded, left out of the settings at the value that acts as before they
# existed, so that those studies keep their fingerprints.
OMITTED_AT = {"image_size": None, "gripper_levels": None, "gripper_head": "classes"}


def resolved_policy_config(policy_type: str, fc: int, given: dict) -> dict:
    """The fields of the policy's own config (not LeRobot's base ones, e.g. hub settings, nor those it takes
    from its dataset) a training gets from `given` and the policy's current defaults, as JSON values."""
    config = PreTrainedConfig.get_choice_class(policy_type)(device="cpu", num_fc_layers=fc, **given)
    left_out = {f.name for f in fields(PreTrainedConfig)} | set(FROM_THE_DATASET)
    own = {
        name: value
        for name, value in asdict(config).items()
        if name not in left_out and not (name in OMITTED_AT and value == OMITTED_AT[name])
    }
    return json.loads(json.dumps(own, default=str))


def perception_stage(cfg: PipelineConfig, training: Stage, env_flags: list[str], gate: bool) -> Stage:
    """`lerobot-ivmc-perception` on validation scenes right after `training`: whether the policy misjudges
    the object's position by more than `perception.max_object_error_cm`. With `gate` (the main training
    seed) such a policy fails the stage, which stops the study; otherwise (extra seeds) the verdict is only
    recorded. No stage reads it, so its settings change no other stage's fingerprint."""
    p = cfg.perception
    name = perception_stage_name(training.name)
    out = cfg.root.resolve() / "perception" / name.removeprefix("check_")
    return Stage(
        name,
        [
            "lerobot-ivmc-perception",
            f"--policy.path={training.output / CHECKPOINT}",
            *env_flags,
            "--env.split=val",
            f"--n_scenes={p.n_scenes}",
            f"--steps={p.steps}",
            f"--seed={cfg.seed}",
            f"--max_object_error_cm={p.max_object_error_cm}",
            *([] if gate else ["--fail_above_limit=false"]),
            f"--output_dir={out}",
        ],
        output=out,
        done_file=out / PERCEPTION_RECORD,
        depends=[training.name],
    )


def find_stage(stages: list[Stage], name: str) -> Stage:
    return next(stage for stage in stages if stage.name == name)


def stage_output(stages: list[Stage], name: str) -> Path:
    return find_stage(stages, name).output


def eval_stage(
    name: str,
    checkpoint: Path,
    out: Path,
    env_flags: list[str],
    n_episodes: int,
    batch_size: int,
    seed: str,
    mode: str | None,
    source: str,
    split: str = "test",
    recovery_flags: list[str] | None = None,
    task: str | None = None,
) -> Stage:
    """`lerobot-ivmc-eval` on `split` scenes (with `--recovery.mode` and `recovery_flags` for the BVMC
    rows; the settings of a strategy beyond the paper, resolved for `task`, enter its fingerprint)."""
    return Stage(
        name,
        [
            "lerobot-ivmc-eval",
            f"--policy.path={checkpoint}",
            *env_flags,
            f"--env.split={split}",
            f"--eval.n_episodes={n_episodes}",
            f"--eval.batch_size={batch_size}",
            seed,
            *([f"--recovery.mode={mode}"] if mode else []),
            *(recovery_flags or []),
            f"--output_dir={out}",
        ],
        output=out,
        done_file=out / EVAL_INFO_FILE,
        depends=[source],
        settings=strategy_settings(mode, task),
    )


def strategy_settings(mode: str | None, task: str | None) -> dict:
    """The settings of a row's strategy beyond the paper as they act on `task`: anchor's (its defaults
    resolved for the task's object), retry's and reach's. They are chosen on validation scenes and may
    change, which must redo the row. The paper's modes keep the paper's defaults and no settings (so their
    rows keep their fingerprints)."""
    if mode == "retry":
        retry = RetrySettings()  # (start_radius only where it acts, so the recorded rows keep theirs)
        return {
            "retry_steps": retry.steps,
            **({"retry_start_radius": retry.start_radius} if retry.start_radius else {}),
        }
    if mode == "reach":
        reach = asdict(ReachSettings())
        # (the newer fields only where they act, so the recorded rows keep their fingerprints)
        if not reach["carry"]:
            del reach["carry"], reach["goal_steps"], reach["release"]
        del reach["push"]  # (a row's own flag: its rows' argv hold it)
        firsts = (
            ("object", "memory"),
            ("goal", "memory"),
            ("max_held_offset", MAX_HELD_OFFSET),
            ("push_legs", 2),
        )
        for name, first in firsts:
            if reach[name] == first:
                del reach[name]
        return {"reach": reach}
    if mode != "anchor":
        return {}
    anchor = AnchorSettings()
    if task is not None:
        anchor = anchor.for_traits(task_env_class(task).traits())
    return json.loads(json.dumps(anchor.as_flat_dict()))  # (the keys the recorded rows' fingerprints hold)
