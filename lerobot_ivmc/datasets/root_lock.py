"""One writer per output folder (a collection root, an evaluation's output, a pipeline study): an OS-level
lock on a file in the folder that dies with its holder.

`fcntl.flock` locks belong to the open file, so the kernel releases them when the holder exits or is
killed (SIGKILL included): a killed collection never leaves a stale lock, and the next run takes it over.
The lock file holds the holder's pid, host, start time and command, so a refused run can name it. The
holder deletes the file before it lets the lock go; a run that locked a file which was deleted meanwhile
tries again on the new one, so two runs never hold locks on two different files of one root.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import socket
import sys
import time
from pathlib import Path

from lerobot_ivmc.datasets.staging import CollectionError

LOCK_FILE = ".ivmc_collect.lock"
EVAL_LOCK_FILE = ".ivmc_eval.lock"


class RootLock:
    """Exclusive, non-blocking lock of an output folder, as a context manager.

    Args:
        root: the folder; created (with its parents) if missing.
        lock_file: the lock file's name in it.
        writer: what writes the folder, for messages ("collector", "evaluation").
        flag: the command-line flag that names the folder, for messages.
        error: the exception raised on entry (the collector's `CollectionError` by default).

    Raises:
        `error`: on entry, when `root` is a file or cannot be created, or another process holds the lock
            (the message names it).
    """

    def __init__(
        self,
        root: Path,
        lock_file: str = LOCK_FILE,
        writer: str = "collector",
        flag: str = "--root",
        error: type[Exception] = CollectionError,
    ):
        self.root = Path(root)
        self.path = self.root / lock_file
        self.writer, self.flag, self.error = writer, flag, error
        self._fd: int | None = None
        self._created_root = False

    def __enter__(self) -> RootLock:
        if self.root.exists() and not self.root.is_dir():
            raise self.error(
                f"{self.flag} {self.root} is a file; give a folder (new, or one this command made)."
            )
        self._created_root = not self.root.exists()
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise self.error(f"Cannot create the folder {self.root} ({self.flag}): {error}.") from error
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as error:
                raise self.error(
                    f"Cannot write the lock file {self.path}: {error}; give a writable {self.flag}."
                ) from error
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise self.error(
                    f"{self.root} is being written by another {self.writer} ({_describe_holder(self.path)}). "
                    f"One {self.writer} writes a folder at a time: wait for it to finish or stop it, or pass "
                    f"another {self.flag}."
                ) from None
            if _same_file(fd, self.path):
                break
            os.close(fd)  # the holder deleted that file as it finished: lock the current one
        self._fd = fd
        holder = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": time.strftime("%Y-%m-%d %H:%M:%S"),
            "command": " ".join(sys.argv),
        }
        os.ftruncate(fd, 0)
        os.write(fd, json.dumps(holder).encode())
        return self

    def __exit__(self, *exc_info) -> None:
        if self._fd is None:
            return
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()  # before the lock goes, so that no later run locks this file
        os.close(self._fd)
        self._fd = None
        if self._created_root:
            with contextlib.suppress(OSError):
                self.root.rmdir()  # only if this run left it empty


def lock_holder(root: Path, lock_file: str) -> str | None:
    """Who holds the lock of `root` now (pid, host, start and command), or None if nobody does. Reads only:
    a missing lock file is not created, and a free lock is let go at once."""
    try:
        fd = os.open(Path(root) / lock_file, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return _describe_holder(Path(root) / lock_file)
    finally:
        os.close(fd)  # (closing lets a lock taken here go)
    return None


def _same_file(fd: int, path: Path) -> bool:
    try:
        on_disk = os.stat(path)
    except FileNotFoundError:
        return False
    held = os.fstat(fd)
    return (held.st_dev, held.st_ino) == (on_disk.st_dev, on_disk.st_ino)


def _describe_holder(path: Path, wait_s: float = 2.0) -> str:
    """The lock holder's pid, host, start time and command, as far as its lock file tells; a holder that has
    only just taken the lock writes them a moment later, so wait up to `wait_s` for them."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            holder = json.loads(path.read_text())
            started = f"started {holder['started']}: {holder['command']}"
            return f"pid {holder['pid']} on {holder['host']}, {started}"
        except (OSError, ValueError, KeyError, TypeError):
            if time.monotonic() >= deadline:
                return "pid unknown: it has only just started"
            time.sleep(0.05)
