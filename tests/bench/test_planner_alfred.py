"""The ALFRED planner bench names the episodes the model planner loses or gains, with their sentence."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from bench.planner_alfred import SPLIT, alfred_config, changed_episodes
from harness.drive.evaluate import EPISODES_DIR, EvalConfig, episode_file_name, episode_for, evaluate
from harness.drive.service import running_service
from symbolic.thor import ALFRED_HFOV_DEG

SMALL_CAMERA_SIDE = 100  # pixels: the test reads episode files, it does not judge the agent


@pytest.mark.data
def test_a_slot_whose_outcome_differs_is_listed_with_its_sentence_and_first_plan(
    shared_data_dir: Path, tmp_path: Path
) -> None:
    if not (shared_data_dir / "alfred" / "valid_seen.jsonl.gz").is_file():
        pytest.skip(f"no ALFRED valid_seen trajectories in {shared_data_dir / 'alfred'}")
    config = EvalConfig(
        benchmark="alfred", split=SPLIT, n=2, camera_side=SMALL_CAMERA_SIDE, hfov_deg=ALFRED_HFOV_DEG
    )
    with running_service() as service:
        evaluate(config, tmp_path / "oracle", service.base_url)
    # The same run as the model's, but for one episode that ended the other way with another plan.
    shutil.copytree(tmp_path / "oracle", tmp_path / "model")
    changed_file = tmp_path / "model" / EPISODES_DIR / episode_file_name(1)
    record = json.loads(changed_file.read_text())
    record["outcome"]["success"] = not record["outcome"]["success"]
    record["plans"] = [["Navigate Knife", "Pickup Knife"], ["Navigate ButterKnife"]]
    changed_file.write_text(json.dumps(record))

    changed = changed_episodes(tmp_path, 2)

    rows = changed["gained"] + changed["lost"]
    assert [row["slot"] for row in rows] == [1], "slot 0 ended the same way in both runs"
    assert rows == (changed["gained"] if record["outcome"]["success"] else changed["lost"])
    row = rows[0]
    assert row["first_plan"] == "Navigate Knife, Pickup Knife"
    assert row["instruction"] == episode_for(alfred_config("model", 2), 1).instruction
    assert row["task_type"] == record["task_name"] and row["instance_id"] == record["instance_id"]
