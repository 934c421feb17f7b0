"""Which of the language planner's readings a session pursues after a subgoal failed."""

from __future__ import annotations

from collections import Counter

import pytest

from symbolic.ontology import load_ontology
from symbolic.readings import TRIES_BEFORE_UNMAPPED, choose_reading
from symbolic.subgoals import Subgoal, parse_subgoals

ONTOLOGY = load_ontology()


def plan(text: str) -> list[Subgoal]:
    return parse_subgoals(text, ONTOLOGY)


MUG = plan("Navigate Mug, Pickup Mug, Navigate SinkBasin, Place SinkBasin")
BOWL = plan("Navigate Bowl, Pickup Bowl, Navigate SinkBasin, Place SinkBasin")
CUP = plan("Navigate Cup, Pickup Cup, Navigate SinkBasin, Place SinkBasin")
MUG_ONCE = Counter(plan("Navigate Mug"))
MUG_TWICE = Counter(plan("Navigate Mug") * TRIES_BEFORE_UNMAPPED)


def test_without_a_failure_the_models_first_reading_stands() -> None:
    choice = choose_reading([MUG, BOWL, CUP], given_up=Counter(), seen_types={"Bowl", "SinkBasin"})
    assert choice.index == 0


def test_a_first_reading_that_does_not_repeat_the_failure_stands() -> None:
    choice = choose_reading([CUP, MUG, BOWL], given_up=MUG_ONCE, seen_types={"Bowl", "SinkBasin"})
    assert choice.index == 0


def test_a_reading_whose_added_objects_are_mapped_is_taken_after_one_failure() -> None:
    choice = choose_reading([MUG, BOWL, CUP], given_up=MUG_ONCE, seen_types={"Cup", "SinkBasin"})
    assert choice.index == 2
    assert "reading 3 of 3" in choice.reason and "Navigate Mug" in choice.reason
    assert "every object it adds is mapped" in choice.reason


def test_after_one_failure_unmapped_readings_wait_and_the_first_is_tried_again() -> None:
    """One give-up is weak evidence the object is absent: a search can miss it."""
    choice = choose_reading([MUG, BOWL, CUP], given_up=MUG_ONCE, seen_types={"SinkBasin"})
    assert choice.index == 0
    assert "once more" in choice.reason and "Bowl, Cup" in choice.reason


def test_given_up_twice_the_beams_order_decides_among_unmapped_readings() -> None:
    choice = choose_reading([MUG, BOWL, CUP], given_up=MUG_TWICE, seen_types={"SinkBasin"})
    assert choice.index == 1
    assert "not mapped yet: Bowl" in choice.reason


def test_given_up_twice_a_mapped_reading_still_beats_an_earlier_unmapped_one() -> None:
    choice = choose_reading([MUG, BOWL, CUP], given_up=MUG_TWICE, seen_types={"Cup", "SinkBasin"})
    assert choice.index == 2


def test_when_every_reading_repeats_the_failure_the_first_stands() -> None:
    other_sink = plan("Navigate Mug, Pickup Mug, Navigate Sink, Place Sink")
    choice = choose_reading([MUG, other_sink], given_up=MUG_TWICE, seen_types={"Sink", "SinkBasin"})
    assert choice.index == 0
    assert "no other reading avoids" in choice.reason


def test_no_readings_is_a_caller_error() -> None:
    with pytest.raises(ValueError, match="at least one reading"):
        choose_reading([], given_up=MUG_ONCE, seen_types=set())
