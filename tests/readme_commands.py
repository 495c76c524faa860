"""Run README.md's commands as written, with small counts, in a fresh folder; report each one's outcome.

    python tests/readme_commands.py [--readme=README.md] [--workdir=DIR] [--report=FILE]

Every command of the README's fenced ```bash blocks (line continuations joined, comments dropped) is
checked in the order the README gives them, in `--workdir` (a new temporary folder by default) as the
current folder, as from the root of a fresh clone:

- the clone's commands (`[project.scripts]` of its pyproject.toml) run as written, in this process through
  their entry points (one import of LeRobot for all of them, not one per command), with the counts made
  small: the flags of `SMALL_COUNTS` get the value there when the command has them, and the command gets the
  flags of `ADDED_SMALL_COUNTS` it does not have (the env's episode length, the foresight head's
  trajectories). Each must exit 0 and write what the README says it writes (`expected_outputs`).
- `lerobot-ivmc-pipeline` (a whole study: hours at `lite`, minutes even at `smoke`) is parsed, preset and
  flags, and its stages built, without running them (`tests/pipeline/` runs the smoke study end to end).
- `bash scripts/<name>.sh`: run.sh installs the environment and runs `lerobot-ivmc-demo` (which
  `tests/recovery/test_demo.py` runs end to end on the shipped checkpoint), test.sh lints and runs this
  suite; both reinstall the package into the environment with pip first, which a test must not do, so they
  are checked for syntax only.

A command this file has no plan for fails the check: nothing is skipped silently. The commands read from
the clone only `docs/results/` (the summary, the pooled seeds), which is copied into the folder first.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import json
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import traceback
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FENCE = re.compile(r"^\s*```+\s*([\w+-]*)")
SHELL_LANGUAGES = ("bash", "sh", "shell")

# Flags whose value becomes a small count wherever a README command has them (both spellings of
# lerobot-ivmc-collect's flags: LeRobot's draccus style and the short one).
SMALL_COUNTS = {
    "--dataset.num_episodes": "2",
    "--num-episodes": "2",
    "--num_workers": "0",  # two demos: recorded in-process, no workers to start
    "--num-workers": "0",
    "--steps": "2",
    "--save_freq": "2",
    "--batch_size": "2",
    "--env.episode_length": "30",
    "--eval.n_episodes": "2",
    "--eval.batch_size": "2",
    "--foresight.num_trajectories": "2",
    "--foresight.epochs": "2",
    "--foresight.ranking_states": "4",
    "--foresight.ranking_every": "10",
}
# The flags of SMALL_COUNTS added where a command has the key (its program, a flag name or a flag=value)
# and does not give them: short episodes, eval batches no larger than the episodes (LeRobot refuses
# larger ones), a tiny distillation.
ADDED_SMALL_COUNTS = {
    "--env.type=ivmc": ["--env.episode_length"],
    "--eval.n_episodes": ["--eval.batch_size"],
    "lerobot-ivmc-collect": ["--num_workers"],
    "lerobot-ivmc-foresight": [
        "--foresight.num_trajectories",
        "--foresight.epochs",
        "--foresight.ranking_states",
        "--foresight.ranking_every",
        "--eval.n_episodes",
        "--eval.batch_size",
    ],
}


@dataclass
class Command:
    """One command of the README: where it starts, its text as written and its arguments."""

    line: int  # 1-based README line of the command's first line
    text: str
    argv: list[str]

    @property
    def where(self) -> str:
        return f"README.md line {self.line}: `{self.text}`"


@dataclass
class Outcome:
    line: int
    command: str
    how: str  # "run", "dry parse" or "syntax"
    ok: bool
    seconds: float
    message: str = ""
    argv: list[str] = field(default_factory=list)


def extract_commands(markdown: str) -> list[Command]:
    """The commands of the fenced shell blocks: continuation lines joined, comments and blank lines dropped.

    Raises:
        ValueError: a fence left open, or a command that is not valid shell (naming its README line).
    """
    commands: list[Command] = []
    language: str | None = None  # the open block's language; None outside blocks
    pending: list[str] = []
    start = 0
    for number, line in enumerate(markdown.splitlines(), start=1):
        fence = FENCE.match(line)
        if fence:
            if language is None:
                language = fence.group(1).lower()
                continue
            if pending:
                raise ValueError(f"README.md line {start}: the command ends in `\\` at its block's end.")
            language = None
            continue
        if language not in SHELL_LANGUAGES:
            continue
        if not pending:
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            start = number
        stripped = line.rstrip()
        if stripped.endswith("\\"):
            pending.append(stripped[:-1])
            continue
        text = " ".join(part.strip() for part in [*pending, stripped])
        pending = []
        try:
            argv = shlex.split(text, comments=True)
        except ValueError as error:
            raise ValueError(f"README.md line {start}: not valid shell ({error}): `{text}`") from None
        if argv:
            commands.append(Command(start, shlex.join(argv), argv))
    if language is not None:
        raise ValueError("README.md: a fenced block is never closed.")
    return commands


def flag_value(argv: list[str], *names: str) -> str | None:
    """The value of the first of `names` given as `--name=value` or `--name value`."""
    for i, arg in enumerate(argv):
        for name in names:
            if arg.startswith(name + "="):
                return arg.split("=", 1)[1]
            if arg == name and i + 1 < len(argv):
                return argv[i + 1]
    return None


def with_small_counts(argv: list[str]) -> list[str]:
    """`argv` with the counts of SMALL_COUNTS made small and ADDED_SMALL_COUNTS' flags added if missing."""
    out = list(argv)
    for i, arg in enumerate(out):
        name = arg.split("=", 1)[0]
        if name in SMALL_COUNTS:
            if "=" in arg:
                out[i] = f"{name}={SMALL_COUNTS[name]}"
            elif i + 1 < len(out):
                out[i + 1] = SMALL_COUNTS[name]
    names = {arg.split("=", 1)[0] for arg in argv}
    for key, added in ADDED_SMALL_COUNTS.items():
        if key in argv or key in names:
            for name in added:
                spelled = spelled_as(name, argv)
                if spelled not in {arg.split("=", 1)[0] for arg in out}:
                    out.append(f"{spelled}={SMALL_COUNTS[name]}")
    return out


