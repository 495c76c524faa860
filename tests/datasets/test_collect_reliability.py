"""`lerobot-ivmc-collect` against hostile but fair use: two writers, user files, damaged files, bad roots."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from lerobot.datasets.lerobot_dataset import LeRobotDataset

from lerobot_ivmc.datasets import collect, staging
from lerobot_ivmc.datasets.collect import CollectConfig, collect_demos
from lerobot_ivmc.envs import DEMO_EPISODE_STEPS
from lerobot_ivmc.scripts.lerobot_ivmc_collect import main

# Subprocesses, trainings or whole studies: left out of `bash scripts/test.sh -m "not slow"`.
pytestmark = pytest.mark.slow

IMAGE_SIZE = 32


def _config(root: Path, **overrides) -> CollectConfig:
    kwargs = {"task": "push", "num_episodes": 2, "image_size": IMAGE_SIZE, "num_workers": 0}
    return CollectConfig(root=root, **{**kwargs, "progress": False, **overrides})


def _args(root: Path, n: int) -> list[str]:
    return [
        "--env.task=push", f"--dataset.num_episodes={n}", f"--dataset.root={root}",
        f"--env.image_size={IMAGE_SIZE}", "--num_workers=0", "--progress=false",
    ]  # fmt: skip


def _collector(args: list[str]) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_collect", *args]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _interrupted(root: Path, monkeypatch, staged: int = 1) -> None:
    """Leave an unfinished collection in `root`: `staged` episodes staged, nothing published."""
    append = collect.EpisodeAssembler.append

    def append_then_stop(self, episode):
        append(self, episode)
        if len(self.episodes) >= staged:
            raise KeyboardInterrupt

    monkeypatch.setattr(collect.EpisodeAssembler, "append", append_then_stop)
    with pytest.raises(KeyboardInterrupt):
        collect_demos(_config(root))
    monkeypatch.undo()
    assert (root / staging.WORK_DIR / staging.EPISODES_DIR).exists()


def test_two_collectors_started_together_on_one_root(tmp_path):
    """One is refused at once, naming the other; the other's dataset loads with the right counts."""
    root, n = tmp_path / "ivmc_push", 8
    collectors = [_collector(_args(root, n)) for _ in range(2)]
    finished: dict[int, float] = {}
    deadline = time.monotonic() + 300
    while len(finished) < 2 and time.monotonic() < deadline:
        for i, process in enumerate(collectors):
            if i not in finished and process.poll() is not None:
                finished[i] = time.monotonic()
        time.sleep(0.05)
    outputs = [process.communicate(timeout=10)[0] for process in collectors]
    codes = [process.returncode for process in collectors]
    assert sorted(codes) == [0, 2], outputs
    winner, loser = (0, 1) if codes[0] == 0 else (1, 0)
    assert f"being written by another collector (pid {collectors[winner].pid}" in outputs[loser]
    assert finished[loser] < finished[winner]  # refused on arrival, not after collecting
    dataset = LeRobotDataset("local/ivmc_push", root=root)
    assert dataset.num_episodes == n and dataset.num_frames == n * DEMO_EPISODE_STEPS
    assert len(dataset.hf_dataset) == n * DEMO_EPISODE_STEPS
    assert sorted(p.name for p in root.iterdir()) == ["data", "meta"]  # no lock file left behind


