"""Planner metrics on tiny hand-made cases with exact answers, and the container normalisation."""

from __future__ import annotations

import pytest

from models.planner.data import PlannerExample
from models.planner.evaluate import (
    MISS_KINDS,
    drop_fetch_container_open_close,
    edit_distance,
    format_miss_table,
    miss_kind,
    report_for,
    score_plans,
)
from models.planner.predict import PlanPrediction
from symbolic.ontology import load_ontology
from symbolic.subgoals import Subgoal, parse_subgoals


def plan(text: str) -> list[Subgoal]:
    return parse_subgoals(text, load_ontology()) if text else []


@pytest.mark.parametrize(
    ("a", "b", "distance"),
    [
        ("", "", 0),
        ("Navigate Mug, Pickup Mug", "", 2),
        ("Navigate Mug, Pickup Mug", "Navigate Mug, Pickup Mug", 0),
        ("Navigate Mug, Pickup Mug", "Navigate Cup, Pickup Mug", 1),
        ("Navigate Mug, Pickup Mug, Navigate Sink", "Pickup Mug, Navigate Sink, Place Sink", 2),
    ],
)
def test_edit_distance_counts_whole_subgoals(a: str, b: str, distance: int) -> None:
    assert edit_distance(plan(a), plan(b)) == distance
    assert edit_distance(plan(b), plan(a)) == distance


def test_scores_of_a_small_set_are_exact() -> None:
    reference = [
        plan("Navigate Mug, Pickup Mug"),
        plan("Navigate Apple, Pickup Apple, Navigate Fridge, Place Fridge"),
    ]
    predicted = [plan("Navigate Mug, Pickup Mug"), plan("Navigate Apple, Pickup Apple, Navigate Sink")]
    scores = score_plans(predicted, reference)
    assert scores.count == 2
    assert scores.exact_match == 0.5
    assert scores.precision == pytest.approx(4 / 5)  # 5 predicted subgoals, 4 of them in the references
    assert scores.recall == pytest.approx(4 / 6)
    assert scores.f1 == pytest.approx(2 * (4 / 5) * (4 / 6) / (4 / 5 + 4 / 6))
    assert scores.mean_edit_distance == pytest.approx((0 + 2) / 2)


def test_overlap_counts_repeated_subgoals_only_as_often_as_the_reference_has_them() -> None:
    twice = plan("Navigate Apple, Pickup Apple, Navigate Apple, Pickup Apple")
    scores = score_plans([twice], [plan("Navigate Apple, Pickup Apple")])
    assert (scores.precision, scores.recall) == (0.5, 1.0)


def test_an_empty_set_scores_zero_and_mismatched_lengths_are_refused() -> None:
    assert score_plans([], []).count == 0
    with pytest.raises(ValueError, match="1 predictions for 0 references"):
        score_plans([plan("Navigate Mug")], [])


def test_fetching_from_a_container_is_normalised_away() -> None:
    reference = plan("Navigate Fridge, Open Fridge, Pickup Apple, Close Fridge, Navigate Sink, Place Sink")
    language_only = plan("Navigate Apple, Pickup Apple, Navigate Sink, Place Sink")
    assert drop_fetch_container_open_close(reference) == language_only
    assert drop_fetch_container_open_close(language_only) == language_only
    scores = score_plans([language_only], [reference])
    assert (scores.exact_match, scores.exact_match_container_normalised) == (0.0, 1.0)


def test_putting_into_a_container_is_kept_and_a_navigate_inside_collapses() -> None:
    cool = plan(
        "Navigate Fridge, Open Fridge, Place Fridge, Close Fridge, Open Fridge, Pickup Apple, Close Fridge"
    )
    assert drop_fetch_container_open_close(cool) == plan(
        "Navigate Fridge, Open Fridge, Place Fridge, Close Fridge, Pickup Apple"
    )
    fetched = plan(
        "Navigate Fridge, Open Fridge, Navigate Bread, Pickup Bread, Close Fridge, Place CounterTop"
    )
    assert drop_fetch_container_open_close(fetched) == plan("Navigate Bread, Pickup Bread, Place CounterTop")


