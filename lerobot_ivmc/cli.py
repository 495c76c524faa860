"""The command-line runner: a bad input ends a command with the plugin's one-line message, not a traceback."""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable
from pathlib import Path

from draccus.utils import DecodingError, ParsingError

USER_ERRORS = (ValueError, FileExistsError, FileNotFoundError, ParsingError, DecodingError)


def root_message(error: BaseException) -> str:
    """The message of the error a config class raised, under draccus' wrappers."""
    while isinstance(error, ParsingError | DecodingError) and error.__cause__ is not None:
        error = error.__cause__
    return str(error)


def check_policy_path(argv: list[str]) -> None:
    """Refuse a `--policy.path` that is neither a folder here nor a hub repo id (LeRobot would take it for
    a malformed repo id and say so, not that the folder is missing)."""
    from huggingface_hub.utils import HFValidationError, validate_repo_id

    for arg in argv:
        if arg.startswith("--policy.path="):
            path = arg.split("=", 1)[1]
            if Path(path).exists():
                continue
            try:
                validate_repo_id(path)
            except HFValidationError:
                raise FileNotFoundError(
                    f"--policy.path={path}: no such folder (and not a hub repo id '<user>/<name>'); pass the "
                    "pretrained_model folder of a checkpoint."
                ) from None


def check_renamed_flags(argv: list[str]) -> None:
    """Refuse a flat flag of earlier versions with the nested one that replaced it."""
    from lerobot_ivmc.recovery.strategy_settings import renamed_flag

    for arg in argv:
        if (replacement := renamed_flag(arg)) is not None:
            raise ValueError(
                f"{arg} is now {replacement}: each recovery mode's settings are nested under it."
            )


def run_cli(main: Callable[[], object]) -> None:
    """Run `main`; a bad input exits with status 2 and `error: <message>` (IVMC_TRACEBACK=1 re-raises)."""
    try:
        check_policy_path(sys.argv[1:])
        check_renamed_flags(sys.argv[1:])
        main()
    except USER_ERRORS as error:
        if os.environ.get("IVMC_TRACEBACK"):
            raise
        print(f"error: {root_message(error)}", file=sys.stderr)
        sys.exit(2)


def cli_main(main: Callable[[], object]) -> None:
    """A console entry point: logging, LeRobot's plugin discovery, then `run_cli(main)`."""
    from lerobot.utils.import_utils import register_third_party_plugins

    logging.basicConfig(level=logging.INFO)
    register_third_party_plugins()
    run_cli(main)
