"""Subgoal grammar (DESIGN.md §5) and the actions-to-subgoals rule for TEACh and ALFRED action lists."""

from __future__ import annotations

from typing import Any

import pytest

from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import (
    ACTION_NAME_FOR_SUBGOAL,
    Subgoal,
    SubgoalAction,
    SubgoalSyntaxError,
    format_subgoals,
    object_type_of_id,
    parse_subgoals,
    subgoals_from_alfred_low_actions,
    subgoals_from_teach_actions,
    to_teach_words,
)
from symbolic.thor import OBJECT_ACTIONS

A = SubgoalAction
KNIFE_THEN_BREAD = [
    Subgoal(A.NAVIGATE, "Knife"),
    Subgoal(A.PICKUP, "Knife"),
    Subgoal(A.NAVIGATE, "Bread"),
    Subgoal(A.SLICE, "Bread"),
]


def test_subgoal_prints_as_text() -> None:
    assert str(Subgoal(A.NAVIGATE, "Knife")) == "Navigate Knife"
    assert format_subgoals(KNIFE_THEN_BREAD) == "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread"


@pytest.mark.parametrize(
    "source",
    [
        "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread",
        "Navigate Knife; Pickup Knife; Navigate Bread; Slice Bread",
        "Navigate Knife\nPickup Knife\nNavigate Bread\nSlice Bread\n",
        "navigate knife, PICKUP knife, Navigate the bread, cut bread",
        "Go to the knife, pick up the knife, goto bread, slice bread",
        "Navigate Knife Pickup Knife Navigate Bread Slice Bread",
        ["Navigate", "Knife", "Pickup", "Knife", "Navigate", "Bread", "Slice", "Bread"],
        ["Navigate Knife", "Pickup Knife", "Navigate Bread", "Slice Bread"],
        [
            {"action": "Navigate", "object": "Knife"},
            {"action": "PickUp", "object": "knife"},
            {"action": "GoTo", "obj": "Bread"},
            {"action": "Slice", "object": "Bread"},
        ],
        [["Navigate", "Knife"], ("Pickup", "Knife"), ["Navigate", "Bread"], ["Cut", "Bread"]],
        KNIFE_THEN_BREAD,
    ],
)
def test_every_input_form_parses_to_the_same_plan(onto: Ontology, source: Any) -> None:
    assert parse_subgoals(source, onto) == KNIFE_THEN_BREAD


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("Put Sink", Subgoal(A.PLACE, "SinkBasin")),
        ("put it in the sink", Subgoal(A.PLACE, "SinkBasin")),
        ("Navigate sink", Subgoal(A.NAVIGATE, "Sink")),
        ("TurnOn Faucet", Subgoal(A.TOGGLE_ON, "Faucet")),
        ("turn off the tap", Subgoal(A.TOGGLE_OFF, "Faucet")),
        ("ToggleOn stove", Subgoal(A.TOGGLE_ON, "StoveBurner")),
        ("Pour house plant", Subgoal(A.POUR, "HousePlant")),
        ("Place table", Subgoal(A.PLACE, "DiningTable")),
        ("Pickup slice of bread", Subgoal(A.PICKUP, "BreadSliced")),
        ("open the refrigerator", Subgoal(A.OPEN, "Fridge")),
    ],
)
def test_aliases_and_names(onto: Ontology, text: str, expected: Subgoal) -> None:
    assert parse_subgoals(text, onto) == [expected]


def test_round_trip_through_text_and_teach_words(onto: Ontology) -> None:
    plan = [Subgoal(action, "Mug") for action in A if action is not A.SLICE] + [Subgoal(A.SLICE, "Apple")]
    assert parse_subgoals(format_subgoals(plan), onto) == plan
    words = to_teach_words(plan)
    assert words[:4] == ["Navigate", "Mug", "Pickup", "Mug"]
    assert parse_subgoals(words, onto) == plan


def test_empty_plans(onto: Ontology) -> None:
    assert parse_subgoals("", onto) == []
    assert parse_subgoals([], onto) == []
    assert format_subgoals([]) == ""


@pytest.mark.parametrize(
    ("source", "where"),
    [
        ("Navigate Knife, Fly Knife", "subgoal 2 ('Fly Knife')"),
        ("Navigate", "subgoal 1 ('Navigate')"),
        ("Pickup the", "subgoal 1 ('Pickup the')"),
        (["Navigate", "Knife", "Pickup"], "word 2"),
        (["Navigate", "Knife", "Fly", "Knife"], "word 2"),
        ([{"verb": "Pickup"}], "item 0"),
        ([3], "item 0"),
        ([["Pickup"]], "item 0"),
    ],
)
def test_syntax_errors_say_where(onto: Ontology, source: Any, where: str) -> None:
    with pytest.raises(SubgoalSyntaxError, match="expected|alternates") as error:
        parse_subgoals(source, onto)
    assert where in str(error.value)


def test_unknown_object_is_reported_with_suggestions(onto: Ontology) -> None:
    with pytest.raises(UnknownObjectType) as error:
        parse_subgoals("Navigate Frige", onto)
    assert "Fridge" in error.value.suggestions


def test_action_names_for_subgoals_are_teach_driver_actions() -> None:
    assert set(ACTION_NAME_FOR_SUBGOAL.values()) == set(OBJECT_ACTIONS)
    assert A.NAVIGATE not in ACTION_NAME_FOR_SUBGOAL
    assert ACTION_NAME_FOR_SUBGOAL[A.TOGGLE_ON] == "ToggleOn"