def test_a_killed_lock_holder_leaves_no_stale_lock(tmp_path):
    root = tmp_path / "ivmc_push"
    holder = subprocess.Popen(
        [sys.executable, "-c", f"from lerobot_ivmc.datasets.root_lock import RootLock; import time\n"
         f"with RootLock({str(root)!r}):\n    print('locked', flush=True); time.sleep(600)"],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert holder.stdout.readline().strip() == "locked"
    with pytest.raises(staging.CollectionError, match=f"pid {holder.pid}"):
        collect_demos(_config(root, num_episodes=1))
    holder.kill()
    holder.wait()
    assert collect_demos(_config(root, num_episodes=1)).num_episodes == 1


def test_a_damaged_published_dataset_is_reported_never_called_complete(tmp_path):
    cfg = _config(tmp_path / "ds")
    collect_demos(cfg)
    data_file = next((cfg.root / "data").rglob("*.parquet"))
    table = pq.read_table(data_file)
    pq.write_table(table.slice(0, DEMO_EPISODE_STEPS + 50), data_file)  # 150 of 200 frames survive
    with pytest.raises(staging.CollectionError, match="damaged dataset.*holds 150 frames, expected 200"):
        collect_demos(cfg)
    assert main(_args(cfg.root, 2)) == 2
    assert len(pq.read_table(data_file)) == 150  # reported, left as it is


def test_resume_keeps_user_files_and_refuses_the_root(tmp_path, monkeypatch):
    root = tmp_path / "ds"
    _interrupted(root, monkeypatch)
    user_files = {
        root / "data" / "notes.txt": "mine",
        root / "images" / "frame.png": "mine too",
        root / "meta" / "extra.json": "{}",
    }
    for path, text in user_files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    with pytest.raises(ValueError, match="files it did not write: data, images, meta"):
        collect_demos(_config(root))
    assert all(path.read_text() == text for path, text in user_files.items())
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before
    for path in user_files:
        staging.remove_tree(path.parent)
    summary = collect_demos(_config(root))
    assert summary.resumed_episodes == 1 and LeRobotDataset("local/ivmc_push", root=root).num_episodes == 2


def test_publish_cut_short_is_finished_not_rebuilt(tmp_path, monkeypatch):
    cfg = _config(tmp_path / "ds")
    moves = []

    def replace_then_die(src, dst, **kwargs):
        os.rename(src, dst, **kwargs)
        moves.append(Path(dst).name)
        if Path(dst).name == "data":
            raise KeyboardInterrupt

    monkeypatch.setattr(staging.os, "replace", replace_then_die)
    with pytest.raises(KeyboardInterrupt):
        collect_demos(cfg)
    monkeypatch.undo()
    data_file = next((cfg.root / "data").rglob("*.parquet"))
    mtime = data_file.stat().st_mtime_ns
    (cfg.root / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="files it did not write: notes.txt"):
        collect_demos(cfg)
    (cfg.root / "notes.txt").unlink()
    collect_demos(cfg)
    assert data_file.stat().st_mtime_ns == mtime  # moved into place by the first run, kept
    assert LeRobotDataset(cfg.repo_id, root=cfg.root).num_episodes == 2
    assert not (cfg.root / staging.WORK_DIR).exists()


def test_root_that_is_a_file_is_refused_in_one_line(tmp_path, capsys):
    root = tmp_path / "ds"
    root.write_text("not a folder")
    with pytest.raises(ValueError, match="is a file"):
        _config(root)
    with pytest.raises(SystemExit) as exit_info:
        main(_args(root, 2))
    assert exit_info.value.code == 2
    last_line = capsys.readouterr().err.strip().splitlines()[-1]
    assert last_line.endswith("is a file; give a folder (new, or one this command made).")
    assert root.read_text() == "not a folder"


def test_damaged_staged_episode_is_named_with_how_to_drop_it(tmp_path, monkeypatch):
    root = tmp_path / "ds"
    _interrupted(root, monkeypatch)
    staged = staging.attempt_path(root / staging.WORK_DIR / staging.EPISODES_DIR, 0, "npz")
    staged.write_bytes(staged.read_bytes()[:1000])
    with pytest.raises(staging.CollectionError, match=f"staged episode {staged} is damaged.*rm '{staged}'"):
        collect_demos(_config(root))
    staged.unlink()
    summary = collect_demos(_config(root))
    assert summary.num_episodes == 2 and LeRobotDataset("local/ivmc_push", root=root).num_episodes == 2


def test_unfinished_collection_of_another_spec_says_how_to_continue(tmp_path, monkeypatch):
    root = tmp_path / "ds"
    _interrupted(root, monkeypatch)
    with pytest.raises(ValueError, match="image_size: stored 32, asked 48") as error:
        collect_demos(_config(root, image_size=48))
    message = str(error.value)
    assert (
        f"--dataset.root={root} --dataset.num_episodes=2 --env.task=push --env.split=train --seed=0 "
        "--env.image_size=32 --env.render_style=fast;" in message
    )
    assert f"remove {root / staging.WORK_DIR}" in message


@pytest.mark.parametrize("image_size", [0, 4096])
def test_image_size_out_of_range_is_refused_before_anything_is_written(tmp_path, image_size):
    with pytest.raises(ValueError, match="at most 2048"):
        _config(tmp_path / "ds", image_size=image_size)
    assert not (tmp_path / "ds").exists()


def test_image_size_above_the_default_framebuffer_collects(tmp_path):
    cfg = _config(tmp_path / "ds", num_episodes=1, image_size=500)
    collect_demos(cfg)
    assert LeRobotDataset(cfg.repo_id, root=cfg.root)[0]["observation.images.front"].shape == (3, 500, 500)


def _files(root: Path) -> dict[Path, bytes]:
    return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_reruns_write_byte_identical_datasets(tmp_path):
    """Same arguments and root, other processes and hash seeds: the same bytes in every file. In another
    root only the fingerprint `datasets` writes into the data parquet's schema differs (it hashes paths)."""
    root, runs = tmp_path / "ds", []
    for hash_seed in ("1", "2"):
        env = {**os.environ, "PYTHONHASHSEED": hash_seed}
        cmd = [sys.executable, "-m", "lerobot_ivmc.scripts.lerobot_ivmc_collect", *_args(root, 2)]
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
        runs.append(_files(root))
        staging.remove_tree(root)
    assert runs[0].keys() == runs[1].keys() and len(runs[0]) == 6
    for name, data in runs[0].items():
        assert runs[1][name] == data, name

    other = tmp_path / "elsewhere"
    collect_demos(_config(other))
    elsewhere = _files(other)
    assert [name for name in runs[0] if elsewhere[name] != runs[0][name]] == [
        Path("data/chunk-000/file-000.parquet")
    ]
    tables = [pq.read_table(other / "data/chunk-000/file-000.parquet")]
    (tmp_path / "first.parquet").write_bytes(runs[0][Path("data/chunk-000/file-000.parquet")])
    tables.append(pq.read_table(tmp_path / "first.parquet"))
    assert tables[0].equals(tables[1])  # values and schema, not metadata
    info = [json.loads(table.schema.metadata[b"huggingface"]) for table in tables]
    assert info[0]["info"] == info[1]["info"] and info[0]["fingerprint"] != info[1]["fingerprint"]
