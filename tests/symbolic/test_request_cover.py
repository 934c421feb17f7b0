"""Making a plan cover the commander's counts and conjunctions (``symbolic.request_cover``)."""

from __future__ import annotations

import pytest

from symbolic.ontology import load_ontology
from symbolic.repair import REQUEST_CONJUNCTION, REQUEST_COUNT, RepairEvent, repair_plan
from symbolic.request_cover import cover_request, cycles
from symbolic.request_words import object_words, read_request
from symbolic.subgoals import Subgoal, format_subgoals, parse_subgoals

ONTOLOGY = load_ontology()
CLEAN_MUG = "Navigate Mug, Pickup Mug, Navigate SinkBasin, Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet"


def _plan(text: str) -> list[Subgoal]:
    return parse_subgoals(text, ONTOLOGY) if text else []


def _cover(said: str, plan: str, history: str = "") -> tuple[str, list[RepairEvent]]:
    request = read_request([said], object_words(ONTOLOGY))
    covered, events = cover_request(_plan(plan), request, ONTOLOGY, _plan(history))
    return format_subgoals(covered), events


def test_a_conjoined_object_gets_the_cycle_of_the_one_the_model_planned() -> None:
    covered, events = _cover("clean a mug and a pan", CLEAN_MUG)
    assert covered == CLEAN_MUG + ", " + CLEAN_MUG.replace("Mug", "Pan")
    assert [(e.rule, e.index, e.removed) for e in events] == [(REQUEST_CONJUNCTION, 6, ())]
    assert "Pan" in events[0].reason and "mug and a pan" in events[0].reason
    assert format_subgoals(events[0].inserted) == CLEAN_MUG.replace("Mug", "Pan")


def test_a_conjoined_object_that_is_cut_not_carried_gets_the_cutting_in_the_order_said() -> None:
    knife = "Navigate Knife, Pickup Knife"
    covered, events = _cover("cut a tomato and a lettuce", f"{knife}, Navigate Lettuce, Slice Lettuce")
    assert covered == f"{knife}, Navigate Tomato, Slice Tomato, Navigate Lettuce, Slice Lettuce"
    assert [(e.rule, format_subgoals(e.inserted)) for e in events] == [
        (REQUEST_CONJUNCTION, "Navigate Tomato, Slice Tomato")
    ]


def test_putting_something_on_an_object_is_not_working_on_it() -> None:
    """A plate that only receives the toast is not handled as the plate the commander asked to clean."""
    toast_on_plate = "Navigate BreadSliced, Pickup BreadSliced, Navigate Plate, Place Plate"
    covered, events = _cover("clean a mug and a plate", f"{CLEAN_MUG}, {toast_on_plate}")
    assert events and CLEAN_MUG.replace("Mug", "Plate") in covered


def test_a_count_repeats_the_cycle_and_a_counted_conjoined_object_gets_as_many() -> None:
    plate = CLEAN_MUG.replace("Mug", "Plate")
    covered, events = _cover("clean two plates and two cups", plate)
    cup = plate.replace("Plate", "Cup")
    assert covered == ", ".join([plate, plate, cup, cup])
    assert [e.rule for e in events] == [REQUEST_COUNT, REQUEST_CONJUNCTION]


SLICE_TOMATO = (
    "Navigate Knife, Pickup Knife, Navigate Tomato, Slice Tomato, Place CounterTop, "
    "Pickup TomatoSliced, Navigate Plate, Place Plate"
)
NEXT_SLICE = "Navigate TomatoSliced, Pickup TomatoSliced, Navigate Plate, Place Plate"
APPLE_AWAY = "Navigate Apple, Pickup Apple, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge"
MICROWAVE_ON = "Navigate Microwave, ToggleOn Microwave"


@pytest.mark.parametrize(
    ("said", "plan", "covered"),
    [
        pytest.param(
            "serve 3 slices of tomato on a plate",
            SLICE_TOMATO,
            f"{SLICE_TOMATO}, {NEXT_SLICE}, {NEXT_SLICE}",
            id="a repeated slice cycle fetches the next slice",
        ),
        pytest.param(
            "put two apples in the fridge and turn on the microwave",
            f"{APPLE_AWAY}, {MICROWAVE_ON}",
            f"{APPLE_AWAY}, {APPLE_AWAY}, {MICROWAVE_ON}",
            id="steps after the object is put away stay after the copies",
        ),
    ],
)
def test_a_repeated_cycle_follows_the_one_planned(said: str, plan: str, covered: str) -> None:
    assert _cover(said, plan)[0] == covered


def test_a_count_already_met_or_already_done_in_the_history_changes_nothing() -> None:
    twice = f"{CLEAN_MUG}, {CLEAN_MUG}"
    assert _cover("wash both mugs", twice) == (twice, [])
    assert _cover("wash both mugs", CLEAN_MUG, history=CLEAN_MUG) == (CLEAN_MUG, [])


def test_a_count_with_one_cycle_in_the_history_adds_the_rest_to_the_plan() -> None:
    done = "Navigate Pillow, Pickup Pillow, Navigate ArmChair, Place ArmChair"
    covered, events = _cover("the pillows belong on the armchair, shift both", "", history=done)
    assert covered == done and events[0].index == 0


def test_taking_back_the_same_object_is_one_cycle_and_rinsing_twice_is_two() -> None:
    toast = _plan(
        "Pickup BreadSliced, Navigate Toaster, Place Toaster, ToggleOn Toaster, ToggleOff Toaster, "
        "Navigate BreadSliced, Pickup BreadSliced, Navigate Plate, Place Plate"
    )
    assert len(cycles(toast, "BreadSliced", ONTOLOGY)) == 1
    assert len(cycles(_plan(f"{CLEAN_MUG}, {CLEAN_MUG}"), "Mug", ONTOLOGY)) == 2


def test_a_copy_does_not_close_a_container_it_did_not_open() -> None:
    plan = "Navigate Cabinet, Open Cabinet, Pickup Mug, Close Cabinet, Navigate SinkBasin, Place SinkBasin"
    covered, _ = _cover("put a mug and a cup in the sink", plan)
    assert covered.endswith("Place SinkBasin, Navigate Cup, Pickup Cup, Navigate SinkBasin, Place SinkBasin")


def test_a_type_that_cannot_do_the_cycle_gets_no_copy() -> None:
    coffee = "Navigate Mug, Pickup Mug, Navigate CoffeeMachine, Place CoffeeMachine, ToggleOn CoffeeMachine"
    assert _cover("make coffee with the mug and the kettle", coffee) == (coffee, [])


def test_nothing_changes_for_words_it_does_not_understand_or_objects_the_model_never_planned() -> None:
    assert _cover("sanitize those filthy beakers, there are two of them", CLEAN_MUG) == (CLEAN_MUG, [])
    assert (
        _cover(
            "put all the forks in the drawer", "Navigate Fork, Pickup Fork, Navigate Drawer, Place Drawer"
        )[1]
        == []
    )
    assert _cover("clean two pans and a pot", CLEAN_MUG) == (CLEAN_MUG, [])


def test_the_pass_only_adds_and_repair_keeps_what_it_added() -> None:
    plan = _plan(CLEAN_MUG)
    request = read_request(["clean a mug and a pan"], object_words(ONTOLOGY))
    covered, _ = cover_request(plan, request, ONTOLOGY)
    assert covered[: len(plan)] == plan
    repaired = repair_plan(covered, ONTOLOGY).plan
    assert repaired.count(parse_subgoals("Pickup Pan", ONTOLOGY)[0]) == 1
