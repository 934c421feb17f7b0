"""Generated plans are validated against the ontology: unknown names mapped to the nearest type or dropped,
and every such decision reported."""

from __future__ import annotations

from models.planner.predict import validate_generated_plan
from symbolic.ontology import load_ontology
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


def test_a_clean_lower_case_generation_parses_to_canonical_types() -> None:
    text = "navigate butterknife, pickup butterknife, navigate breadsliced, toggleon toaster"
    subgoals, notes = validate_generated_plan(text, load_ontology())
    assert subgoals == [
        Subgoal(A.NAVIGATE, "ButterKnife"),
        Subgoal(A.PICKUP, "ButterKnife"),
        Subgoal(A.NAVIGATE, "BreadSliced"),
        Subgoal(A.TOGGLE_ON, "Toaster"),
    ]
    assert notes == []


def test_a_misspelt_object_is_mapped_to_the_nearest_type_and_said_so() -> None:
    subgoals, notes = validate_generated_plan("navigate coffeemachin, place coffeemachin", load_ontology())
    assert subgoals == [Subgoal(A.NAVIGATE, "CoffeeMachine"), Subgoal(A.PLACE, "CoffeeMachine")]
    assert [(n.item_index, n.kind) for n in notes] == [(0, "mapped"), (1, "mapped")]
    assert "'coffeemachin' -> CoffeeMachine" in notes[0].detail
    assert notes[1].subgoals == (Subgoal(A.PLACE, "CoffeeMachine"),)


def test_items_without_an_action_or_a_known_object_are_dropped_and_the_rest_kept() -> None:
    text = "navigate mug, frobnicate the mug, pickup qqqqzzzz, pickup mug,"
    subgoals, notes = validate_generated_plan(text, load_ontology())
    assert subgoals == [Subgoal(A.NAVIGATE, "Mug"), Subgoal(A.PICKUP, "Mug")]
    assert [(n.item_index, n.item, n.kind) for n in notes] == [
        (1, "frobnicate the mug", "dropped"),
        (2, "pickup qqqqzzzz", "dropped"),
    ]
    assert "expected an action" in notes[0].detail
    assert "qqqqzzzz" in notes[1].detail


def test_an_empty_or_truncated_generation_gives_an_empty_plan() -> None:
    assert validate_generated_plan("", load_ontology()) == ([], [])
    subgoals, notes = validate_generated_plan("navigate", load_ontology())
    assert subgoals == []
    assert [n.kind for n in notes] == ["dropped"]
