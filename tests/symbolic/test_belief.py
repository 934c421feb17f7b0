"""Belief state: each subgoal's assumed effect, including AI2-THOR's contextual interactions."""

from __future__ import annotations

from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.subgoals import Subgoal, SubgoalAction, parse_subgoals

A = SubgoalAction


def run(onto: Ontology, text: str, start: BeliefState | None = None) -> BeliefState:
    belief = start if start is not None else BeliefState.initial(onto)
    for subgoal in parse_subgoals(text, onto):
        belief = belief.apply(subgoal, onto)
    return belief


def test_initial_belief_knows_boxes_stand_open(onto: Ontology) -> None:
    belief = BeliefState.initial(onto)
    assert belief.open == {"Box"}
    assert belief.held is None and belief.at is None


def test_apply_returns_a_new_state(onto: Ontology) -> None:
    before = BeliefState()
    after = before.apply(Subgoal(A.PICKUP, "Apple"), onto)
    assert after.held == "Apple"
    assert before.held is None
    copied = after.copy()
    copied.open.add("Fridge")
    assert "Fridge" not in after.open


def test_pickup_and_place_move_the_object(onto: Ontology) -> None:
    belief = run(onto, "Navigate Knife, Pickup Knife", BeliefState(inside={"Knife": "Drawer"}))
    assert belief.held == "Knife"
    assert "Knife" not in belief.inside
    assert belief.at == "Drawer"  # the agent stands where the knife was
    belief = run(onto, "Navigate CounterTop, Place CounterTop", belief)
    assert belief.held is None
    assert belief.inside["Knife"] == "CounterTop"
    assert belief.at == "CounterTop"


def test_place_with_empty_hands_changes_nothing(onto: Ontology) -> None:
    assert run(onto, "Place CounterTop") == BeliefState.initial(onto)


def test_open_close_toggle_slice(onto: Ontology) -> None:
    belief = run(onto, "Open Fridge, ToggleOn Television, Slice Bread")
    assert "Fridge" in belief.open and "Television" in belief.toggled_on and "Bread" in belief.sliced
    assert belief.is_available("BreadSliced", onto)
    assert not belief.is_available("TomatoSliced", onto)
    assert belief.is_available("Tomato", onto)
    belief = run(onto, "Close Fridge, ToggleOff Television", belief)
    assert "Fridge" not in belief.open and "Television" not in belief.toggled_on


def test_microwave_cooks_what_is_inside_when_switched_on(onto: Ontology) -> None:
    belief = run(onto, "Pickup Potato, Open Microwave, Place Microwave, Close Microwave")
    assert "Potato" not in belief.cooked
    belief = run(onto, "ToggleOn Microwave", belief)
    assert "Potato" in belief.cooked


def test_placing_into_a_running_toaster_cooks(onto: Ontology) -> None:
    belief = run(onto, "ToggleOn Toaster, Slice Bread, Pickup BreadSliced, Place Toaster")
    assert "BreadSliced" in belief.cooked


def test_stove_knob_lights_the_burner_and_cooks_the_pan_contents(onto: Ontology) -> None:
    start = BeliefState(inside={"Pan": "StoveBurner"})
    belief = run(onto, "Pickup PotatoSliced, Place Pan", start)
    assert "PotatoSliced" not in belief.cooked
    belief = run(onto, "ToggleOn StoveKnob", belief)
    assert "StoveBurner" in belief.toggled_on
    assert "PotatoSliced" in belief.cooked
    assert "Pan" not in belief.cooked  # a pan is not food
    belief = run(onto, "ToggleOff StoveKnob", belief)
    assert "StoveBurner" not in belief.toggled_on


def test_pan_onto_a_lit_burner_cooks_its_contents(onto: Ontology) -> None:
    start = BeliefState(toggled_on={"StoveBurner"}, inside={"EggCracked": "Pan"})
    belief = run(onto, "Pickup Pan, Place StoveBurner", start)
    assert "EggCracked" in belief.cooked


def test_faucet_cleans_and_fills_what_is_in_the_sink(onto: Ontology) -> None:
    start = BeliefState(dirty={"Mug", "Plate"})
    belief = run(onto, "Pickup Mug, Place SinkBasin, ToggleOn Faucet", start)
    assert "Mug" not in belief.dirty and "Mug" in belief.cleaned and "Mug" in belief.filled
    assert "Plate" in belief.dirty
    belief = run(onto, "ToggleOff Faucet, Pickup Mug, Pour HousePlant", belief)
    assert "Mug" not in belief.filled
    assert "HousePlant" in belief.filled


def test_placing_under_a_running_faucet_washes(onto: Ontology) -> None:
    belief = run(onto, "ToggleOn Faucet, Pickup Plate, Place SinkBasin", BeliefState(dirty={"Plate"}))
    assert "Plate" not in belief.dirty and "Plate" in belief.cleaned


def test_coffee_machine_fills_a_mug(onto: Ontology) -> None:
    belief = run(onto, "Pickup Mug, Place CoffeeMachine, ToggleOn CoffeeMachine")
    assert "Mug" in belief.filled


def test_navigating_to_a_type_the_plan_put_away_means_another_one(onto: Ontology) -> None:
    belief = run(onto, "Pickup CD, Place Drawer")
    assert belief.inside["CD"] == "Drawer" and "CD" in belief.placed
    belief = run(onto, "Navigate CD", belief)
    assert "CD" not in belief.inside and "CD" not in belief.placed
