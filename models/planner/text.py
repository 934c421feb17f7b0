"""The planner's input text: dialogue turns joined with <COM>/<FOL>, history subgoals after <HIS>.

JARVIS appendix A ("Language Planning Module"): special tokens <COM> and <FOL> concatenate the
commander's and the follower's utterances, and <HIS> joins the history subgoals to the dialogue. The seed
builds history subgoals from the history actions "by excluding all the navigation", so Navigate steps are
left out of the history here too: they say where the agent walked, not what is done. The output is the
future plan in DESIGN.md §5's text form (``symbolic.subgoals.format_subgoals``).

An ALFRED goal is not a dialogue turn, and its plans follow other habits than a TEACh commander's (ALFRED's
expert puts a knife down after slicing and a container before filling it; a TEACh follower fetches the knife
and slices). It is marked <INS> so one model can learn both without one style pulling the other: a lone
commander turn "make a cup of coffee" is a TEACh request, and "Put a heated mug in the coffee machine"
after <INS> is an ALFRED task.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from symbolic.subgoals import Subgoal, SubgoalAction, format_subgoals

COMMANDER_MARK = "<COM>"
FOLLOWER_MARK = "<FOL>"
HISTORY_MARK = "<HIS>"
INSTRUCTION_MARK = "<INS>"
PLANNER_MARKS: tuple[str, ...] = (COMMANDER_MARK, FOLLOWER_MARK, HISTORY_MARK, INSTRUCTION_MARK)
"""Added to every planner tokenizer as whole special tokens, in this order (a mark added later comes
last, so a checkpoint trained before it keeps its ids)."""

_MARK_FOR_SPEAKER: dict[str, str] = {
    "commander": COMMANDER_MARK,
    "driver": FOLLOWER_MARK,
    "follower": FOLLOWER_MARK,
}
"""TEACh names the follower "Driver"; TATC and the seed say "Follower"."""

_SPACES = re.compile(r"\s+")


class UnknownSpeaker(ValueError):
    """A dialogue turn whose speaker is neither the commander nor the follower."""


def speaker_mark(speaker: str) -> str:
    """<COM> for the commander, <FOL> for the driver/follower (case-insensitive)."""
    mark = _MARK_FOR_SPEAKER.get(speaker.strip().lower())
    if mark is None:
        raise UnknownSpeaker(f"speaker {speaker!r} is not one of Commander, Driver, Follower")
    return mark


def clean_utterance(text: str) -> str:
    """One line of text without the marks themselves, so a user cannot forge a turn boundary."""
    for mark in PLANNER_MARKS:
        text = text.replace(mark, " ")
    return _SPACES.sub(" ", text).strip()


def format_dialogue(turns: Sequence[tuple[str, str]]) -> str:
    """``[("Commander", "make coffee"), ("Driver", "where is the mug?")]`` ->
    ``"<COM> make coffee <FOL> where is the mug?"``; empty utterances are skipped."""
    parts = []
    for speaker, text in turns:
        mark = speaker_mark(speaker)
        cleaned = clean_utterance(text)
        if cleaned:
            parts.append(f"{mark} {cleaned}")
    return " ".join(parts)


def format_history(history: Sequence[Subgoal]) -> str:
    """History subgoals without Navigate (the seed's appendix A), in §5's text form."""
    return format_subgoals([subgoal for subgoal in history if subgoal.action is not SubgoalAction.NAVIGATE])


def format_planner_input(
    turns: Sequence[tuple[str, str]], history: Sequence[Subgoal] = (), instruction: str | None = None
) -> str:
    """The seed's Eq. (1) input ``(D, G_{0:t-1})``: the ALFRED goal after <INS> when there is one, the
    dialogue, then <HIS> and the history when there is one (Eq. (2), TfD, has no history and no <HIS>)."""
    goal = clean_utterance(instruction) if instruction is not None else ""
    parts = [f"{INSTRUCTION_MARK} {goal}" if goal else "", format_dialogue(turns)]
    done = format_history(history)
    if done:
        parts += [HISTORY_MARK, done]
    return " ".join(part for part in parts if part)


def format_instruction(instruction: str, history: Sequence[Subgoal] = ()) -> str:
    """ALFRED's single instruction after <INS>, and the subgoals done so far after <HIS>."""
    return format_planner_input([], history, instruction)
