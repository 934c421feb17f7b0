"""One registry for every named family: lookup, order, and the one unknown-name error."""

from __future__ import annotations

import pytest

from symbolic.registry import Registry, UnknownName
from symbolic.repair import (
    ASSUME_FILLED,
    BEAM_READING,
    KIN_STAND_IN,
    MAKE_ROOM,
    PLAN_CHECKS,
    REPAIR_RULES,
    REQUEST_CONJUNCTION,
    REQUEST_CORRECTION,
    REQUEST_COUNT,
    RETRY_GIVEN_UP,
    STAND_IN,
    SUBGOAL_FAILED,
)

COLOURS: Registry[int] = Registry("colour", {"red": 1, "green": 2, "blue": 3})


def test_entries_are_found_by_name_and_listed_in_the_order_given() -> None:
    assert COLOURS.get("green") == 2
    assert COLOURS.names() == ("red", "green", "blue")
    assert COLOURS.items() == (("red", 1), ("green", 2), ("blue", 3))
    assert "blue" in COLOURS and "grey" not in COLOURS and len(COLOURS) == 3


def test_an_unknown_name_lists_the_known_ones_and_the_closest() -> None:
    with pytest.raises(UnknownName) as error:
        COLOURS.get("gren")
    assert str(error.value) == "unknown colour 'gren'; known: red, green, blue; closest: green"
    assert (error.value.kind, error.value.name, error.value.known) == ("colour", "gren", COLOURS.names())
    assert isinstance(error.value, LookupError)


def test_a_name_far_from_every_known_one_gets_no_suggestion() -> None:
    with pytest.raises(UnknownName, match=r"^unknown colour 'violet'; known: red, green, blue$") as error:
        COLOURS.get("violet")
    assert error.value.closest is None


def test_a_registry_must_carry_exactly_the_names_its_typed_list_gives() -> None:
    Registry("colour", {"red": 1, "green": 2}, names=("green", "red"))
    with pytest.raises(ValueError, match=r"\['green', 'red'\].*\['blue', 'green', 'red'\]"):
        Registry("colour", {"red": 1, "green": 2}, names=("red", "green", "blue"))


def test_every_rule_the_repair_log_can_name_is_registered_with_a_description() -> None:
    applied_elsewhere = {
        ASSUME_FILLED,
        REQUEST_COUNT,
        REQUEST_CONJUNCTION,
        REQUEST_CORRECTION,
        STAND_IN,
        KIN_STAND_IN,
        MAKE_ROOM,
        SUBGOAL_FAILED,
        RETRY_GIVEN_UP,
        BEAM_READING,
    }
    for name in applied_elsewhere:
        rule = REPAIR_RULES.get(name)
        assert rule.check is None and rule.applied_by != "repair_plan", name
    for name, rule in REPAIR_RULES.items():
        assert rule.description, name
    checked = [name for name, _ in PLAN_CHECKS]
    assert checked == [name for name in REPAIR_RULES if name not in applied_elsewhere]
    assert checked[:2] == ["close-after-place", "close-after-pickup"] and checked[-1] == "dedupe-navigate"
