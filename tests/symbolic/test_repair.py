"""Task-level repair (JARVIS Alg. 2 and the kitchen rules): one test per rule, plus the acceptance example."""

from __future__ import annotations

from typing import Any

import pytest

from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.registry import UnknownName
from symbolic.repair import REPAIR_RULES, SLICE_NEEDS_KNIFE, RepairResult, repair_plan, slice_needs_knife
from symbolic.subgoals import (
    Subgoal,
    SubgoalAction,
    format_subgoals,
    parse_subgoals,
    subgoals_from_alfred_low_actions,
)

A = SubgoalAction


def repair(onto: Ontology, text: str, belief: BeliefState | None = None) -> RepairResult:
    return repair_plan(parse_subgoals(text, onto), onto, belief)


def fired(result: RepairResult) -> list[str]:
    return [event.rule for event in result.log]


def test_acceptance_slice_bread_fetches_a_knife_first(onto: Ontology) -> None:
    result = repair(onto, "Slice Bread")
    assert format_subgoals(result.plan) == "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread"
    assert fired(result) == ["slice-needs-knife"] + ["navigate-before-interaction"] * 2
    first = result.log[0]
    assert first.inserted == (Subgoal(A.PICKUP, "Knife"),) and first.removed == ()
    assert "knife" in first.reason


def test_a_long_run_of_repeated_pickups_settles_to_one(onto: Ontology) -> None:
    """Seventy "Pickup Apple" (a client's loop gone wrong) are one pickup and 69 logged drops, not a 500."""
    result = repair(onto, ", ".join(["Pickup Apple"] * 70))
    assert format_subgoals(result.plan) == "Navigate Apple, Pickup Apple"
    assert fired(result).count("pickup-needs-free-hands") == 69


def test_impossible_actions_are_removed(onto: Ontology) -> None:
    result = repair(onto, "Slice Mug, Open Apple, Pickup CounterTop, ToggleOn Bread, Navigate Floor")
    assert result.plan == []
    assert fired(result) == ["impossible-action"] * 5
    assert [e.removed for e in result.log][0] == (Subgoal(A.SLICE, "Mug"),)
    assert "Mug cannot be sliced" in result.log[0].reason


def test_place_with_nothing_held_is_removed(onto: Ontology) -> None:
    result = repair(onto, "Navigate CounterTop, Place CounterTop")
    assert format_subgoals(result.plan) == "Navigate CounterTop"
    assert fired(result) == ["place-needs-held"]


def test_a_coffee_machine_with_nothing_held_gets_a_mug_fetched(onto: Ontology) -> None:
    result = repair(onto, "Navigate CoffeeMachine, Place CoffeeMachine, ToggleOn CoffeeMachine")
    assert format_subgoals(result.plan) == (
        "Navigate Mug, Pickup Mug, Navigate CoffeeMachine, Place CoffeeMachine, ToggleOn CoffeeMachine"
    )
    assert "place-needs-held" in fired(result)
    assert "CoffeeMachine works on a Mug" in result.log[0].reason


def test_place_into_an_incompatible_receptacle_is_removed(onto: Ontology) -> None:
    belief = BeliefState(held="Bread", at="Toaster")
    result = repair(onto, "Place Toaster", belief)
    assert result.plan == []
    assert fired(result) == ["place-needs-compatible-receptacle"]
    assert "Toaster does not accept Bread" in result.log[0].reason


def test_pickup_with_full_hands_puts_the_held_object_on_the_counter(onto: Ontology) -> None:
    result = repair(onto, "Pickup Apple", BeliefState(held="Mug", at="Apple"))
    expected = "Navigate CounterTop, Place CounterTop, Navigate Apple, Pickup Apple"
    assert format_subgoals(result.plan) == expected
    assert fired(result)[0] == "pickup-needs-free-hands"
    assert result.log[0].inserted == (Subgoal(A.PLACE, "CounterTop"),)


