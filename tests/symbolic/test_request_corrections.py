"""The correction pass (symbolic/request_corrections.py, issue 62): a plan that kept the word the commander
took back follows the correction; a plan that needs nothing, or a turn that corrects nothing, stays."""

from __future__ import annotations

import pytest

from symbolic.ontology import load_ontology
from symbolic.repair import REQUEST_CORRECTION
from symbolic.request_corrections import follow_corrections, read_corrections
from symbolic.request_words import object_words, read_request
from symbolic.subgoals import format_subgoals, parse_subgoals

ONTOLOGY = load_ontology()
WORDS = object_words(ONTOLOGY)
RINSE = "Navigate {0}, Pickup {0}, Navigate SinkBasin, Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet"


def corrected(said: list[str], plan: str) -> tuple[str, list[str]]:
    """The plan after the pass, and the reasons it logged."""
    request = read_request(said, WORDS)
    result, log = follow_corrections(
        parse_subgoals(plan, ONTOLOGY), read_corrections(said, WORDS), request.mentions, ONTOLOGY
    )
    assert all(event.rule == REQUEST_CORRECTION for event in log)
    return format_subgoals(result), [event.reason for event in log]


@pytest.mark.parametrize(
    ("said", "plan", "expected"),
    [
        (
            ["take the pillow over to the desk", "sorry, not the desk, the sofa"],
            "Navigate Pillow, Pickup Pillow, Navigate Desk, Place Desk",
            "Navigate Pillow, Pickup Pillow, Navigate Sofa, Place Sofa",
        ),
        (
            ["put the book on the sofa, not the bed"],
            "Navigate Book, Pickup Book, Navigate Bed, Place Bed",
            "Navigate Book, Pickup Book, Navigate Sofa, Place Sofa",
        ),
        (
            ["could you rinse the mug", "oh wait, I meant the cup"],
            RINSE.format("Mug"),
            RINSE.format("Cup"),
        ),
        (
            ["cut the tomato please", "use the potato instead of the tomato"],
            "Navigate Knife, Pickup Knife, Navigate Tomato, Slice Tomato, Place CounterTop, "
            "Navigate TomatoSliced, Pickup TomatoSliced, Navigate Plate, Place Plate",
            "Navigate Knife, Pickup Knife, Navigate Potato, Slice Potato, Place CounterTop, "
            "Navigate PotatoSliced, Pickup PotatoSliced, Navigate Plate, Place Plate",
        ),
        (
            ["chill the apple in the fridge", "there is no apple, use the egg"],
            "Navigate Apple, Pickup Apple, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge",
            "Navigate Egg, Pickup Egg, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge",
        ),
    ],
)
def test_a_plan_that_kept_the_word_taken_back_follows_the_correction(
    said: list[str], plan: str, expected: str
) -> None:
    result, reasons = corrected(said, plan)
    assert result == expected
    assert len(reasons) == 1 and "corrected" in reasons[0]


@pytest.mark.parametrize(
    ("said", "plan"),
    [
        # the model already followed it
        (
            ["take the pillow over to the desk", "sorry, not the desk, the sofa"],
            "Navigate Pillow, Pickup Pillow, Navigate Sofa, Place Sofa",
        ),
        # no correction: a second request, or a location
        (
            ["put the apple in the fridge", "actually, also put the egg there"],
            "Navigate Apple, Pickup Apple, Navigate Fridge, Open Fridge, Place Fridge, Close Fridge",
        ),
        (
            ["make a cup of coffee", "the mug is next to the sink"],
            "Navigate Mug, Pickup Mug, Navigate CoffeeMachine, Place CoffeeMachine, ToggleOn CoffeeMachine, "
            "ToggleOff CoffeeMachine",
        ),
        # the meant object cannot do what the taken-back one did: a sofa is not carried to the sink
        (
            ["rinse the mug", "wrong one, the sofa"],
            RINSE.format("Mug"),
        ),
        # the meant receptacle does not take the thing: a pan does not go in a mug
        (
            ["put the pan on the counter", "no, not the counter, the mug"],
            "Navigate Pan, Pickup Pan, Navigate CounterTop, Place CounterTop",
        ),
    ],
)
def test_a_plan_that_needs_no_correction_stays_as_planned(said: list[str], plan: str) -> None:
    result, reasons = corrected(said, plan)
    assert result == plan and reasons == []


def test_a_correction_in_the_service_log_names_both_types_and_the_words() -> None:
    said = ["take the pillow over to the desk", "sorry, not the desk, the sofa"]
    request = read_request(said, WORDS)
    plan = parse_subgoals("Navigate Pillow, Pickup Pillow, Navigate Desk, Place Desk", ONTOLOGY)
    _, log = follow_corrections(plan, read_corrections(said, WORDS), request.mentions, ONTOLOGY)
    (event,) = log
    assert event.index == 2
    assert format_subgoals(list(event.removed)) == "Navigate Desk, Place Desk"
    assert format_subgoals(list(event.inserted)) == "Navigate Sofa, Place Sofa"
    assert "Desk" in event.reason and "Sofa" in event.reason and "not the desk" in event.reason
