"""`ThresholdRecord`: the recovery threshold a bvmc checkpoint carries (`recovery_threshold.json`), with the
validation episodes it was picked on; saved and loaded with the policy (`BVMCPolicy`), locally or from the
hub. Picking one is `recovery.threshold`'s job."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from lerobot_ivmc.atomic_files import write_json_atomic

THRESHOLD_FILE = "recovery_threshold.json"


def check_finite(name: str, values: Sequence[float] | np.ndarray | float) -> np.ndarray:
    """`values` as a float array if every one is finite, else a ValueError naming `name` and the first bad
    entries: a NaN threshold or uncertainty would silently turn recovery off (NaN > C is never true)."""
    array = np.asarray(values, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(array.reshape(-1)))
    if len(bad):
        where = "" if array.ndim == 0 else f" at {bad[:5].tolist()}{' ...' if len(bad) > 5 else ''}"
        raise ValueError(
            f"{name} must be finite, got {array.reshape(-1)[bad[0]]}{where}: a NaN or infinite uncertainty "
            "means a broken policy or record; retrain or pick the threshold again."
        )
    return array


@dataclass
class ThresholdRecord:
    """A picked threshold and the validation episodes it came from (`recovery_threshold.json`).

    Attributes:
        threshold: C, compared with the sliding-window sum of step uncertainties (over `baseline` at the
            same step, where the record has one).
        method: how it was picked ("argmax": the paper's; "conformal": split conformal on successes).
        alpha: the false-alarm bound of a conformal threshold (None for argmax).
        window: the sliding window's length it applies to.
        task: the task of the validation episodes.
        split: their scene split.
        num_samples: S, Monte Carlo samples per step (the uncertainty's scale depends on it).
        uncertainty_lambda: lambda of the uncertainty measure.
        episodes: per validation episode: seed, u and success (with a baseline, u is the time-conditioned
            score under a baseline made without the episode).
        baseline: (T,) per step, a quantile of the successful validation episodes' window sums: the
            time-conditioned score divides by it (`recovery/time_baseline.py`); None: the paper's score.
        baseline_quantile: which quantile, chosen on the validation episodes.
        score_auroc: where the picking weighed the time-conditioned score, the validation AUROC of each
            score ("window_sum", "time_conditioned": cross-fitted; None without a failure).
        deadline: the longest successful validation episode's steps + 1, what `--recovery.deadline=auto`
            fires at; None without a successful episode (or in a record picked before it was kept).
    """

    threshold: float
    method: str
    window: int
    task: str
    split: str
    num_samples: int
    uncertainty_lambda: float
    episodes: list[dict] = field(default_factory=list)
    alpha: float | None = None
    baseline: list[float] | None = None
    baseline_quantile: float | None = None
    score_auroc: dict[str, float | None] | None = None
    deadline: int | None = None

    def __post_init__(self) -> None:
        check_finite("The threshold", self.threshold)
        check_finite("The validation episodes' u", [e["u"] for e in self.episodes])
        if self.baseline is not None and not (
            len(self.baseline) > 0 and (check_finite("The baseline", self.baseline) > 0).all()
        ):
            raise ValueError(
                "The baseline's window sums must be positive, at least one: pick the threshold again."
            )
        if self.deadline is not None and self.deadline < 1:
            raise ValueError(
                f"The deadline must be >= 1 step, got {self.deadline}: pick the threshold again."
            )

    def save(self, folder: Path) -> Path:
        path = Path(folder) / THRESHOLD_FILE
        write_json_atomic(path, asdict(self))
        return path

    @classmethod
    def load(cls, folder: Path | str, **hub_kwargs) -> ThresholdRecord | None:
        """The record of a checkpoint, a local folder or a hub repo id (fetched with `hf_hub_download` and
        `hub_kwargs`, e.g. `revision`, `cache_dir`; the cache serves it offline), or None if it has none."""
        path = Path(folder) / THRESHOLD_FILE
        if not Path(folder).is_dir():
            path = hub_file(str(folder), THRESHOLD_FILE, **hub_kwargs)
        if path is None or not path.is_file():
            return None
        try:
            return cls(**json.loads(path.read_text()))
        except (ValueError, TypeError, KeyError) as error:  # (json's decode error is a ValueError)
            raise ValueError(f"{path} is not a valid threshold record ({error}); pick it again.") from error


def hub_file(repo_id: str, filename: str, **hub_kwargs) -> Path | None:
    """A file of a hub model repo, from the local cache or downloaded; None if the repo has no such file, the
    name is no repo id, or it is neither cached nor reachable."""
    from huggingface_hub import hf_hub_download
    from huggingface_hub.errors import EntryNotFoundError, HFValidationError, LocalEntryNotFoundError

    try:
        return Path(hf_hub_download(repo_id=repo_id, filename=filename, **hub_kwargs))
    except (EntryNotFoundError, LocalEntryNotFoundError, HFValidationError):
        return None
