"""Metrics on small hand-computed cases: TEACh's GC formula, trajectory-length weights, aggregation."""

from __future__ import annotations

import pytest

from harness.drive.metrics import EpisodeOutcome, aggregate, episode_metrics, failure_histogram


def outcome(**fields: object) -> EpisodeOutcome:
    base: dict[str, object] = {
        "instance_id": "g1.edh0",
        "task_name": "Coffee",
        "success": False,
        "gc_satisfied": 0,
        "gc_total": 4,
        "init_gc_satisfied": 0,
        "init_gc_total": 4,
        "pred_len": 10,
        "ref_len": 10,
    }
    base.update(fields)
    return EpisodeOutcome(**base)  # type: ignore[arg-type]


def test_gc_counts_only_conditions_unsatisfied_at_the_start() -> None:
    # 6 conditions were left after the history; 3 are still left at the end: GC = 1 - 3/6.
    m = episode_metrics(outcome(init_gc_total=10, init_gc_satisfied=4, gc_total=12, gc_satisfied=9))
    assert m["goal_condition_success"] == pytest.approx(0.5)
    assert (m["completed_goal_conditions"], m["total_goal_conditions"]) == (3, 6)


def test_satisfied_counts_are_capped_at_totals() -> None:
    m = episode_metrics(outcome(init_gc_total=4, init_gc_satisfied=1, gc_total=4, gc_satisfied=6))
    assert m["goal_condition_success"] == 1.0
    assert (m["completed_goal_conditions"], m["total_goal_conditions"]) == (3, 3)


def test_undoing_work_makes_gc_negative_as_in_teach() -> None:
    m = episode_metrics(outcome(init_gc_total=4, init_gc_satisfied=2, gc_total=4, gc_satisfied=0))
    assert m["goal_condition_success"] == pytest.approx(-1.0)


def test_nothing_left_at_the_start() -> None:
    assert episode_metrics(outcome(init_gc_satisfied=4, gc_satisfied=4))["goal_condition_success"] == 1.0
    assert episode_metrics(outcome(init_gc_satisfied=4, gc_satisfied=3))["goal_condition_success"] == 0.0


def test_trajectory_length_weighting() -> None:
    # |A_R| = 20, |Â| = 40: weight 20 / 40; SR 1 -> TLW-SR 0.5; GC 0.5 -> TLW-GC 0.25.
    m = episode_metrics(
        outcome(success=True, pred_len=40, ref_len=20, init_gc_total=4, gc_total=4, gc_satisfied=4)
    )
    assert (m["success"], m["success_spl"], m["path_len_weighted_success_spl"]) == (1, 0.5, 10.0)
    m = episode_metrics(outcome(pred_len=40, ref_len=20, gc_satisfied=2))
    assert (m["goal_condition_spl"], m["path_len_weighted_goal_condition_spl"]) == (0.25, 5.0)


def test_a_shorter_trajectory_than_the_reference_is_not_rewarded_beyond_one() -> None:
    m = episode_metrics(outcome(success=True, pred_len=5, ref_len=20, gc_satisfied=4))
    assert m["success_spl"] == 1.0


def test_aggregate_weights_by_reference_length() -> None:
    a = outcome(instance_id="a", success=True, gc_satisfied=4, pred_len=10, ref_len=10, steps=12, wall_s=1.0)
    b = outcome(
        instance_id="b",
        task_name="Salad",
        init_gc_satisfied=2,
        gc_satisfied=3,
        pred_len=60,
        ref_len=30,
        steps=70,
        wall_s=3.0,
    )
    summary = aggregate([a, b])
    assert summary["success"] == {"num_successes": 1, "num_evals": 2, "success_rate": 0.5}
    gc = summary["goal_condition_success"]
    assert (gc["completed_goal_conditions"], gc["total_goal_conditions"]) == (5, 6)
    assert gc["goal_condition_success_rate"] == pytest.approx(5 / 6)
    assert gc["mean_goal_condition_success"] == pytest.approx(0.75)
    # TLW-SR: (1 * 1 * 10 + 0) / 40; TLW-GC: (1 * 1 * 10 + 0.5 * 0.5 * 30) / 40.
    assert summary["path_length_weighted_success_rate"] == pytest.approx(0.25)
    assert summary["path_length_weighted_goal_condition_success_rate"] == pytest.approx(0.4375)
    assert (summary["n"], summary["mean_steps"], summary["mean_wall_s"]) == (2, 41, 2.0)
    assert summary["per_task"]["Salad"]["success"]["success_rate"] == 0.0
    assert summary["per_task"]["Coffee"]["path_length_weighted_success_rate"] == 1.0


def test_limits_and_stops_are_counted() -> None:
    summary = aggregate(
        [
            outcome(instance_id="a", failure_reasons={"blocked when moving": 30}),
            outcome(instance_id="b", pred_len=1000),
            outcome(instance_id="c", predicted_stop=True),
            outcome(instance_id="d", error=True),
        ]
    )
    assert summary["num_fails_by_api_limit"] == 1
    assert summary["num_fails_by_traj_len_limit"] == 1
    assert summary["num_predicted_stops"] == 1
    assert summary["num_fails_by_error"] == 1


def test_failure_histogram_is_a_share_of_all_failures() -> None:
    outcomes = [
        outcome(failure_reasons={"blocked when moving": 2, "too far to interact": 1}),
        outcome(failure_reasons={"blocked when moving": 1}),
    ]
    assert failure_histogram(outcomes) == {"blocked when moving": 75.0, "too far to interact": 25.0}
    assert aggregate(outcomes)["failure_counts"] == {"blocked when moving": 3, "too far to interact": 1}


def test_aggregate_refuses_nothing() -> None:
    with pytest.raises(ValueError, match="at least one"):
        aggregate([])
