"""Paired comparison of evaluations on the same scenes, the library of `lerobot-ivmc-compare`
(`scripts/lerobot_ivmc_compare.py`): two `lerobot-ivmc-eval` runs with the same `--seed` see the same scenes
in the same order, so their episodes pair up; counts of the scenes both, one or neither solve, the exact
McNemar test on the discordant pairs, and a recovery row's rescue record against BVMC."""

from __future__ import annotations

import json
from pathlib import Path

from scipy import stats

from lerobot_ivmc.constants import EVAL_INFO_FILE


def load_run(folder: Path) -> dict:
    """A run's `eval_info.json`: its `run` record (task, split, seed) and `per_episode` list."""
    path = Path(folder) / EVAL_INFO_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: pass the --output_dir of a lerobot-ivmc-eval run.")
    try:
        info = json.loads(path.read_text())
        info["run"]["task"], info["run"]["split"], info["per_episode"][0]["seed"]  # noqa: B018
    except (ValueError, KeyError, IndexError, TypeError) as error:
        raise ValueError(
            f"{path} is not a complete lerobot-ivmc-eval record ({error!r}); rerun it."
        ) from error
    return info


def exact_mcnemar_p(only_first: int, only_second: int) -> float:
    """The exact McNemar test of paired binary outcomes: a two-sided binomial test on the discordant pairs
    (1.0 without any)."""
    discordant = only_first + only_second
    return float(stats.binomtest(only_second, discordant, 0.5).pvalue) if discordant else 1.0


def paired_outcomes(a: dict, b: dict, milestone: str) -> dict:
    """Counts of (a, b) outcomes on the scenes both runs evaluated and the exact McNemar p-value.

    Args:
        a, b: runs as `load_run` reads them, of one task and split; episodes pair up by scene seed (runs
            with the same `--seed` and different counts share their first scenes).
        milestone: the subtask compared (the task's last one is success).
    """
    for key in ("task", "split"):
        if a["run"][key] != b["run"][key]:
            raise ValueError(
                f"The runs evaluated different {key}s ({a['run'][key]!r} and {b['run'][key]!r}): compare "
                "runs of one task on one scene split."
            )
    subtasks = list(a["per_episode"][0]["subtasks"])
    if milestone not in subtasks:
        raise ValueError(
            f"--milestone={milestone} is not a milestone of {a['run']['task']}: choose from {subtasks}."
        )
    b_by_seed = {e["seed"]: e for e in b["per_episode"]}
    pairs = [(x, b_by_seed[x["seed"]]) for x in a["per_episode"] if x["seed"] in b_by_seed]
    if not pairs:
        raise ValueError("The runs share no scene: rerun them with the same --seed.")
    flags = [(bool(x["subtasks"][milestone]), bool(y["subtasks"][milestone])) for x, y in pairs]
    only_a = sum(x and not y for x, y in flags)
    only_b = sum(y and not x for x, y in flags)
    p = exact_mcnemar_p(only_a, only_b)
    return {
        "milestone": milestone,
        "episodes": len(flags),
        "episodes_first": len(a["per_episode"]),
        "episodes_second": len(b["per_episode"]),
        "both": sum(x and y for x, y in flags),
        "only_first": only_a,
        "only_second": only_b,
        "neither": sum(not x and not y for x, y in flags),
        "mcnemar_exact_p": float(p),
    }


def pooled_outcomes(pairs: list[dict]) -> dict:
    """`paired_outcomes` results of several run pairs (e.g. one per training seed) summed, with the exact
    McNemar p of the summed discordant pairs: each scene stays a matched pair within its own runs."""
    counts = ("episodes", "both", "only_first", "only_second", "neither")
    total = {key: sum(pair[key] for pair in pairs) for key in counts}
    return {
        "pairs": len(pairs),
        **total,
        "mcnemar_exact_p": exact_mcnemar_p(total["only_first"], total["only_second"]),
    }


def rescue_record(bvmc: dict, recovered: dict, milestone: str) -> dict:
    """What a recovery mode did with the failures of the same policy without recovery, scene by scene.

    Args:
        bvmc: the run of the policy without recovery (`load_run`), with each episode's u.
        recovered: the run with a recovery mode on the same scenes, with the threshold it used.
        milestone: the subtask that counts as success (the task's last one).

    Returns:
        failures: scenes the policy failed without recovery; flagged: those of them whose u crossed the
        recovery run's threshold (where a recovery could start; None where the runs' u differ in kind, or
        where the recovery run's deadline or missed grasp also fires recoveries);
        rescued: failed without recovery, succeeded with it; lost: the reverse; rescue_rate: (rescued -
        lost) / failures (None without failures); mcnemar_exact_p: the paired test of rescued against lost.
    """
    pair = paired_outcomes(bvmc, recovered, milestone)
    threshold = recovered["recovery"]["threshold"]
    shared = {e["seed"] for e in recovered["per_episode"]}
    failures = [e for e in bvmc["per_episode"] if e["seed"] in shared and not e["subtasks"][milestone]]
    rescued, lost = pair["only_second"], pair["only_first"]
    return {
        "failures": len(failures),
        # Only where both runs' u are on the threshold's scale (a threshold picked for the time-conditioned
        # score scores the run without recovery it is picked on by the window sum; baselines differ).
        "flagged": sum(e["max_uncertainty"] > threshold for e in failures)
        if score_kind(bvmc) == score_kind(recovered) and not other_triggers(recovered)
        else None,
        "rescued": rescued,
        "lost": lost,
        "rescue_rate": (rescued - lost) / len(failures) if failures else None,
        "mcnemar_exact_p": pair["mcnemar_exact_p"],
    }


def other_triggers(run: dict) -> bool:
    """Whether a recovery run also fired on something else than its score (a deadline, a missed grasp)."""
    settings = run.get("recovery", {}).get("settings", {})
    return bool(settings.get("deadline") or settings.get("grasp_miss"))


def time_conditioned(run: dict) -> bool:
    """Whether a bvmc run's u and threshold are the time-conditioned score's (`recovery/time_baseline.py`)."""
    return "time-conditioned" in str(run.get("recovery", {}).get("threshold_source"))


def score_kind(run: dict) -> str:
    """What a bvmc run's u is: "window_sum", or the time-conditioned score of one baseline (its digest, where
    the run recorded it)."""
    if not time_conditioned(run):
        return "window_sum"
    return run["recovery"].get("baseline_digest", "time_conditioned")
