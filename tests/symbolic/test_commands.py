"""The TATC commander's instruction form (``symbolic.commands``): subgoals with stand and click hints."""

from __future__ import annotations

import pytest

from symbolic.commands import ClickHint, CommandItem, StandHint, format_command, parse_command
from symbolic.ontology import Ontology
from symbolic.subgoals import Subgoal, SubgoalAction, SubgoalSyntaxError

A = SubgoalAction
FULL = [
    CommandItem(Subgoal(A.NAVIGATE, "Mug"), stand=StandHint(2.0, 5.25, 270.0, 30.0)),
    CommandItem(Subgoal(A.PICKUP, "Mug"), click=ClickHint(0.7, 0.37)),
]


@pytest.mark.parametrize(
    ("items", "text"),
    [
        (FULL, "Navigate Mug @ (2.000, 5.250, 270, 30), Pickup Mug @ (0.700, 0.370)"),
        (
            [
                CommandItem(Subgoal(A.NAVIGATE, "Cabinet"), stand=StandHint(-1.625, 0.875, 90.0)),
                CommandItem(Subgoal(A.OPEN, "Cabinet")),
            ],
            "Navigate Cabinet @ (-1.625, 0.875, 90), Open Cabinet",
        ),
        (
            [CommandItem(Subgoal(A.TOGGLE_ON, "Faucet")), CommandItem(Subgoal(A.TOGGLE_OFF, "Faucet"))],
            "ToggleOn Faucet, ToggleOff Faucet",
        ),
    ],
    ids=["stand and click (full)", "stand only (no segmentation)", "plain (no goal location)"],
)
def test_the_text_form_round_trips(onto: Ontology, items: list[CommandItem], text: str) -> None:
    assert format_command(items) == text
    assert parse_command(text, onto) == items


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("pickup mug.", [CommandItem(Subgoal(A.PICKUP, "Mug"))]),
        ("Pickup the mug", [CommandItem(Subgoal(A.PICKUP, "Mug"))]),
        (
            "  Navigate Mug @( 2 , 5 , 270 ) ;Pickup Mug",
            [
                CommandItem(Subgoal(A.NAVIGATE, "Mug"), stand=StandHint(2, 5, 270)),
                CommandItem(Subgoal(A.PICKUP, "Mug")),
            ],
        ),
        ("Slice Bread @ (+.5, 1.)", [CommandItem(Subgoal(A.SLICE, "Bread"), click=ClickHint(0.5, 1.0))]),
    ],
    ids=["lower case and a full stop", "an article", "spacing and semicolons", "decimal forms"],
)
def test_loose_spelling_is_read(onto: Ontology, text: str, expected: list[CommandItem]) -> None:
    assert parse_command(text, onto) == expected


@pytest.mark.parametrize(
    "text",
    [
        "",
        "   ",
        "Please pick up the mug and put it in the sink.",
        "Hello! Today's task: Water the plant.",
        "Pickup Mug and then Open Fridge",
        "That's everything: the task is done. Thank you!",
        "Fly Mug",
    ],
)
def test_plain_language_is_not_an_instruction(onto: Ontology, text: str) -> None:
    assert parse_command(text, onto) is None


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("Navigate Mug @ (2.0, 5.0)", r"item 0: a Navigate hint is \(x, z, yaw\)"),
        ("Navigate Mug @ (2.0, 5.0, 270, 30, 1)", "a Navigate hint"),
        ("Navigate Mug @ (2.0, 5.0, 270, 75)", "horizon 75 lies outside"),
        ("Pickup Mug @ (0.5)", r"a click hint is \(x, y\)"),
        ("Navigate Mug, Pickup Mug @ (1.5, 0.2)", r"item 1: a click hint is \(x, y\) fractions in \[0, 1\]"),
        ("Pickup Mug @ (0.5, abc)", "decimal numbers only, got 'abc'"),
        ("Pickup Mug @ (nan, 0.5)", "decimal numbers only, got 'nan'"),
        ("Pickup Mug @ ()", "decimal numbers only"),
    ],
)
def test_a_malformed_hint_is_a_syntax_error_naming_the_item(onto: Ontology, text: str, message: str) -> None:
    with pytest.raises(SubgoalSyntaxError, match=message):
        parse_command(text, onto)


def test_object_synonyms_resolve_to_types(onto: Ontology) -> None:
    items = parse_command("Navigate Butter Knife, Pickup Butter Knife", onto)
    assert items is not None
    assert [str(item.subgoal) for item in items] == ["Navigate ButterKnife", "Pickup ButterKnife"]
