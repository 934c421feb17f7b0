"""The TATC commander's instruction form: subgoals with optional where-to-stand and where-to-click hints.

The JARVIS seed's commander (its Figure 5) speaks in this form: ``Navigate Mug @ (2.00, 5.00, 270),
Pickup Mug @ (0.70, 0.37)`` — a Navigate may carry a standing pose (x, z in metres, yaw in degrees) found
with SearchObject, an interaction a click point (x = column, y = row, fractions of the follower's frame)
from the ground-truth segmentation. Which hints the commander may give is its information level (the
seed's Table 2): everything; no segmentation (no clicks); neither segmentation nor goal location (plain
subgoals). A follower reads the subgoals as its plan and the hints as help for finding and clicking.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import Subgoal, SubgoalAction, SubgoalSyntaxError, parse_subgoals


@dataclass(frozen=True)
class StandHint:
    """Where to stand to reach the object: world metres and a yaw in degrees."""

    x: float
    z: float
    yaw: float


@dataclass(frozen=True)
class ClickHint:
    """Where the object shows in the follower's frame from the hinted pose: column, row fractions."""

    x: float
    y: float


@dataclass(frozen=True)
class CommandItem:
    """One subgoal of a commander instruction and the hint that came with it (at most one)."""

    subgoal: Subgoal
    stand: StandHint | None = None
    click: ClickHint | None = None

    def __str__(self) -> str:
        if self.stand is not None:
            return f"{self.subgoal} @ ({self.stand.x:.2f}, {self.stand.z:.2f}, {self.stand.yaw:.0f})"
        if self.click is not None:
            return f"{self.subgoal} @ ({self.click.x:.2f}, {self.click.y:.2f})"
        return str(self.subgoal)


_ITEM = re.compile(r"\s*([A-Za-z]+)\s+([A-Za-z][A-Za-z ]*?)\s*(?:@\s*\(([^)]*)\))?\s*(?:,|;|$)")
_NUMBER = r"-?\d+(?:\.\d+)?"


def _hint(subgoal: Subgoal, numbers: str, where: str) -> CommandItem:
    values = [float(v) for v in re.findall(_NUMBER, numbers)]
    if subgoal.action is SubgoalAction.NAVIGATE:
        if len(values) != 3:
            raise SubgoalSyntaxError(f"{where}: a Navigate hint is (x, z, yaw), got ({numbers})")
        return CommandItem(subgoal, stand=StandHint(*values))
    if len(values) != 2 or not all(0.0 <= v <= 1.0 for v in values):
        raise SubgoalSyntaxError(f"{where}: a click hint is (x, y) fractions in [0, 1], got ({numbers})")
    return CommandItem(subgoal, click=ClickHint(*values))


def parse_command(text: str, ontology: Ontology) -> list[CommandItem] | None:
    """The items of a commander instruction, or None when the text is not one (ordinary language).

    All of the text must be items: "Pickup Mug @ (0.7, 0.37)" parses; "please pick up the mug" does not.
    Raises SubgoalSyntaxError for a hint of the wrong shape (the text clearly meant to be an instruction).
    """
    stripped = text.strip().rstrip(".")
    if not stripped:
        return None
    items: list[CommandItem] = []
    position = 0
    while position < len(stripped):
        match = _ITEM.match(stripped, position)
        if match is None or match.end() == position:
            return None
        action, obj, numbers = match.group(1), match.group(2), match.group(3)
        try:
            parsed = parse_subgoals(f"{action} {obj}", ontology)
        except (SubgoalSyntaxError, UnknownObjectType):
            return None  # not an action word or not an object name: ordinary language
        if len(parsed) != 1:
            return None
        where = f"item {len(items)}"
        items.append(CommandItem(parsed[0]) if numbers is None else _hint(parsed[0], numbers, where))
        position = match.end()
    return items


def format_command(items: Sequence[CommandItem]) -> str:
    """The text form ``parse_command`` reads."""
    return ", ".join(str(item) for item in items)
