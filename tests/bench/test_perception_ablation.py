"""The ablation bench keeps settings measured in an earlier run only when they cover the same episodes, and
re-runs one task's episodes on request."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.perception_ablation import RESULTS, SPLIT, earlier_settings, episode_indices, main


def _write(path: Path, split: str, indices: list[int]) -> None:
    rows = {"oracle": {"success_rate": 0.8, "episodes": [{"index": i} for i in indices]}}
    path.write_text(json.dumps({"split": split, "settings": rows}))


def test_settings_of_the_same_episodes_are_kept(tmp_path: Path) -> None:
    path = tmp_path / "ablation.json"
    _write(path, SPLIT, [0, 1, 2])
    assert earlier_settings(path, [0, 1, 2])["oracle"]["success_rate"] == 0.8


def test_settings_of_other_episodes_or_another_split_or_no_file_are_dropped(tmp_path: Path) -> None:
    path = tmp_path / "ablation.json"
    assert earlier_settings(path, [0, 1]) == {}
    _write(path, SPLIT, [0, 1, 2])
    assert earlier_settings(path, [0, 1]) == {}
    _write(path, "valid_seen", [0, 1])
    assert earlier_settings(path, [0, 1]) == {}


def test_one_task_is_its_slots_among_the_first_n() -> None:
    assert episode_indices(5, "Boil X") == ([4], []), "slot i holds task i % 12, the fifth is Boil X"


def test_one_task_needs_a_results_file_of_its_own() -> None:
    before = RESULTS.read_bytes()
    with pytest.raises(SystemExit) as stopped:
        main(["--task", "Boil X"])
    assert stopped.value.code == 2
    assert RESULTS.read_bytes() == before
