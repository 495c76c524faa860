"""How long a study would take with unlimited workers: the longest chain of stages through the graph of
what each stage waits for (`Stage.prerequisites`), each stage counted at its recorded wall time."""

from __future__ import annotations

from lerobot_ivmc.pipeline.stages import Stage


def critical_path(stages: list[Stage], wall_s: dict[str, float]) -> tuple[float, list[str]]:
    """The longest path's time (seconds) and its stages, first to last. `stages` in an order where every
    stage comes after those it waits for; a stage missing from `wall_s` counts 0 s."""
    finish: dict[str, float] = {}
    before: dict[str, str | None] = {}
    for stage in stages:
        last = max(stage.prerequisites, key=finish.__getitem__, default=None)
        before[stage.name] = last
        finish[stage.name] = (finish[last] if last else 0.0) + wall_s.get(stage.name, 0.0)
    if not finish:
        return 0.0, []
    name: str | None = max(finish, key=finish.__getitem__)
    total, path = finish[name], []
    while name is not None:
        path.append(name)
        name = before[name]
    return total, path[::-1]


def overlaps(started_ended: dict[str, tuple[float, float]]) -> list[tuple[str, str]]:
    """Pairs of stages that ran at the same time, from their (start, end) seconds in one run."""
    spans = sorted(started_ended.items(), key=lambda item: item[1][0])
    return [
        (a, b)
        for i, (a, (_, a_end)) in enumerate(spans)
        for b, (b_start, _) in spans[i + 1 :]
        if b_start < a_end
    ]