@pytest.mark.parametrize(
    ("oid", "object_type"),
    [
        ("Knife|+01.00|+00.90|-00.50", "Knife"),
        ("Bread|-00.52|+01.17|-00.03|BreadSliced_1", "BreadSliced"),
        ("Sink|-01.99|+00.14|-00.18|SinkBasin", "SinkBasin"),
        ("Egg|+00.10|+00.90|+00.20|EggCracked_0", "EggCracked"),
    ],
)
def test_object_type_of_id(oid: str, object_type: str) -> None:
    assert object_type_of_id(oid) == object_type


def _teach(name: str, oid: str | None = None) -> dict[str, object]:
    return {"action_name": name, "oid": oid, "obj_interaction_action": int(oid is not None)}


def test_teach_actions_become_subgoals() -> None:
    history = [
        _teach("Text"),
        _teach("Forward"),
        _teach("Turn Left"),
        _teach("Look Down"),
        _teach("Pickup", "Knife|+01.00|+00.90|-00.50"),
        _teach("Pan Right"),
        _teach("Slice", "Bread|-00.52|+01.17|-00.03"),
        _teach("Place", "CounterTop|+00.10|+00.95|+00.20"),
        _teach("Pickup", "Bread|-00.52|+01.17|-00.03|BreadSliced_1"),
        _teach("Backward"),
        _teach("Turn Right"),
        _teach("Place", "Toaster|+00.90|+00.95|+00.10"),
        _teach("ToggleOn", "Toaster|+00.90|+00.95|+00.10"),
        _teach("Stop"),
        _teach("Forward"),
    ]
    subgoals = subgoals_from_teach_actions(history)
    assert format_subgoals(subgoals) == (
        "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread, Place CounterTop, Pickup BreadSliced, "
        "Navigate Toaster, Place Toaster, ToggleOn Toaster"
    )


def test_teach_interaction_without_object_is_skipped_but_still_ends_the_run() -> None:
    actions = [_teach("Forward"), _teach("Pickup", None), _teach("Open", "Fridge|+1|+0|+2")]
    assert subgoals_from_teach_actions(actions) == [Subgoal(A.NAVIGATE, "Fridge"), Subgoal(A.OPEN, "Fridge")]


def _alfred(action: str, **ids: str) -> dict[str, object]:
    return {"api_action": {"action": action, "forceAction": True, **ids}}


def test_alfred_low_actions_become_subgoals() -> None:
    low = [
        _alfred("LookDown"),
        _alfred("MoveAhead"),
        _alfred("PickupObject", objectId="Knife|+01.00|+00.90|-00.50"),
        _alfred("SliceObject", objectId="Apple|-00.52|+01.17|-00.03"),
        _alfred("RotateLeft"),
        _alfred("OpenObject", objectId="Microwave|+00.9|+01.1|+00.1"),
        _alfred(
            "PutObject",
            objectId="Knife|+01.00|+00.90|-00.50",
            receptacleObjectId="Microwave|+00.9|+01.1|+00.1",
        ),
        _alfred("CloseObject", objectId="Microwave|+00.9|+01.1|+00.1"),
        _alfred("ToggleObjectOn", objectId="Microwave|+00.9|+01.1|+00.1"),
        _alfred("ToggleObjectOff", objectId="Microwave|+00.9|+01.1|+00.1"),
    ]
    assert format_subgoals(subgoals_from_alfred_low_actions(low)) == (
        "Navigate Knife, Pickup Knife, Slice Apple, Navigate Microwave, Open Microwave, Place Microwave, "
        "Close Microwave, ToggleOn Microwave, ToggleOff Microwave"
    )


@pytest.mark.data
def test_real_alfred_trajectory(alfred_valid_seen: list[dict[str, Any]]) -> None:
    """valid_seen's 'cooked slice of apple' trajectory, subgoal by subgoal."""
    traj = next(t for t in alfred_valid_seen if t["task_id"] == "trial_T20190907_232225_725376")
    assert format_subgoals(subgoals_from_alfred_low_actions(traj["plan"]["low_actions"])) == (
        "Navigate Knife, Pickup Knife, Slice Apple, Place SinkBasin, Pickup AppleSliced, Navigate Microwave, "
        "Open Microwave, Place Microwave, Close Microwave, ToggleOn Microwave, ToggleOff Microwave, "
        "Open Microwave, Pickup AppleSliced, Close Microwave, Navigate CounterTop, Place CounterTop"
    )


@pytest.mark.data
def test_all_alfred_trajectories_follow_the_rule(
    onto: Ontology, alfred_valid_seen: list[dict[str, Any]]
) -> None:
    """Every interaction low action gives one subgoal; every Navigate names the next interaction's object."""
    interactions = {"PickupObject", "PutObject", "OpenObject", "CloseObject", "ToggleObjectOn",
                    "ToggleObjectOff", "SliceObject"}  # fmt: skip
    for traj in alfred_valid_seen:
        low = traj["plan"]["low_actions"]
        subgoals = subgoals_from_alfred_low_actions(low)
        acted = [g for g in subgoals if g.action is not A.NAVIGATE]
        assert len(acted) == sum(step["api_action"]["action"] in interactions for step in low)
        for i, subgoal in enumerate(subgoals):
            onto.get(subgoal.obj)
            if subgoal.action is A.NAVIGATE:
                assert subgoals[i + 1].action is not A.NAVIGATE
                assert subgoals[i + 1].obj == subgoal.obj
