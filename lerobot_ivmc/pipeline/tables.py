"""The study's tables in markdown: Table I's rows with the paper's values, the training seeds' rows and
pooled rescue, the perception checks (`results.py` gathers what they show)."""

from __future__ import annotations

METHOD_LABELS = {
    "vmc": "VMC",
    "none": "BVMC",
    "rand": "BVMC + rand",
    "init": "BVMC + init",
    "min_unc": "BVMC + min unc",
    "anchor": "BVMC + anchor (beyond the paper)",
    "anchor_control": "BVMC + anchor at threshold 0 (anchor's control: fired from the first step it may)",
    "retry": "BVMC + retry (beyond the paper, no task knowledge)",
    "reach": "BVMC + reach (beyond the paper, no task knowledge)",
    "reach_carry": "BVMC + reach, carried to the believed goal (beyond the paper, no task knowledge)",
    "reach_place": (
        "BVMC + reach, carried to the believed goal and let go (beyond the paper, no task knowledge)"
    ),
    "reach_carry_frame": (
        "BVMC + reach on the frame head, carried to the believed goal (beyond the paper, no task knowledge)"
    ),
    "reach_place_frame": (
        "BVMC + reach on the frame head, carried to the believed goal and let go (beyond the paper, no task "
        "knowledge)"
    ),
    "reach_push": "BVMC + reach, pushed to the believed goal (beyond the paper, no task knowledge)",
    "reach_push_frame": (
        "BVMC + reach on the frame head, pushed to the believed goal (beyond the paper, no task knowledge)"
    ),
    "reach_push_frame_object": (
        "BVMC + reach, the object on the frame head, pushed to the believed goal (beyond the paper, no task "
        "knowledge)"
    ),
    "chosen": "BVMC + the mode that knows no task chosen on validation scenes",
    "chosen_over_seeds": (
        "BVMC + the mode that knows no task chosen once, on every training seed's validation scenes together"
    ),
}
# A row `<row>_<trigger>` (`config.TRIGGER_VARIANTS`) is labelled as its row with its trigger.
TRIGGER_LABELS = {
    "deadline": "with the deadline",
    "grasp_miss": "with the missed grasp",
    "deadline_only": "under the deadline alone",
    "grasp_miss_only": "under the missed grasp alone",
    "grasp_miss_deadline_only": "under the missed grasp and the deadline alone",
}


def split_trigger(method: str) -> tuple[str, str | None]:
    """A row's own row in `METHOD_LABELS` and its trigger (None for a row without one)."""
    for trigger in TRIGGER_LABELS:
        own = method.removesuffix(f"_{trigger}")
        if own != method and own in METHOD_LABELS:
            return own, trigger
    if method not in METHOD_LABELS:
        raise KeyError(f"No table label for the row {method!r}.")
    return method, None


def row_sort_key(method: str) -> tuple[int, int]:
    """Where a row goes in the tables: its own row's place, then its trigger's (the row alone first)."""
    own, trigger = split_trigger(method)
    return list(METHOD_LABELS).index(own), 0 if trigger is None else list(TRIGGER_LABELS).index(trigger) + 1


def row_label(method: str) -> str:
    """A row's label in the tables: `METHOD_LABELS`, with its trigger for a `<row>_<trigger>` row."""
    own, trigger = split_trigger(method)
    return METHOD_LABELS[own] if trigger is None else f"{METHOD_LABELS[own]}, {TRIGGER_LABELS[trigger]}"


