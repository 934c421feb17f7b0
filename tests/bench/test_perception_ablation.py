"""The ablation bench keeps settings measured in an earlier run only when the same committed code measured
them over the same episodes, and re-runs one task's episodes on request."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.perception_ablation import RESULTS, SPLIT, earlier_settings, episode_indices, main

COMMIT = "a" * 40


def _write(path: Path, split: str, indices: list[int], commit: str = COMMIT, dirty: bool = False) -> None:
    rows = {"oracle": {"success_rate": 0.8, "episodes": [{"index": i} for i in indices]}}
    stamp = {"commit": commit, "dirty": dirty}
    path.write_text(json.dumps({"stamp": stamp, "split": split, "settings": rows}))


def test_settings_of_the_same_episodes_and_code_are_kept(tmp_path: Path) -> None:
    path = tmp_path / "ablation.json"
    _write(path, SPLIT, [0, 1, 2])
    assert earlier_settings(path, [0, 1, 2], COMMIT)["oracle"]["success_rate"] == 0.8


def test_settings_of_other_episodes_or_another_split_or_no_file_are_dropped(tmp_path: Path) -> None:
    path = tmp_path / "ablation.json"
    assert earlier_settings(path, [0, 1], COMMIT) == {}
    _write(path, SPLIT, [0, 1, 2])
    assert earlier_settings(path, [0, 1], COMMIT) == {}
    _write(path, "valid_seen", [0, 1])
    assert earlier_settings(path, [0, 1], COMMIT) == {}


def test_settings_of_another_commit_or_of_uncommitted_code_are_dropped(tmp_path: Path) -> None:
    path = tmp_path / "ablation.json"
    _write(path, SPLIT, [0, 1], commit="b" * 40)
    assert earlier_settings(path, [0, 1], COMMIT) == {}, "a file never mixes code versions"
    _write(path, SPLIT, [0, 1], dirty=True)
    assert earlier_settings(path, [0, 1], COMMIT) == {}
    path.write_text(json.dumps({"split": SPLIT, "settings": {"oracle": {"episodes": [{"index": 0}]}}}))
    assert earlier_settings(path, [0], COMMIT) == {}, "an unstamped file says no commit"


def test_one_task_is_its_slots_among_the_first_n() -> None:
    assert episode_indices(5, "Boil X") == ([4], []), "slot i holds task i % 12, the fifth is Boil X"


def test_one_task_needs_a_results_file_of_its_own() -> None:
    before = RESULTS.read_bytes()
    with pytest.raises(SystemExit) as stopped:
        main(["--task", "Boil X"])
    assert stopped.value.code == 2
    assert RESULTS.read_bytes() == before
