"""The demo's report: a policy without and with recovery on the same scenes, as a table and one page."""

from __future__ import annotations

import shutil
from pathlib import Path

from lerobot_ivmc.evaluation.compare import load_run, rescue_record

PAGE_FILE = "demo.md"


def demo_table(without: dict, with_recovery: dict) -> tuple[str, dict]:
    """Markdown table and numbers: success without and with recovery, failures, flagged, rescued, lost."""
    milestone = list(without["per_episode"][0]["subtasks"])[-1]
    rescue = rescue_record(without, with_recovery, milestone)
    n = len(without["per_episode"])
    success = [sum(e["subtasks"][milestone] for e in run["per_episode"]) for run in (without, with_recovery)]
    mode = with_recovery["recovery"]["mode"]
    lines = [
        f"| {n} held-out scenes | {milestone} (success) | failures | flagged by the uncertainty | rescued "
        "| lost |",
        "|---|---|---|---|---|---|",
        f"| BVMC, no recovery | {success[0]} ({100 * success[0] / n:.0f}%) | {rescue['failures']} | "
        f"{rescue['flagged']} | - | - |",
        f"| BVMC + {mode} | {success[1]} ({100 * success[1] / n:.0f}%) | {n - success[1]} | - | "
        f"{rescue['rescued']} | {rescue['lost']} |",
    ]
    return "\n".join(lines), {"episodes": n, "success": success, "mode": mode, "rescue": rescue}


def write_demo_page(without_dir: Path, recovery_dir: Path, output_dir: Path, command: str) -> Path:
    """Write `demo.md` in `output_dir` with the table, Fig. 3 of the run without recovery and a recovery
    video (copied next to it); return its path."""
    without, with_recovery = load_run(without_dir), load_run(recovery_dir)
    table, numbers = demo_table(without, with_recovery)
    figure = output_dir / "uncertainty_vs_success.png"
    shutil.copyfile(without_dir / "uncertainty_vs_success.png", figure)
    videos = sorted((recovery_dir / "recovery_videos").glob("*.mp4"))
    video = None
    if videos:
        video = output_dir / f"recovery_{videos[0].name}"
        shutil.copyfile(videos[0], video)
    rho = without.get("uncertainty_vs_success", {}).get("spearman_rho")
    parts = [
        "# Introspective visuomotor control: the demo",
        "",
        f"`{command}`",
        "",
        "A Bayesian visuomotor policy (`bvmc`) on pick_place, first alone, then with "
        f"`--recovery.mode={numbers['mode']}`, on the same held-out scenes. The policy's Monte Carlo dropout "
        "uncertainty, summed over a sliding window of 20 steps, crosses the threshold picked on validation "
        "scenes in the episodes that are going to fail; recovery starts there.",
        "",
        table,
        "",
        f"Uncertainty against success (the paper's Fig. 3; Spearman rho {rho:.2f}):"
        if rho is not None
        else "Uncertainty against success (the paper's Fig. 3):",
        "",
        f"![uncertainty against success]({figure.name})",
        "",
    ]
    if video is not None:
        parts += [
            f"A recovery: [{video.name}]({video.name}) (the camera the policy sees; under it the window sum "
            "of the uncertainty, the threshold, the recovery phases shaded and the current step).",
            "",
        ]
    parts += [
        f"Runs: [{without_dir}]({without_dir}) and [{recovery_dir}]({recovery_dir}) (`eval_info.json`: every "
        "episode's milestones, uncertainty and recoveries).",
        "",
    ]
    page = output_dir / PAGE_FILE
    page.write_text("\n".join(parts))
    return page