def test_opening_for_nothing_but_the_container_itself_is_kept() -> None:
    heat = plan("Open Microwave, ToggleOn Microwave, Close Microwave")
    assert drop_fetch_container_open_close(heat) == heat


def test_reports_group_by_task_type_and_count_validation_notes() -> None:
    ontology = load_ontology()
    examples = [
        PlannerExample("a", "<COM> x", "Navigate Mug, Pickup Mug", "Coffee", "handwritten"),
        PlannerExample("b", "<COM> y", "Navigate Pot, Pickup Pot", "Boil X", "handwritten"),
        PlannerExample("c", "<COM> z", "Navigate Mug, Pickup Mug", "Coffee", "handwritten"),
    ]
    predictions = [
        PlanPrediction("navigate mug, pickup mug", tuple(plan("Navigate Mug, Pickup Mug")), ()),
        PlanPrediction("navigate pot", tuple(plan("Navigate Pot")), ()),
        PlanPrediction("navigate mug", tuple(plan("Navigate Mug")), ()),
    ]
    report = report_for("tiny", examples, predictions, ontology)
    assert report.overall.exact_match == pytest.approx(1 / 3)
    assert report.per_task_type["Coffee"].exact_match == 0.5
    assert report.per_task_type["Boil X"].recall == 0.5
    assert report.as_json()["per_task_type"].keys() == {"Boil X", "Coffee"}


def test_navigate_ignored_match_compares_the_interactions_in_order() -> None:
    walked = plan("Navigate Drawer, Open Drawer, Navigate Knife, Pickup Knife, Close Drawer")
    stood = plan("Open Drawer, Pickup Knife, Close Drawer")
    swapped = plan("Open Drawer, Close Drawer, Pickup Knife")
    scores = score_plans([stood, swapped], [walked, walked])
    assert (scores.exact_match, scores.exact_match_interactions) == (0.0, 0.5)


KNIFE_PLAN = "Navigate Drawer, Open Drawer, Pickup Knife, Close Drawer, Navigate Bread, Slice Bread"


@pytest.mark.parametrize(
    ("predicted", "kind"),
    [
        (KNIFE_PLAN, None),
        ("Open Drawer, Pickup Knife, Close Drawer, Navigate Bread, Slice Bread", "navigate"),
        ("Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread", "fetch_container"),
        ("Navigate Drawer, Open Drawer, Pickup Knife, Close Drawer", "stops_early"),
        (KNIFE_PLAN + ", Place CounterTop", "runs_on"),
        ("Navigate Drawer, Open Drawer, Pickup ButterKnife, Close Drawer, Slice Bread", "other_objects"),
        ("Navigate ButterKnife, Pickup ButterKnife, Navigate Bread, Slice Bread", "other_objects"),
        (
            "Navigate Bread, Pickup Bread",
            "other_steps",
        ),
    ],
)
def test_each_miss_gets_the_first_reason_that_explains_it(predicted: str, kind: str | None) -> None:
    assert miss_kind(plan(predicted), plan(KNIFE_PLAN)) == kind


def test_a_report_counts_its_misses_by_reason_and_the_table_shows_them() -> None:
    ontology = load_ontology()
    examples = [
        PlannerExample(str(i), "<COM> slice the bread", KNIFE_PLAN, "Toast", "handwritten") for i in range(3)
    ]
    texts = [
        KNIFE_PLAN,
        "Open Drawer, Pickup Knife, Close Drawer, Navigate Bread, Slice Bread",
        KNIFE_PLAN + ", Place CounterTop",
    ]
    predictions = [PlanPrediction(text, tuple(plan(text)), ()) for text in texts]
    record = report_for("tiny", examples, predictions, ontology).as_json()
    assert record["misses"] == {kind: int(kind in ("navigate", "runs_on")) for kind in MISS_KINDS}
    table = format_miss_table([record])
    assert table.splitlines()[2] == "| tiny | 2 | 1 | 0 | 0 | 1 | 0 | 0 |"
