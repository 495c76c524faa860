"""The data-budget rule: the same for every task, it puts a study where BVMC fails often enough for
recovery to be measured (a task solved at full data, such as pick_reach at `lite`, has nothing to recover).

    lerobot-ivmc-pipeline --task=pick_reach --preset=lite --regime.demo_budgets=[1000,500,250]
    lerobot-ivmc-pipeline --task=door-open-v3 --preset=metaworld --regime.train_steps=[2000,1000]

The budget is the number of demos (`--regime.demo_budgets`) or, for a task solved even with few demos, the
number of training steps on all of them (`--regime.train_steps`). Budgets are tried from the largest, the
preset's (`--collect.dataset.num_episodes` or `--train.steps`), then each of the listed ones in turn. A
budget's probe is the start of an ordinary study in `<output_dir>/demos<n>/` (or `steps<n>/`) with that
budget (the collector records attempts in a fixed order, so n demos are the first n demos of every larger
budget): the collection, the main seed's BVMC training of the first #fc, and BVMC without recovery on
`--regime.n_episodes` validation scenes (the threshold's first scenes; no test scene is touched). The rule
(`choose_budget`):

- the first budget whose validation failure rate lies in `--regime.failure_range` (default 20-40%) is
  chosen;
- a budget that fails more often than the range stops the search: of it and the budget tried before it,
  the one whose rate is nearer the range is chosen (a tie: the larger budget);
- when every budget fails less often than the range, the smallest is chosen, and the record says the
  range was not reached.

Then the chosen budget's study runs to the end (its probe's stages are reused, not redone), with every
training seed, and `<output_dir>/regime.json` records each probe's failures and the choice (also in the
chosen study's `results/`, and under `regime` in its results JSON).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace

from lerobot_ivmc.atomic_files import write_json_atomic
from lerobot_ivmc.constants import EVAL_INFO_FILE, LAST_PRETRAINED_MODEL
from lerobot_ivmc.pipeline.config import PipelineConfig
from lerobot_ivmc.pipeline.results import REGIME_FILE, RESULTS_DIR
from lerobot_ivmc.pipeline.runner import claim_root, run_stages, study_lock
from lerobot_ivmc.pipeline.stage_names import COLLECT_STAGE, train_stage_name
from lerobot_ivmc.pipeline.stages import Stage, build_stages, chain_flags, eval_stage, find_stage

PROBE_STAGE = "regime_val"


@dataclass
class BudgetProbe:
    """One budget's validation run: BVMC without recovery, trained with `budget` demos or steps."""

    budget: int
    episodes: int
    failures: int

    @property
    def failure_rate(self) -> float:
        return self.failures / self.episodes


def distance_to_range(rate: float, low: float, high: float) -> float:
    """How far a failure rate lies outside [low, high] (0 inside)."""
    return round(max(low - rate, rate - high, 0.0), 9)  # (so that equal distances compare equal)


def choose_budget(probes: list[BudgetProbe], low: float, high: float, exhausted: bool) -> int | None:
    """The rule, on the probes so far (largest budget first): the chosen budget, or None when the next
    smaller budget must be probed. `exhausted`: no smaller budget is left to probe."""
    if not probes:
        raise ValueError("choose_budget needs at least one probe.")
    last = probes[-1]
    if low <= last.failure_rate <= high:
        return last.budget
    if last.failure_rate > high:
        candidates = probes[-2:]  # the overshooting budget and the one before it (larger first)
        return min(candidates, key=lambda p: distance_to_range(p.failure_rate, low, high)).budget
    return last.budget if exhausted else None


def budgets(cfg: PipelineConfig) -> list[int]:
    """The budgets to try, largest first: the preset's demos or steps, then the listed ones."""
    if cfg.regime.budget == "steps":
        return [cfg.train.steps, *cfg.regime.train_steps]
    return [cfg.collect.dataset.num_episodes, *cfg.regime.demo_budgets]