def test_put_down_prefers_a_receptacle_that_accepts_the_held_object(onto: Ontology) -> None:
    """The CounterTop does not take a Pillow; the Sofa the plan mentions does."""
    result = repair(onto, "Pickup Apple, Navigate Sofa", BeliefState(held="Pillow", at="Apple"))
    assert result.log[0].inserted == (Subgoal(A.PLACE, "Sofa"),)


def test_pickup_of_what_is_already_held_is_dropped(onto: Ontology) -> None:
    result = repair(onto, "Pickup Mug", BeliefState(held="Mug"))
    assert result.plan == []
    assert fired(result) == ["pickup-needs-free-hands"]


def test_pickup_from_a_closed_container_opens_it_and_closes_it_after(onto: Ontology) -> None:
    belief = BeliefState.initial(onto)
    belief.inside["Knife"] = "Drawer"
    result = repair(onto, "Pickup Knife", belief)
    assert format_subgoals(result.plan) == "Navigate Drawer, Open Drawer, Pickup Knife, Close Drawer"
    assert fired(result) == ["pickup-from-closed", "close-after-pickup"]


def test_place_into_a_closed_fridge_opens_and_closes_it(onto: Ontology) -> None:
    result = repair(onto, "Navigate Apple, Pickup Apple, Navigate Fridge, Place Fridge")
    assert format_subgoals(result.plan) == (
        "Navigate Apple, Pickup Apple, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge"
    )
    assert fired(result) == ["place-needs-open", "close-after-place"]
    assert "the task leaves it closed" in result.log[1].reason


def test_no_extra_close_when_the_plan_closes_it_later(onto: Ontology) -> None:
    text = "Navigate Apple, Pickup Apple, Navigate Fridge, Place Fridge, Navigate Fridge, Close Fridge"
    result = repair(onto, text)
    assert format_subgoals(result.plan) == (
        "Navigate Apple, Pickup Apple, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge"
    )
    assert "close-after-place" not in fired(result)


def test_no_close_when_the_plan_opened_it_itself(onto: Ontology) -> None:
    text = "Navigate Fridge, Open Fridge, Navigate Apple, Pickup Apple, Navigate Fridge, Place Fridge"
    result = repair(onto, text)
    assert result.plan == parse_subgoals(text, onto)
    assert result.log == []


def test_boxes_stand_open_unless_closed(onto: Ontology) -> None:
    assert repair(onto, "Navigate Watch, Pickup Watch, Navigate Box, Place Box").log == []
    closed = repair(onto, "Navigate Box, Close Box, Navigate Watch, Pickup Watch, Navigate Box, Place Box")
    assert fired(closed) == ["place-needs-open", "close-after-place"]


def test_slice_with_full_hands_puts_down_then_fetches_a_knife(onto: Ontology) -> None:
    result = repair(onto, "Slice Tomato", BeliefState(held="Plate", at="Tomato"))
    assert format_subgoals(result.plan) == (
        "Navigate CounterTop, Place CounterTop, Navigate Knife, Pickup Knife, Navigate Tomato, Slice Tomato"
    )
    assert result.log[0].rule == "slice-needs-knife"
    assert result.log[0].inserted == (Subgoal(A.PLACE, "CounterTop"), Subgoal(A.PICKUP, "Knife"))


def test_a_butter_knife_is_knife_enough(onto: Ontology) -> None:
    assert repair(onto, "Slice Bread", BeliefState(held="ButterKnife", at="Bread")).log == []


def test_pieces_need_slicing_first(onto: Ontology) -> None:
    result = repair(onto, "Navigate BreadSliced, Pickup BreadSliced")
    assert format_subgoals(result.plan) == (
        "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread, Navigate CounterTop, Place CounterTop, "
        "Navigate BreadSliced, Pickup BreadSliced"
    )
    assert fired(result)[0] == "slice-before-pieces"


