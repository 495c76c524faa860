"""Files written all or nothing: a temporary sibling, flushed to disk, renamed into place. A reader (or a
rerun after a kill) sees the old file or the whole new one, never a part."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def atomic_write(path: Path, write: Callable[[BinaryIO], object]) -> None:
    """Call `write(file)` on a temporary sibling of `path`, fsync it, then rename it to `path`."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as file:
            write(file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_json_atomic(path: Path, payload, indent: int = 2) -> None:
    """`payload` as JSON (`indent` spaces, as `json.dumps` writes it) in `path`, all or nothing."""
    atomic_write(path, lambda file: file.write(json.dumps(payload, indent=indent).encode()))