def budget_config(cfg: PipelineConfig, budget: int) -> PipelineConfig:
    """The study of one budget, in `<output_dir>/demos<n>` (or `steps<n>`), without the rule."""
    axis = cfg.regime.budget or "demos"
    regime = replace(cfg.regime, demo_budgets=[], train_steps=[])
    if axis == "steps":
        return replace(
            cfg, train=replace(cfg.train, steps=budget), regime=regime, output_dir=cfg.root / f"steps{budget}"
        )
    collect = replace(cfg.collect, dataset=replace(cfg.collect.dataset, num_episodes=budget))
    return replace(cfg, collect=collect, regime=regime, output_dir=cfg.root / f"demos{budget}")


def probe_stages(cfg: PipelineConfig) -> list[Stage]:
    """A budget study's probe (`cfg` from `budget_config`): its collection, the main seed's BVMC training
    of the first #fc, and that BVMC without recovery on the first validation scenes."""
    stages = build_stages(cfg)
    fc = cfg.train.num_fc_layers[0]
    training = find_stage(stages, train_stage_name("bvmc", fc))
    out = cfg.root.resolve() / PROBE_STAGE
    r = cfg.regime
    chain = chain_flags(cfg)
    probe = eval_stage(
        PROBE_STAGE,
        training.output / LAST_PRETRAINED_MODEL,
        out,
        chain.eval_env_flags,
        r.n_episodes,
        r.batch_size,
        f"--seed={cfg.seed}",
        None,
        training.name,
        split="val",
        recovery_flags=chain.bvmc_flags,
    )
    return [find_stage(stages, COLLECT_STAGE), training, probe]


def read_probe(stage: Stage, budget: int) -> BudgetProbe:
    """The failures of a finished probe stage, from its `eval_info.json`."""
    info = json.loads((stage.output / EVAL_INFO_FILE).read_text())
    successes = [bool(episode["success"]) for episode in info["per_episode"]]
    return BudgetProbe(budget, len(successes), successes.count(False))


def run_regime(cfg: PipelineConfig, run_study: Callable[[PipelineConfig], dict], log=print) -> dict:
    """Probe the budgets by the rule, then run the chosen budget's whole study with `run_study`; return its
    results JSON (with the rule's record under `regime`)."""
    root = cfg.root
    claim_root(root, {"task": cfg.task, "preset": cfg.preset, "regime": True})
    low, high = cfg.regime.failure_range
    axis = cfg.regime.budget or "demos"
    tried = budgets(cfg)
    probes: list[BudgetProbe] = []
    with study_lock(root):
        for index, budget in enumerate(tried):
            study = budget_config(cfg, budget)
            claim_root(study.root, {"task": cfg.task, "preset": cfg.preset})
            log(f"Regime: probing {budget} {axis} in {study.root}")
            stages = probe_stages(study)
            with study_lock(study.root):
                run_stages(study.root, stages, log)
            probe = read_probe(stages[-1], budget)
            probes.append(probe)
            log(f"Regime: {budget} {axis}, BVMC fails {probe.failures} of {probe.episodes} val scenes")
            chosen = choose_budget(probes, low, high, exhausted=index == len(tried) - 1)
            if chosen is not None:
                break
        chosen_study = budget_config(cfg, chosen)
        record = {
            "rule": "first budget with validation failure rate in the range; past it, the nearer of the "
            "last two; none reached, the smallest",
            "failure_range": [low, high],
            "validation_episodes": cfg.regime.n_episodes,
            "probes": [
                {
                    axis: p.budget,
                    "episodes": p.episodes,
                    "failures": p.failures,
                    "failure_rate": p.failure_rate,
                }
                for p in probes
            ],
            f"chosen_{axis}": chosen,
            "range_reached": any(low <= p.failure_rate <= high for p in probes if p.budget == chosen),
            "study": str(chosen_study.root),
        }
        write_json_atomic(root / REGIME_FILE, record)
        # (before the study: its results JSON, written after each stage, carries the record)
        write_json_atomic(chosen_study.root / RESULTS_DIR / REGIME_FILE, record)
        rates = ", ".join(f"{p.budget}: {p.failure_rate:.0%}" for p in probes)
        log(f"Regime: {chosen} {axis} chosen (validation failure rate by {axis}: {rates})")
        results = run_study(chosen_study)
    return {**results, "regime": record}