def test_pour_with_nothing_held_fetches_and_fills_a_container(onto: Ontology) -> None:
    result = repair(onto, "Pour HousePlant")
    assert format_subgoals(result.plan) == (
        "Navigate Cup, Pickup Cup, Navigate SinkBasin, Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet, "
        "Pickup Cup, Navigate HousePlant, Pour HousePlant"
    )
    not_navigation = [r for r in fired(result) if r != "navigate-before-interaction"]
    assert not_navigation == ["pour-needs-filled-container"] * 2


def test_pour_prefers_the_container_the_plan_mentions(onto: Ontology) -> None:
    result = repair(onto, "Navigate Bowl, Pour HousePlant")
    assert result.log[0].inserted == (Subgoal(A.PICKUP, "Bowl"),)


def test_pour_with_a_filled_container_is_left_alone(onto: Ontology) -> None:
    belief = BeliefState(held="Mug", filled={"Mug"}, at="HousePlant")
    assert repair(onto, "Pour HousePlant", belief).log == []


def test_pour_of_nothing_into_the_sink_is_removed(onto: Ontology) -> None:
    result = repair(onto, "Pour SinkBasin", BeliefState(held="Cup", at="SinkBasin"))
    assert result.plan == []
    assert fired(result) == ["pour-needs-filled-container"]


def test_navigate_before_every_interaction_with_a_new_object(onto: Ontology) -> None:
    result = repair(onto, "Pickup Apple, Place CounterTop")
    expected = "Navigate Apple, Pickup Apple, Navigate CounterTop, Place CounterTop"
    assert format_subgoals(result.plan) == expected
    assert fired(result) == ["navigate-before-interaction"] * 2


def test_faucet_is_within_reach_at_the_sink(onto: Ontology) -> None:
    text = "Navigate Mug, Pickup Mug, Navigate SinkBasin, Place SinkBasin, ToggleOn Faucet"
    assert repair(onto, text).log == []


def test_dedupe_navigate(onto: Ontology) -> None:
    result = repair(onto, "Navigate Fridge, Navigate Apple, Pickup Apple, Navigate Apple, Navigate Apple")
    assert format_subgoals(result.plan) == "Navigate Apple, Pickup Apple"
    assert fired(result) == ["dedupe-navigate"] * 3


def test_a_second_navigate_to_a_type_the_plan_put_away_is_kept(onto: Ontology) -> None:
    """ALFRED's pick_two_obj: the second CD is another one, not the one just shut in the drawer."""
    text = (
        "Navigate CD, Pickup CD, Navigate Drawer, Open Drawer, Place Drawer, Close Drawer, "
        "Navigate CD, Pickup CD, Navigate Drawer, Open Drawer, Place Drawer, Close Drawer"
    )
    assert repair(onto, text).log == []


def test_repair_leaves_the_input_alone(onto: Ontology) -> None:
    plan = parse_subgoals("Slice Bread", onto)
    belief = BeliefState()
    repair_plan(plan, onto, belief)
    assert plan == [Subgoal(A.SLICE, "Bread")]
    assert belief == BeliefState()


def test_rule_registry_fails_loudly() -> None:
    assert REPAIR_RULES.get(SLICE_NEEDS_KNIFE).check is slice_needs_knife
    with pytest.raises(UnknownName, match="known: close-after-place"):
        REPAIR_RULES.get("teleport")


@pytest.mark.data
def test_expert_alfred_plans_keep_every_interaction(
    onto: Ontology, alfred_valid_seen: list[dict[str, Any]]
) -> None:
    """Repair only adds what our explicit plans need (navigation) to plans the ALFRED expert executed."""
    for traj in alfred_valid_seen:
        plan = subgoals_from_alfred_low_actions(traj["plan"]["low_actions"])
        result = repair_plan(plan, onto)
        navigation_only = {"navigate-before-interaction", "dedupe-navigate"}
        assert {e.rule for e in result.log} <= navigation_only, traj["task_id"]
        assert [g for g in result.plan if g.action is not A.NAVIGATE] == [
            g for g in plan if g.action is not A.NAVIGATE
        ]
