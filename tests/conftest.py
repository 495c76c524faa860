import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

# Under pytest-xdist (scripts/test.sh runs the suite on every core), share the cores between the workers:
# torch in each worker, and in the CLIs it starts (which inherit the variables), gets cores // workers
# threads, so two workers' trainings do not oversubscribe the cores.
_workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
if _workers > 1:
    _threads = str(max(1, (os.cpu_count() or 1) // _workers))
    for _name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_name, _threads)
    if "torch" in sys.modules:  # imported before this file (a plugin): set its pool directly
        sys.modules["torch"].set_num_threads(int(_threads))


def pytest_collection_modifyitems(items: list) -> None:
    """Start the tests marked `long` first: a worker that meets one last leaves the others idle meanwhile."""
    items.sort(key=lambda item: item.get_closest_marker("long") is None)


# The tiny bvmc checkpoints, shared by the recovery and evaluation tests (imported after the thread
# settings above, as they import torch).
from helpers.checkpoints import tiny_bvmc, tiny_foresight, tiny_recovery_checkpoint  # noqa: E402, F401
