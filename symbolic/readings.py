"""Choosing among the language planner's readings of a request once a subgoal has failed.

HLSM's high level samples another subgoal when one fails; our planner's beam already holds the other
readings the model found likely, and they differ mostly in which object a word means ("the pan" as Pan or
Pot, "the cup" as Cup or Mug). When the agent gave a subgoal up (its object was not found, or the action
kept failing), the top reading of the re-plan often asks for the same thing again; a reading that asks for
something else, preferably something the map has seen, is the better bet. Only then does the choice
leave the model's order: without a failure, the model's first reading stands (an object not seen yet is
just not found yet).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass

from symbolic.subgoals import Subgoal, format_subgoals


@dataclass(frozen=True)
class ReadingChoice:
    """The reading to pursue (an index into the readings, 0 being the model's first) and why."""

    index: int
    reason: str


def choose_reading(
    readings: Sequence[Sequence[Subgoal]], failed: Collection[Subgoal], seen_types: Collection[str]
) -> ReadingChoice:
    """The reading that repeats the fewest failed subgoals, then names the fewest object types the map has
    not seen, then ranks first in the beam. ``readings[0]`` stands unless it repeats a failed subgoal and
    another reading repeats fewer."""
    if not readings:
        raise ValueError("choose_reading needs at least one reading")

    def repeats(plan: Sequence[Subgoal]) -> int:
        return sum(1 for subgoal in plan if subgoal in failed)

    def unseen(plan: Sequence[Subgoal]) -> list[str]:
        return sorted({subgoal.obj for subgoal in plan if subgoal.obj not in seen_types})

    first_repeats = repeats(readings[0])
    if first_repeats == 0:
        return ReadingChoice(0, "the first reading repeats no failed subgoal")
    best = min(range(len(readings)), key=lambda i: (repeats(readings[i]), len(unseen(readings[i])), i))
    if best == 0:
        return ReadingChoice(0, "no other reading avoids the failed subgoals")
    missing = unseen(readings[best])
    mapped = "every object it names is mapped" if not missing else f"not mapped yet: {', '.join(missing)}"
    again = [format_subgoals([s]) for s in dict.fromkeys(s for s in readings[0] if s in failed)]
    reason = (
        f"the model's reading {best + 1} of {len(readings)} instead of its first, which asks again for "
        f"{'; '.join(again)} (given up); {mapped}"
    )
    return ReadingChoice(best, reason)