def spelled_as(name: str, argv: list[str]) -> str:
    """A flag's name as the command spells its own: lerobot-ivmc-collect's short style has `--num-workers`."""
    draccus_style = any(arg.startswith(("--env.", "--dataset.")) for arg in argv)
    return name.replace("_", "-") if argv[0] == "lerobot-ivmc-collect" and not draccus_style else name


def expected_outputs(argv: list[str]) -> list[str]:
    """The files a command writes, as the README and the command's docs say (relative to the folder)."""
    program, out = argv[0], flag_value(argv, "--output_dir")
    if program == "lerobot-ivmc-collect":
        root = flag_value(argv, "--dataset.root", "--root")
        return [f"{root}/meta/info.json"]
    if program == "lerobot-ivmc-train":
        return [f"{out}/checkpoints/last/pretrained_model/model.safetensors"]
    if program == "lerobot-ivmc-foresight":
        return [f"{out}/pretrained_model/model.safetensors", f"{out}/foresight_report.json"]
    if program == "lerobot-ivmc-threshold":
        return [f"{out}/pretrained_model/recovery_threshold.json"]
    if program == "lerobot-ivmc-eval":
        return [f"{out}/eval_info.json"]
    if program == "lerobot-ivmc-detect":
        return [f"{out or Path(str(flag_value(argv, '--eval_dir'))) / 'detection'}/detection.json"]
    if program == "lerobot-ivmc-inspect":
        seed = flag_value(argv, "--episode_seed") or "0"
        return [f"{out}/inspect_seed{seed}.json", f"{out}/inspect_seed{seed}.png"]
    if program == "lerobot-ivmc-summary":
        folder = out or flag_value(argv, "--results_dir")
        return [f"{folder}/reproduction.md", f"{folder}/reproduction.json"]
    if program == "lerobot-ivmc-pool-seeds":
        pooled = str(flag_value(argv, "--output"))
        return [pooled, str(Path(pooled).with_suffix(".md"))]
    return []


def console_scripts() -> dict[str, str]:
    """The clone's commands, `[project.scripts]` of its pyproject.toml: name -> "module:function" (read from
    the clone, not from the installed metadata, which an older install may have left behind)."""
    return tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]


def command_module(name: str):
    """The module of command `name`, imported."""
    return importlib.import_module(console_scripts()[name].partition(":")[0])


def run_entry_point(argv: list[str]) -> tuple[int, str]:
    """Call the console entry point `argv[0]` in this process with `argv[1:]`; its exit status and stdout."""
    stdout = io.StringIO()

    class Tee(io.TextIOBase):
        def write(self, text: str) -> int:
            stdout.write(text)
            return sys.__stdout__.write(text)

        def flush(self) -> None:
            sys.__stdout__.flush()

    saved_argv, sys.argv = sys.argv, list(argv)
    try:
        main = getattr(command_module(argv[0]), console_scripts()[argv[0]].partition(":")[2])
        with contextlib.redirect_stdout(Tee()):
            status = main()
    except SystemExit as done:
        status = done.code
    except BaseException:  # a crash is this command's failure, reported with its README line
        traceback.print_exc()
        status = 1
    finally:
        sys.argv = saved_argv
    if isinstance(status, str):
        print(status, file=sys.stderr)
        status = 1
    return int(status or 0), stdout.getvalue()


