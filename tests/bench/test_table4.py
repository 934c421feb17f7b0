"""The Table 4 bench: each cell is the harness evaluation the seed's row describes, its numbers are TEACh's
metrics of the cell's episodes, the table sets them beside the seed's rows, and end to end it writes one
stamped file with every cell asked for."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.table4 import CELLS, SEED_TABLE_4_UNSEEN, cell_config, cell_summary, main, table
from harness.drive.metrics import EpisodeOutcome, aggregate


def _outcome(task: str, success: bool, satisfied: int, pred: int, ref: int) -> EpisodeOutcome:
    return EpisodeOutcome(
        instance_id=f"{task}.{pred}",
        task_name=task,
        success=success,
        gc_satisfied=satisfied,
        gc_total=4,
        init_gc_satisfied=0,
        init_gc_total=4,
        pred_len=pred,
        ref_len=ref,
    )


RESULT = {
    "metrics": aggregate([_outcome("Coffee", True, 4, 20, 10), _outcome("Boil X", False, 1, 50, 40)]),
    "episode_failures": {"overall": {"wrong final state": 1}},
    "unavailable": {},
}


def test_each_cell_runs_the_planner_and_perception_its_name_says() -> None:
    configs = {cell: cell_config("tfd", 100, cell) for cell in CELLS}
    assert {cell: (c.planner, c.perception) for cell, c in configs.items()} == {
        "expert+oracle": ("oracle", "oracle"),
        "expert+learned": ("oracle", "learned"),
        "model+oracle": ("model", "oracle"),
        "model+learned": ("model", "learned"),
    }
    assert {(c.benchmark, c.split, c.n, c.camera_side) for c in configs.values()} == {
        ("tfd", "valid_unseen", 100, 300)
    }, "every cell runs the same slots"


def test_a_cells_numbers_are_teachs_metrics_of_its_episodes() -> None:
    summary = cell_summary(RESULT)
    assert (summary["n"], summary["successes"]) == (2, 1)
    assert summary["sr"] == pytest.approx(0.5)
    assert summary["gc"] == pytest.approx(5 / 8), "completed over open conditions, summed over episodes"
    assert summary["tlw_sr"] == pytest.approx(0.5 * 10 / 50), "the success weighted by 10/20, over 50 steps"
    assert summary["per_task_sr"] == {"Boil X": 0.0, "Coffee": 1.0}
    assert summary["episode_failures"] == {"wrong final state": 1}


def test_the_table_sets_each_cell_beside_the_seed_row_it_ablates() -> None:
    summary = cell_summary(RESULT)
    lines = table("edh", {"expert+oracle": summary, "model+oracle": summary}).splitlines()
    ours = ["50.0", "[10.0]", "62.5", "[26.0]"]  # TLW-GC: (1 x 10/20 x 10 + 1/4 x 40/50 x 40) / 50
    assert lines[1].split()[:5] == ["expert+oracle", *ours]
    assert "60.9 [26.2], 63.6 [35.4]  Reasoning (w/ gt subgoals & visual)" in lines[1]
    assert lines[2].split() == ["model+oracle", *ours], "no seed row: the seed's teleports"
    assert SEED_TABLE_4_UNSEEN["tfd"]["model+learned"] == ("JARVIS", (1.8, 0.3, 3.1, 1.6))


def test_an_unknown_cell_is_one_line_and_exit_code_2(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--cells", "expert+teleport"])
    assert stop.value.code == 2
    assert "--cells" in capsys.readouterr().err


@pytest.mark.slow
def test_two_cells_end_to_end_write_one_stamped_file(tmp_path: Path) -> None:
    out = tmp_path / "table4.json"
    args = ["--benchmark", "edh", "--n", "1", "--cells", "expert+oracle", "model+oracle"]
    assert main([*args, "--run-dir", str(tmp_path / "runs"), "--out", str(out)]) == 0

    report = json.loads(out.read_text())
    assert report["stamp"]["bench"] == "table4" and report["stamp"]["commit"]
    assert list(report["cells"]) == ["expert+oracle", "model+oracle"]
    assert report["cells"]["model+oracle"]["planner"] == "model"
    for row in report["cells"].values():
        assert row["n"] + len(row["unavailable"]) == 1 and 0.0 <= row["sr"] <= 1.0
    assert report["seed_table_4_unseen_percent"]["model+learned"]["row"] == "JARVIS"
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == ["expert_oracle", "model_oracle"]
