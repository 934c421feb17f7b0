"""The TATC commander's instruction form: subgoals with optional where-to-stand and where-to-click hints.

The JARVIS seed's commander (its Figure 5) speaks in this form: ``Navigate Mug @ (2.00, 5.00, 270, 30),
Pickup Mug @ (0.70, 0.37)`` — a Navigate may carry a standing pose (x, z in metres, yaw in degrees and,
optionally, the camera's horizon in degrees, positive looking down) found with SearchObject, an
interaction a click point (x = column, y = row, fractions of the follower's frame) from the ground-truth
segmentation, valid from that pose at that horizon. Which hints the commander may give is its
information level (the seed's Table 2): everything; no segmentation (no clicks); neither segmentation nor
goal location (plain subgoals). A follower reads the subgoals as its plan and the hints as help for
finding and clicking.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from symbolic.ontology import Ontology, UnknownObjectType
from symbolic.subgoals import Subgoal, SubgoalAction, SubgoalSyntaxError, parse_subgoals
from symbolic.thor import HORIZON_MAX_DEG, HORIZON_MIN_DEG

STAND_DECIMALS = 3
"""Decimals of a stand hint's metres: AI2-THOR's 0.25 m grid has its cell centres on multiples of 0.125 m,
which three decimals carry exactly (the click hint holds only from exactly there)."""
CLICK_DECIMALS = 3
"""Decimals of a click hint's fractions: 0.0005 of a 900-pixel frame is under half a pixel (two decimals
would move a click by up to 4.5 pixels, off a small object or onto what lies on it)."""


@dataclass(frozen=True)
class StandHint:
    """Where to stand to reach the object: world metres, a yaw in degrees (0 faces +z, clockwise), and the
    camera horizon in degrees (positive looks down) from which the click hint that follows holds."""

    x: float
    z: float
    yaw: float
    horizon: float | None = None


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
            stand = self.stand
            horizon = "" if stand.horizon is None else f", {stand.horizon:.0f}"
            d = STAND_DECIMALS
            return f"{self.subgoal} @ ({stand.x:.{d}f}, {stand.z:.{d}f}, {stand.yaw:.0f}{horizon})"
        if self.click is not None:
            d = CLICK_DECIMALS
            return f"{self.subgoal} @ ({self.click.x:.{d}f}, {self.click.y:.{d}f})"
        return str(self.subgoal)


_ITEM = re.compile(r"\s*([A-Za-z]+)\s+([A-Za-z][A-Za-z ]*?)\s*(?:@\s*\(([^)]*)\))?\s*(?:,|;|$)")
_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)")


def _numbers(text: str, where: str) -> list[float]:
    """The comma-separated decimal numbers of a hint; anything else in the parentheses is an error."""
    parts = [part.strip() for part in text.split(",")]
    bad = [part for part in parts if not _NUMBER.fullmatch(part)]
    if bad:
        raise SubgoalSyntaxError(f"{where}: a hint holds decimal numbers only, got {bad[0]!r} in ({text})")
    return [float(part) for part in parts]


def _hint(subgoal: Subgoal, numbers: str, where: str) -> CommandItem:
    values = _numbers(numbers, where)
    if subgoal.action is SubgoalAction.NAVIGATE:
        if len(values) not in (3, 4):
            raise SubgoalSyntaxError(
                f"{where}: a Navigate hint is (x, z, yaw) or (x, z, yaw, horizon), got ({numbers})"
            )
        if len(values) == 4 and not HORIZON_MIN_DEG <= values[3] <= HORIZON_MAX_DEG:
            raise SubgoalSyntaxError(
                f"{where}: the horizon {values[3]:g} lies outside "
                f"[{HORIZON_MIN_DEG:g}, {HORIZON_MAX_DEG:g}] degrees"
            )
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
