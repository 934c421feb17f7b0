"""Which of the language planner's readings a session pursues after a subgoal failed."""

from __future__ import annotations

import pytest

from symbolic.ontology import load_ontology
from symbolic.readings import choose_reading
from symbolic.subgoals import Subgoal, parse_subgoals

ONTOLOGY = load_ontology()


def plan(text: str) -> list[Subgoal]:
    return parse_subgoals(text, ONTOLOGY)


MUG = plan("Navigate Mug, Pickup Mug, Navigate SinkBasin, Place SinkBasin")
BOWL = plan("Navigate Bowl, Pickup Bowl, Navigate SinkBasin, Place SinkBasin")
CUP = plan("Navigate Cup, Pickup Cup, Navigate SinkBasin, Place SinkBasin")
MUG_FAILED = set(plan("Navigate Mug"))


def test_without_a_failure_the_models_first_reading_stands() -> None:
    choice = choose_reading([MUG, BOWL, CUP], failed=set(), seen_types={"Bowl", "SinkBasin"})
    assert choice.index == 0


def test_a_first_reading_that_does_not_repeat_the_failure_stands() -> None:
    choice = choose_reading([CUP, MUG, BOWL], failed=MUG_FAILED, seen_types={"Bowl", "SinkBasin"})
    assert choice.index == 0


def test_a_reading_whose_objects_are_mapped_wins_over_an_earlier_one_that_is_not() -> None:
    choice = choose_reading([MUG, BOWL, CUP], failed=MUG_FAILED, seen_types={"Cup", "SinkBasin"})
    assert choice.index == 2
    assert "reading 3 of 3" in choice.reason and "Navigate Mug" in choice.reason
    assert "every object it names is mapped" in choice.reason


def test_among_readings_the_map_cannot_tell_apart_the_beams_order_decides() -> None:
    choice = choose_reading([MUG, BOWL, CUP], failed=MUG_FAILED, seen_types={"SinkBasin"})
    assert choice.index == 1
    assert "not mapped yet: Bowl" in choice.reason


def test_when_every_reading_repeats_the_failure_the_first_stands() -> None:
    other_sink = plan("Navigate Mug, Pickup Mug, Navigate Sink, Place Sink")
    choice = choose_reading([MUG, other_sink], failed=MUG_FAILED, seen_types={"Sink", "SinkBasin"})
    assert choice.index == 0


def test_no_readings_is_a_caller_error() -> None:
    with pytest.raises(ValueError, match="at least one reading"):
        choose_reading([], failed=MUG_FAILED, seen_types=set())
