"""`python <this file> <command...>`: runs one stage's command for a Ray worker and dies with the worker,
taking the command's whole process group (its env workers, its data loaders) with it, so that a killed
worker or driver leaves nothing running.

It is started as the leader of a new process group (`run_command(..., tied_to_parent=True)`), which the
command joins. The kernel kills it when its parent, the worker, dies (Linux `PR_SET_PDEATHSIG`); Ray also
kills a dead worker's children. Either way a guard it forks beforehand, outside the group, sees the end of a
pipe only this process holds and kills the group. It exits with the command's exit code (and the guard
clears whatever of the group is left).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
import sys

PR_SET_PDEATHSIG = 1
# Set by the parent: its pid, to tell whether it died before the death signal was armed.
PARENT_PID_VARIABLE = "IVMC_STAGE_PARENT_PID"


def guard(group: int) -> int:
    """Fork a process, in a group of its own, that kills process group `group` once this process is gone;
    returns the pipe end whose closing (this process's death) sets it off."""
    read_end, write_end = os.pipe()
    if os.fork() == 0:
        os.close(write_end)
        os.setpgid(0, 0)
        with contextlib.suppress(OSError):
            os.read(read_end, 1)  # returns at EOF: the other end's only holder died
        with contextlib.suppress(ProcessLookupError):
            os.killpg(group, signal.SIGKILL)
        os._exit(0)
    os.close(read_end)
    return write_end


def main() -> None:
    prctl = getattr(ctypes.CDLL(None, use_errno=True), "prctl", None)
    if prctl is not None:  # Linux; elsewhere Ray's killing of a dead worker's children sets the guard off
        prctl(PR_SET_PDEATHSIG, signal.SIGKILL)
    if str(os.getppid()) != os.environ.get(PARENT_PID_VARIABLE, str(os.getppid())):
        sys.exit(1)  # the parent died before the death signal was armed
    guard(os.getpgid(0))
    sys.exit(subprocess.call(sys.argv[1:]))  # (close_fds: the command does not hold the guard's pipe)


if __name__ == "__main__":
    main()
