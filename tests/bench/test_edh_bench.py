"""The EDH bench: its report's numbers are TEACh's metrics of the episodes (exact on hand-made outcomes), its
table puts ours beside the seed's Table 1 rows, and end to end through the real service it writes every field
the README promises."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.edh import SEED_TABLE_1_EDH, edh_summary, main, per_task_table, seed_layout_table
from harness.drive.metrics import EpisodeOutcome, aggregate


def _outcome(
    task: str, success: bool, final: tuple[int, int], init: tuple[int, int], pred: int, ref: int
) -> EpisodeOutcome:
    return EpisodeOutcome(
        instance_id=f"{task}.{pred}",
        task_name=task,
        success=success,
        gc_satisfied=final[0],
        gc_total=final[1],
        init_gc_satisfied=init[0],
        init_gc_total=init[1],
        pred_len=pred,
        ref_len=ref,
    )


OUTCOMES = [
    # 1 of 1 open condition done; twice the reference length: weight 0.5.
    _outcome("Coffee", True, final=(3, 3), init=(2, 3), pred=20, ref=10),
    # 1 of 3 open conditions done (GC 1/3); shorter than the reference: weight 1.
    _outcome("Coffee", False, final=(1, 3), init=(0, 3), pred=5, ref=30),
    _outcome("Water Plant", True, final=(2, 2), init=(1, 2), pred=8, ref=8),
]
RESULT = {"metrics": aggregate(OUTCOMES), "episode_failures": {}, "unavailable": {}}


def test_the_summary_holds_teach_sr_gc_and_length_weighted_metrics_overall_and_per_task() -> None:
    summary = edh_summary(RESULT)

    overall = summary["overall"]
    assert overall["n"] == 3 and overall["successes"] == 2
    assert overall["sr"] == pytest.approx(2 / 3)
    assert overall["gc"] == pytest.approx(3 / 5), "TEACh: completed over open conditions, summed"
    assert overall["gc_mean_per_episode"] == pytest.approx((1 + 1 / 3 + 1) / 3)
    assert overall["tlw_sr"] == pytest.approx((1 * 0.5 * 10 + 0 + 1 * 1 * 8) / 48), (
        "weights |A_R| / sum |A_R|"
    )
    assert overall["tlw_gc"] == pytest.approx((1 * 0.5 * 10 + (1 / 3) * 30 + 1 * 8) / 48)
    coffee = summary["per_task"]["Coffee"]
    assert (coffee["n"], coffee["sr"], coffee["gc"]) == (2, 0.5, pytest.approx(2 / 4))
    assert coffee["tlw_sr"] == pytest.approx(5 / 40) and coffee["tlw_gc"] == pytest.approx(15 / 40)
    assert coffee["seed_table_3_edh_sr_percent"] == 21.3
    assert summary["per_task"]["Water Plant"]["seed_table_3_edh_sr_percent"] == 21.0


def test_the_table_puts_our_unseen_percentages_under_the_seeds_rows_in_its_layout() -> None:
    summary = edh_summary(RESULT)

    lines = seed_layout_table(summary["overall"], "ours").splitlines()

    assert lines[1].split() == ["Model", *["SR", "[TLW]", "GC", "[TLW]"] * 2]
    assert [line.split("  ")[0] for line in lines[2:-1]] == list(SEED_TABLE_1_EDH)
    assert "15.8 [2.6]" in lines[3] and "16.6 [8.2]" in lines[3], "JARVIS's EDH unseen cells"
    assert lines[-1].split() == ["ours", "-", "-", "66.7", "[27.1]", "60.0", "[47.9]"]
    task_rows = per_task_table(summary["per_task"]).splitlines()[1:]
    assert [row.split("  ")[0] for row in task_rows] == ["Water Plant", "Coffee"], "TEACh's task order"


def test_a_run_where_no_episode_ran_is_an_error_not_a_zero() -> None:
    with pytest.raises(ValueError, match="no EDH episode ran"):
        edh_summary({"metrics": None, "episode_failures": {}, "unavailable": {"0": "no game"}})


def test_a_bad_count_is_one_line_and_exit_code_2(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(["--n", "0"])
    assert stop.value.code == 2
    assert "--n" in capsys.readouterr().err


@pytest.mark.slow
def test_two_instances_end_to_end_write_every_reported_field(tmp_path: Path) -> None:
    out = tmp_path / "edh.json"
    run_dir = tmp_path / "run"

    assert main(["--n", "2", "--workers", "2", "--run-dir", str(run_dir), "--out", str(out)]) == 0

    report = json.loads(out.read_text())
    stamp = report["stamp"]
    assert stamp["bench"] == "edh" and stamp["command"].startswith("python -m bench.edh --n 2")
    assert stamp["commit"] and stamp["machine"]["cores"] >= 1
    assert report["agent"]["perception"] == "oracle" and report["planner_checkpoint"]["recipe"]
    overall = report["result"]["overall"]
    assert overall["n"] + len(report["result"]["unavailable"]) == 2
    assert set(report["result"]["per_task"]) <= {"Water Plant", "Coffee"}, "slot i is task i % 12"
    for key in ("sr", "gc", "tlw_sr", "tlw_gc"):
        assert 0.0 <= overall[key] <= 1.0
        assert report["table_1_edh_unseen_percent"]["ours"][key] == round(100 * overall[key], 1)
    assert overall["tlw_sr"] <= overall["sr"] and overall["tlw_gc"] <= overall["gc"] + 1e-9
    assert report["table_1_edh_unseen_percent"]["seed"]["JARVIS (Ours)"]["sr"] == [15.8, 2.6], "quoted beside"
    assert report["seed_table_1_edh_percent"]["JARVIS (Ours)"]["seen"]["gc"] == [22.6, 8.7]
    episodes = sorted((run_dir / "episodes").glob("*.json"))
    assert [path.name for path in episodes] == ["00000.json", "00001.json"]
    metrics = json.loads((run_dir / "metrics.json").read_text())
    assert metrics["config"]["benchmark"] == "edh" and metrics["config"]["planner"] == "model"
