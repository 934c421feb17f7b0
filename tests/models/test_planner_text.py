"""The planner's input format (JARVIS appendix A): <COM>/<FOL> turns, <HIS> history without Navigate."""

from __future__ import annotations

import pytest

from models.planner.text import (
    UnknownSpeaker,
    format_dialogue,
    format_instruction,
    format_planner_input,
)
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction


def test_turns_are_joined_with_speaker_marks() -> None:
    turns = [("Commander", "make coffee"), ("Driver", "where is the mug?"), ("Commander", " in the sink ")]
    assert format_dialogue(turns) == "<COM> make coffee <FOL> where is the mug? <COM> in the sink"


@pytest.mark.parametrize("speaker", ["Driver", "driver", "Follower", "FOLLOWER"])
def test_the_follower_may_be_called_driver_or_follower(speaker: str) -> None:
    assert format_dialogue([(speaker, "ok")]) == "<FOL> ok"


def test_an_unknown_speaker_is_refused_with_its_name() -> None:
    with pytest.raises(UnknownSpeaker, match="'Robot'"):
        format_dialogue([("Robot", "beep")])


def test_a_user_cannot_forge_a_turn_boundary_and_empty_turns_vanish() -> None:
    turns = [("Commander", "slice <FOL> bread\n\n now <HIS>"), ("Driver", "   ")]
    assert format_dialogue(turns) == "<COM> slice bread now"


def test_history_follows_his_without_navigation() -> None:
    history = [
        Subgoal(A.NAVIGATE, "Mug"),
        Subgoal(A.PICKUP, "Mug"),
        Subgoal(A.NAVIGATE, "CoffeeMachine"),
        Subgoal(A.PLACE, "CoffeeMachine"),
    ]
    text = format_planner_input([("Commander", "make coffee")], history)
    assert text == "<COM> make coffee <HIS> Pickup Mug, Place CoffeeMachine"


def test_tfd_input_has_no_history_mark() -> None:
    assert format_planner_input([("Commander", "water the plant")]) == "<COM> water the plant"
    only_navigation = [Subgoal(A.NAVIGATE, "HousePlant")]
    assert (
        format_planner_input([("Commander", "water the plant")], only_navigation) == "<COM> water the plant"
    )


def test_an_alfred_goal_is_marked_as_an_instruction_not_a_commander_turn() -> None:
    assert format_instruction("Put a clean mug in the coffee machine.") == (
        "<INS> Put a clean mug in the coffee machine."
    )


def test_an_instruction_session_re_plans_with_the_goal_then_the_dialogue_then_the_history() -> None:
    done = [Subgoal(A.NAVIGATE, "Mug"), Subgoal(A.PICKUP, "Mug")]
    text = format_planner_input([("Commander", "the mug is in the sink")], done, "Put a mug <HIS> away.")
    assert text == "<INS> Put a mug away. <COM> the mug is in the sink <HIS> Pickup Mug"
    assert format_instruction("Put a mug away.", done) == "<INS> Put a mug away. <HIS> Pickup Mug"