def run_command(command: Command, workdir: Path) -> Outcome:
    argv = with_small_counts(command.argv)
    start = time.perf_counter()
    status, stdout = run_entry_point(argv)
    missing = [path for path in expected_outputs(argv) if not (workdir / path).is_file()]
    ok, message = status == 0 and not missing, ""
    if status != 0:
        message = f"exited {status}"
    elif missing:
        message = f"wrote none of {missing}"
    elif argv[0] == "lerobot-ivmc-compare" and "McNemar" not in stdout:
        ok, message = False, "printed no McNemar test"
    return Outcome(command.line, command.text, "run", ok, time.perf_counter() - start, message, argv)


def dry_parse_pipeline(command: Command, workdir: Path) -> Outcome:
    start = time.perf_counter()
    try:
        from lerobot_ivmc.pipeline.stages import build_stages

        parse_config = command_module(
            command.argv[0]
        ).parse_config  # the command's own parser: preset + flags
        stages = build_stages(parse_config(command.argv[1:]))
        ok, message = bool(stages), f"{len(stages)} stages"
    except (Exception, SystemExit) as error:  # draccus exits on an unknown flag
        traceback.print_exc()
        ok, message = False, f"does not parse: {error!r}"
    return Outcome(command.line, command.text, "dry parse", ok, time.perf_counter() - start, message)


def check_shell_script(command: Command, workdir: Path) -> Outcome:
    start = time.perf_counter()
    script = REPO / command.argv[1] if len(command.argv) > 1 else None
    if script is None or not script.is_file():
        return Outcome(command.line, command.text, "syntax", False, 0.0, "no such script in the clone")
    done = subprocess.run(["bash", "-n", str(script)], capture_output=True, text=True)
    return Outcome(
        command.line, command.text, "syntax", done.returncode == 0, time.perf_counter() - start, done.stderr
    )


def plan_for(command: Command) -> Callable[[Command, Path], Outcome] | None:
    """How a command is checked; None for a command this file does not know (a failure)."""
    program = command.argv[0]
    if program == "bash" and len(command.argv) >= 2 and command.argv[1].startswith("scripts/"):
        return check_shell_script
    if program == "lerobot-ivmc-pipeline":
        return dry_parse_pipeline
    if program in console_scripts():
        return run_command
    return None


def check_readme(readme: Path, workdir: Path) -> list[Outcome]:
    """Check every command of `readme` in `workdir`, stopping at the first failure (later ones need it)."""
    commands = extract_commands(readme.read_text())
    shutil.copytree(REPO / "docs" / "results", workdir / "docs" / "results", dirs_exist_ok=True)
    outcomes = []
    with contextlib.chdir(workdir):
        for command in commands:
            plan = plan_for(command)
            print(f"\n[{command.where}]", flush=True)
            if plan is None:
                outcome = Outcome(command.line, command.text, "none", False, 0.0, "no plan to check it")
            else:
                try:
                    outcome = plan(command, workdir)
                except Exception as error:  # reported with the README line, not as a crash of the check
                    traceback.print_exc()
                    outcome = Outcome(command.line, command.text, "crash", False, 0.0, f"raised {error!r}")
            print(f"[README.md line {command.line}: {outcome.how}, {outcome.seconds:.1f} s, "
                  f"{'ok' if outcome.ok else 'FAILED'}] {outcome.message}", flush=True)  # fmt: skip
            outcomes.append(outcome)
            if not outcome.ok:
                break
    return outcomes


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--readme", type=Path, default=REPO / "README.md")
    parser.add_argument("--workdir", type=Path, default=None, help="default: a new temporary folder")
    parser.add_argument("--report", type=Path, default=None, help="write the outcomes as JSON here")
    args = parser.parse_args()
    workdir = args.workdir or Path(tempfile.mkdtemp(prefix="readme_commands_"))
    workdir.mkdir(parents=True, exist_ok=True)
    outcomes = check_readme(args.readme.resolve(), workdir.resolve())
    if args.report:
        args.report.write_text(json.dumps([asdict(o) for o in outcomes], indent=1))
    print(f"\n{sum(o.ok for o in outcomes)} of {len(outcomes)} README commands passed in {workdir}")
    return 0 if outcomes and all(o.ok for o in outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
