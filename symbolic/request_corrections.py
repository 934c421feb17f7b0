"""Follow the commander's corrections: "sorry, not the desk, the sofa", "I meant the cup", "a bowl instead".

People correct themselves mid-dialogue, and the language planner often keeps the first word (issue 62: "the
commander's corrections are ignored"). This pass reads each commander turn for a correction and, when the
plan still handles the object the commander took back and not the one meant, gives the meant type the
taken-back type's steps. What a turn must say to count as a correction:

- an object said to be wrong: "not the desk", "instead of the mug", "rather than the fridge"; the meant one
  is another object named in that turn ("not the desk, the sofa"; "the sofa, not the desk");
- or a word that only a correction uses ("instead", "meant", "I mean", "wrong", "mistake", "oops",
  "scratch that", "rather", a turn opening with "no,") with the meant object named; the one taken back is
  then the object of the same kind (carried, or a place to put things) named in an earlier turn that the
  plan handles; the latest such one.

It changes nothing unless the plan names the taken-back type and not the meant one (a plan that already
follows the correction, or never had the wrong object, stays as it is), nothing in the history (what was
done is done), and nothing when the meant type cannot do a step the other did (a correction to a sofa does
not make the sofa carried). Pieces follow their whole: "not the tomato, the potato" turns TomatoSliced into
PotatoSliced. Each change is a ``RepairEvent`` under ``request-correction``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from symbolic.ontology import Ontology
from symbolic.repair import REQUEST_CORRECTION, RepairEvent
from symbolic.request_cover import renamed
from symbolic.request_words import DETERMINERS, Mention, ObjectWords, mentions_in, tokens, word_set
from symbolic.subgoals import Subgoal

CORRECTING_WORDS = word_set("instead meant wrong mistake oops rather correction")
"""Words that make a turn a correction by themselves (with the meant object named in it)."""
CORRECTING_PAIRS = frozenset({("i", "mean"), ("scratch", "that"), ("my", "bad")})
NEGATIONS = (("not",), ("instead", "of"), ("rather", "than"), ("no",))
"""What, said right before an object (determiners between allowed), takes it back: "not the desk"."""
ADDING_WORDS = word_set("also too another more additionally plus")
"""A turn that adds to the request ("actually, also put the apple away") corrects nothing."""


@dataclass(frozen=True)
class Correction:
    """One commander turn taking an object back: ``wrong`` (None when the turn did not name it) for
    ``meant``."""

    meant: Mention
    wrong: Mention | None
    said: str


def read_corrections(texts: Sequence[str], words: ObjectWords) -> list[Correction]:
    """The corrections in the commander's turns (in order), by the rules in the module docstring."""
    corrections = []
    for turn, text in enumerate(texts):
        turn_words = tokens(text)
        if ADDING_WORDS & set(turn_words):
            continue
        found = mentions_in(turn, turn_words, words)
        negated = [m for m in found if _taken_back(turn_words, m.start)]
        kept = [m for m in found if m not in negated]
        if not kept:
            continue
        if negated:
            wrong = negated[0]
            carried = words.ontology.get(wrong.object_type).pickupable
            alike = [m for m in kept if words.ontology.get(m.object_type).pickupable == carried] or kept
            meant = min(alike, key=lambda m: abs(m.start - wrong.start))
            corrections.append(Correction(meant, wrong, text))
        elif _correcting(turn_words):
            corrections.append(Correction(kept[-1], None, text))
    return corrections


def _taken_back(words: Sequence[str], start: int) -> bool:
    i = start
    while True:
        if any(tuple(words[max(i - len(n), 0) : i]) == n for n in NEGATIONS):
            return True
        if i == 0 or words[i - 1] not in DETERMINERS:
            return False
        i -= 1


def _correcting(words: Sequence[str]) -> bool:
    if CORRECTING_WORDS & set(words):
        return True
    if words[:2] == ["no", ","]:
        return True
    return any(pair in CORRECTING_PAIRS for pair in zip(words, words[1:], strict=False))


def follow_corrections(
    plan: Sequence[Subgoal],
    corrections: Sequence[Correction],
    earlier: Sequence[Mention],
    ontology: Ontology,
) -> tuple[list[Subgoal], list[RepairEvent]]:
    """``plan`` with each correction followed where it still needs to be; ``earlier`` are the mentions of
    every commander turn (``Request.mentions``), where a correction that names no wrong object finds it."""
    result = list(plan)
    log = []
    for correction in corrections:
        meant = correction.meant.object_type
        wrong = _wrong_type(result, correction, earlier, ontology)
        if wrong is None or _handles(result, meant, ontology):
            continue
        renames = _renames(wrong, meant, ontology)
        changed = renamed(result, renames, ontology, set(renames.values()), as_receptacles=True)
        if changed is None or changed == result:
            continue
        differ = [i for i, (old, new) in enumerate(zip(result, changed, strict=True)) if old != new]
        first, last = differ[0], differ[-1] + 1
        log.append(
            RepairEvent(
                REQUEST_CORRECTION,
                first,
                f"the commander corrected {wrong} to {meant} ({correction.said!r}): the plan's {wrong} steps "
                f"are now {meant}'s",
                tuple(result[first:last]),
                tuple(changed[first:last]),
            )
        )
        result = changed
    return result, log


def _wrong_type(
    plan: Sequence[Subgoal], correction: Correction, earlier: Sequence[Mention], ontology: Ontology
) -> str | None:
    """The type the correction takes back, if the plan handles it: the named one, else the latest earlier
    mention of the meant object's kind (carried or not) that the plan handles."""
    if correction.wrong is not None:
        wrong = correction.wrong.object_type
        return wrong if _handles(plan, wrong, ontology) else None
    meant = correction.meant
    carried = ontology.get(meant.object_type).pickupable
    before = [m for m in earlier if m.turn < meant.turn and m.family != meant.family]
    for mention in reversed(before):
        if ontology.get(mention.object_type).pickupable == carried and _handles(
            plan, mention.object_type, ontology
        ):
            return mention.object_type
    return None


def _handles(plan: Sequence[Subgoal], object_type: str, ontology: Ontology) -> bool:
    """Whether a step of the plan names the type or a piece of it."""
    return any(s.obj == object_type or ontology.get(s.obj).sliced_from == object_type for s in plan)


def _renames(wrong: str, meant: str, ontology: Ontology) -> dict[str, str]:
    """wrong -> meant, and wrong's piece type to meant's when they are the same kind of piece (BreadSliced ->
    TomatoSliced; not EggCracked -> TomatoSliced)."""
    renames = {wrong: meant}
    wrong_piece, meant_piece = ontology.get(wrong).sliced_into, ontology.get(meant).sliced_into
    if wrong_piece and meant_piece and wrong_piece.removeprefix(wrong) == meant_piece.removeprefix(meant):
        renames[wrong_piece] = meant_piece
    return renames
