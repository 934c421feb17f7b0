"""The ablation bench keeps settings measured in an earlier run only when they cover the same episodes."""

from __future__ import annotations

import json
from pathlib import Path

from bench.perception_ablation import SPLIT, earlier_settings


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