def training_seed_table(rows: list[dict], summary: list[dict]) -> str:
    """Markdown: one line per (model, #fc, training seed), then the mean +- standard deviation over seeds."""
    subtasks = list(rows[0]["subtasks"])
    n = rows[0]["subtasks"][subtasks[0]]["n"]
    lines = [
        f"| row, {n} test scenes | #fc | training seed | " + " | ".join(f"{s} [%]" for s in subtasks) + " |",
        "|---|---|---|" + "---|" * len(subtasks),
    ]
    for row in rows:
        cells = [f"{row['subtasks'][s]['rate']:.1f} +- {row['subtasks'][s]['stderr']:.1f}" for s in subtasks]
        label = row.get("label") or (row_label(row["method"]) if "method" in row else row["model"])
        lines.append(
            f"| {label} | {row['num_fc_layers']} | {row['train_seed']} | " + " | ".join(cells) + " |"
        )
    for entry in summary:
        cells = [f"{entry['subtasks'][s]['mean']:.1f} +- {entry['subtasks'][s]['std']:.1f}" for s in subtasks]
        seeds = ", ".join(map(str, entry["train_seeds"]))
        label = f"{entry['model']}, mean +- sd over {len(entry['train_seeds'])} seeds"
        lines.append(f"| {label} | {entry['num_fc_layers']} | {seeds} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def pooled_rescue_table(pooled: list[dict]) -> str:
    """Markdown: per (#fc, recovery mode) BVMC's failures over the seeds and what the mode did with them."""
    if not pooled:
        return ""
    lines = [
        "\n| recovery, over training seeds | #fc | seeds | BVMC's failures (flagged) | rescued / lost | "
        "rescue rate | exact p |",
        "|---|---|---|---|---|---|---|",
    ]
    for entry in pooled:
        chosen = f": {entry['chosen_mode']}" if "chosen_mode" in entry else ""
        lines.append(
            f"| {row_label(entry['method'])}{chosen} | {entry['num_fc_layers']} | "
            f"{', '.join(map(str, entry['train_seeds']))} | {rescue_cells(entry)} | {entry['exact_p']:.3f} |"
        )
    return "\n".join(lines) + "\n"


def rescue_cells(record: dict) -> str:
    """A rescue record's table cells: failures (flagged) | rescued / lost | rescue rate."""
    rate = "-" if record["rescue_rate"] is None else f"{record['rescue_rate']:.0%}"
    return f"{record['failures']} ({record['flagged']}) | {record['rescued']} / {record['lost']} | {rate}"


def perception_table(rows: list[dict]) -> str:
    """Markdown: one line per checked policy, median object and grip estimate errors in cm."""
    first = rows[0]
    lines = [
        f"| policy ({first['scenes']} {first['split']} scenes, first {first['steps']} steps) | #fc | "
        "training seed | object, watching the expert [cm] | object, acting [cm] | grip, acting [cm] | "
        "limit [cm] |",
        "|---|---|---|---|---|---|---|",
    ]
    verdicts = {True: "within", False: "**above**", None: "no limit"}
    for row in rows:
        limit = row["max_object_error_cm"]
        limit = f"{limit:g}: {verdicts[row['passed']]}" if limit else verdicts[None]
        lines.append(
            f"| {row['model']} | {row['num_fc_layers']} | {row['train_seed']} | "
            f"{row['watching_expert']['object_cm']:.1f} | {row['acting']['object_cm']:.1f} | "
            f"{row['acting']['grip_cm']:.1f} | {limit} |"
        )
    return "\n".join(lines) + "\n"


def markdown_table(rows: list[dict]) -> str:
    """Table I layout: measured rate +- SE per subtask, the paper's next to it."""
    subtasks = list(rows[0]["subtasks"])
    n = rows[0]["subtasks"][subtasks[0]]["n"]
    head = " | ".join(f"{s} [%] (paper)" for s in subtasks)
    lines = [
        f"| model, {n} test scenes | #fc | {head} | recoveries (episodes) | vs BVMC: gained / lost, p | "
        "BVMC's failures (flagged): rescue rate |",
        "|---|---|" + "---|" * len(subtasks) + "---|---|---|",
    ]
    for row in rows:
        cells = []
        for s in subtasks:
            m, p = row["subtasks"][s], row["paper"].get(s)
            paper = f" ({p['rate']:.0f})" if p else ""
            cells.append(f"{m['rate']:.1f} +- {m['stderr']:.1f}{paper}")
        rec = f"{row['recoveries']} ({row['episodes_with_recovery']})" if "recoveries" in row else "-"
        pair = row["paired"].get("vs_none")
        versus = (
            f"{pair['only_second']} / {pair['only_first']}, {pair['mcnemar_exact_p']:.2f}" if pair else "-"
        )
        rescue = row.get("rescue")
        rescued = (
            f"{rescue['failures']} ({rescue['flagged']}): "
            + ("-" if rescue["rescue_rate"] is None else f"{rescue['rescue_rate']:.0%}")
            if rescue
            else "-"
        )
        lines.append(
            f"| {row['label']} | {row['num_fc_layers']} | "
            + " | ".join(cells)
            + f" | {rec} | {versus} | {rescued} |"
        )
    return "\n".join(lines) + "\n"
