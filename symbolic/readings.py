"""Choosing among the language planner's readings of a request once a subgoal has failed.

HLSM's high level samples another subgoal when one fails; our planner's beam already holds the other
readings the model found likely, and they differ mostly in which object a word means ("the pan" as Pan or
Pot, "the cup" as Cup or Mug). When the agent gave a subgoal up (its object was not found, or the action
kept failing), the top reading of the re-plan often asks for the same thing again. Giving a subgoal up once
is weak evidence: the search may have missed an object that is there (ALFRED valid_seen game 30 lost its Cup
that way to a Mug reading). So another reading is taken at once only when the objects it adds are on the
map; otherwise the first reading gets another try, and only a subgoal given up again sends the agent to a
reading whose objects are not mapped yet. Without a failure, the model's first reading always stands.

The other rule, retrying the first reading once whatever the map says, was measured against this one on the
model-planner TfD and ALFRED benches: it wins where the mapped object of another reading is the wrong one
and loses where the first reading's object is absent from the room, and the two end level; so the map
decides here.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass

from symbolic.subgoals import Subgoal, format_subgoals

TRIES_BEFORE_UNMAPPED = 2
"""Times the first reading's subgoal is given up before a reading naming unmapped objects is followed."""


@dataclass(frozen=True)
class ReadingChoice:
    """The reading to pursue (an index into the readings, 0 being the model's first) and why."""

    index: int
    reason: str


def choose_reading(
    readings: Sequence[Sequence[Subgoal]],
    given_up: Mapping[Subgoal, int],
    seen_types: Collection[str],
) -> ReadingChoice:
    """Which reading to pursue, given how often each subgoal was given up and the types the map has seen.

    ``readings[0]`` stands unless it asks again for a given-up subgoal and another reading asks for fewer.
    Among those, one whose added object types (named by it, not by the first) are all mapped is taken,
    fewest repeats then beam rank first; failing that, the first reading is retried until a subgoal it
    repeats has been given up ``TRIES_BEFORE_UNMAPPED`` times, and then the reading with the fewest
    repeats, then fewest unmapped types, then best rank is taken."""
    if not readings:
        raise ValueError("choose_reading needs at least one reading")
    first = readings[0]
    repeated = [subgoal for subgoal in dict.fromkeys(first) if given_up.get(subgoal, 0) > 0]
    if not repeated:
        return ReadingChoice(0, "the first reading repeats no given-up subgoal")

    def repeats(plan: Sequence[Subgoal]) -> int:
        return sum(1 for subgoal in plan if given_up.get(subgoal, 0) > 0)

    first_types = {subgoal.obj for subgoal in first}

    def unmapped_added(plan: Sequence[Subgoal]) -> list[str]:
        added = {subgoal.obj for subgoal in plan} - first_types
        return sorted(obj for obj in added if obj not in seen_types)

    others = [i for i in range(1, len(readings)) if repeats(readings[i]) < repeats(first)]
    again = "; ".join(format_subgoals([subgoal]) for subgoal in repeated)
    if not others:
        return ReadingChoice(0, f"no other reading avoids {again} (given up)")
    mapped = [i for i in others if not unmapped_added(readings[i])]
    tries = max(given_up[subgoal] for subgoal in repeated)
    if mapped:
        best = min(mapped, key=lambda i: (repeats(readings[i]), i))
        why = "every object it adds is mapped"
    elif tries < TRIES_BEFORE_UNMAPPED:
        missing = sorted({obj for i in others for obj in unmapped_added(readings[i])})
        return ReadingChoice(
            0,
            f"the first reading again, once more: the other readings name objects not mapped yet "
            f"({', '.join(missing)}), and {again} was given up only once",
        )
    else:
        best = min(others, key=lambda i: (repeats(readings[i]), len(unmapped_added(readings[i])), i))
        why = f"given up {tries} times; not mapped yet: " + ", ".join(unmapped_added(readings[best]))
    reason = (
        f"the model's reading {best + 1} of {len(readings)} instead of its first, which asks again for "
        f"{again} (given up); {why}"
    )
    return ReadingChoice(best, reason)
