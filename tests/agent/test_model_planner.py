"""The model planner in a session: generation from the dialogue, validation notes and repair in the log."""

from __future__ import annotations

import pytest

from agent.model_planner import ModelPlanner, load_generator, validation_events
from agent.planning import DialogueTurn, PlannerConfig, PlanningContext
from models.planner.predict import PlanPrediction, validate_generated_plan
from symbolic.ontology import load_ontology
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


@pytest.fixture(scope="module")
def planner() -> ModelPlanner:
    return ModelPlanner(load_ontology(), PlannerConfig())


def test_the_model_is_loaded_once_per_process() -> None:
    assert load_generator() is load_generator()
    first = ModelPlanner(load_ontology(), PlannerConfig())
    second = ModelPlanner(load_ontology(), PlannerConfig())
    assert first.generator is second.generator


def test_an_instruction_is_planned_by_the_model_and_repaired(planner: ModelPlanner) -> None:
    outcome = planner.plan(PlanningContext(instruction="Put a cell phone on the bed."))
    assert outcome.source == "model"
    assert outcome.plan[-1] == Subgoal(A.PLACE, "Bed")
    assert Subgoal(A.PICKUP, "CellPhone") in outcome.plan
    assert planner.replans_on_dialogue


def test_the_outcome_carries_the_beams_other_readings_of_the_request(planner: ModelPlanner) -> None:
    """Issue #65: the beam's other plans with the same actions, through the same passes, ready for a
    subgoal that fails; "the pan" is a Pan first and a Pot next."""
    dialogue = (DialogueTurn("Commander", "put the pan in the sink"),)
    outcome = planner.plan(PlanningContext(dialogue=dialogue, readings_wanted=True))
    assert Subgoal(A.PICKUP, "Pan") in outcome.plan
    assert any(Subgoal(A.PICKUP, "Pot") in reading for reading in outcome.readings)
    assert tuple(outcome.plan) not in outcome.readings
    assert len(set(outcome.readings)) == len(outcome.readings)
    for reading in outcome.readings:
        assert [s.action for s in reading] == [s.action for s in outcome.plan]

    plain = planner.plan(PlanningContext(dialogue=dialogue))
    assert plain.plan == outcome.plan and plain.readings == ()  # only a re-plan after a failure asks


def test_a_coffee_dialogue_becomes_a_coffee_plan(planner: ModelPlanner) -> None:
    context = PlanningContext(
        dialogue=(
            DialogueTurn("Driver", "hi, what should I do?"),
            DialogueTurn("Commander", "make a cup of coffee"),
        )
    )
    outcome = planner.plan(context)
    assert outcome.plan[:2] == (Subgoal(A.NAVIGATE, "Mug"), Subgoal(A.PICKUP, "Mug"))
    place = outcome.plan.index(Subgoal(A.PLACE, "CoffeeMachine"))
    assert Subgoal(A.TOGGLE_ON, "CoffeeMachine") in outcome.plan[place:]


@pytest.mark.parametrize("request_text", ["make a cup of coffee", "Make coffee."])
def test_a_bare_request_alone_makes_coffee(planner: ModelPlanner, request_text: str) -> None:
    """What a curl user types first, with nothing before it; the planner once read it as ALFRED's goal
    and chilled the mug in the fridge, never switching the machine on."""
    outcome = planner.plan(PlanningContext(dialogue=(DialogueTurn("Commander", request_text),)))
    assert Subgoal(A.PICKUP, "Mug") in outcome.plan
    assert Subgoal(A.PLACE, "Fridge") not in outcome.plan
    place = outcome.plan.index(Subgoal(A.PLACE, "CoffeeMachine"))
    assert Subgoal(A.TOGGLE_ON, "CoffeeMachine") in outcome.plan[place:]


def test_a_dialogue_with_history_plans_only_the_future(planner: ModelPlanner) -> None:
    context = PlanningContext(
        dialogue=(
            DialogueTurn("Commander", "hi! today make a cup of coffee"),
            DialogueTurn("Driver", "where is the mug?"),
            DialogueTurn("Commander", "the mug is in the sink"),
        ),
        history_subgoals=(Subgoal(A.NAVIGATE, "Mug"), Subgoal(A.PICKUP, "Mug")),
    )
    outcome = planner.plan(context)
    assert Subgoal(A.PLACE, "CoffeeMachine") in outcome.plan
    assert outcome.plan[0] not in (Subgoal(A.NAVIGATE, "Mug"), Subgoal(A.PICKUP, "Mug"))  # already in hand


def test_nothing_said_means_no_plan(planner: ModelPlanner) -> None:
    outcome = planner.plan(PlanningContext(dialogue=(DialogueTurn("Driver", "  "),)))
    assert (outcome.plan, outcome.repair_log, outcome.source) == ((), (), "model")


def test_plans_longer_than_the_limit_are_cut_and_the_cut_is_logged() -> None:
    short = ModelPlanner(load_ontology(), PlannerConfig(max_subgoals=2))
    outcome = short.plan(PlanningContext(instruction="Put a cell phone on the bed."))
    assert len(outcome.plan) == 2
    assert "plan-truncated" in {event.rule for event in outcome.repair_log}


def test_validation_notes_become_repair_log_entries() -> None:
    subgoals, notes = validate_generated_plan("navigate coffeemachin, frobnicate mug", load_ontology())
    events = validation_events(PlanPrediction("...", tuple(subgoals), tuple(notes)))
    assert [(e.rule, e.index) for e in events] == [("model-output-mapped", 0), ("model-output-dropped", 1)]
    assert events[0].inserted == (Subgoal(A.NAVIGATE, "CoffeeMachine"),)
    assert "'frobnicate mug'" in events[1].reason
