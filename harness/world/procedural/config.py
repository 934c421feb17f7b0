"""What the procedural generator is asked for (``WorldGenConfig``), the floor outlines it can draw, and how
it says an attempt or a whole config failed."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from harness.world.catalog import Span, load_catalog
from harness.world.model import RoomKind
from symbolic.thor import GRID_STEP_M

ShapeName = Literal["auto", "rect", "L", "T", "U"]

CELLS_PER_M = round(1 / GRID_STEP_M)
MIN_ARM_CELLS = 8
"""Narrowest part of a room: 2 m, so counters on both walls still leave a 0.5 m walkway."""
MIN_NOTCH_CELLS = 4
"""Smallest step in an L, T or U outline (1 m), so the shape is not a rectangle in disguise."""
SHAPE_MIN_CELLS: dict[str, int] = {"rect": 64, "L": 128, "T": 144, "U": 224}
"""Fewest floor cells each outline can have with MIN_ARM_CELLS arms and MIN_NOTCH_CELLS notches."""
SHAPE_WEIGHTS: dict[str, float] = {"rect": 0.35, "L": 0.3, "T": 0.15, "U": 0.2}
"""How often "auto" picks each outline among those that fit the drawn area."""


class WorldGenError(RuntimeError):
    """No sound world could be built for a config (after every attempt); says what kept failing."""


class Retry(Exception):
    """One attempt cannot succeed; the generator draws the next sub-seed."""


@dataclass(frozen=True)
class WorldGenConfig:
    """What to generate. Same config, same world."""

    kind: RoomKind
    seed: int = 0
    min_area_m2: float | None = None
    """Smallest floor area; None takes the room kind's default from the catalog (kitchens 10 m^2)."""
    max_area_m2: float | None = None
    """Largest floor area; None takes the room kind's default (kitchens 30 m^2)."""
    shape: ShapeName = "auto"
    dirty_prob: float = 0.3
    """Chance that a dirtyable object (dish, pan, mug...) starts dirty."""
    inside_closed_prob: float = 0.35
    """Chance that an object which may go in a closed openable (fridge, cabinet, drawer...) is put in one."""
    filled_prob: float = 0.15
    """Chance that a clean fillable container starts filled."""
    coffee_prob: float = 0.3
    """Chance that a filled Mug holds coffee rather than water."""
    require: tuple[tuple[str, int], ...] = ()
    """Types and how many of each must exist, e.g. (("Potato", 1), ("Pot", 1)); impossible ones fail."""
    max_attempts: int = 40
    """Sub-seeds to try before giving up with WorldGenError."""

    def __post_init__(self) -> None:
        catalog = load_catalog()
        catalog.room(self.kind)
        if self.shape not in get_args(ShapeName):
            raise ValueError(f"shape must be one of {get_args(ShapeName)}, got {self.shape!r}")
        for name in ("dirty_prob", "inside_closed_prob", "filled_prob", "coffee_prob"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        lo, hi = self.area_range_m2()
        if not 0 < lo <= hi:
            raise ValueError(f"min_area_m2 must be positive and <= max_area_m2, got {lo} and {hi}")
        if self.shape != "auto" and SHAPE_MIN_CELLS[self.shape] > hi * CELLS_PER_M**2:
            need = SHAPE_MIN_CELLS[self.shape] / CELLS_PER_M**2
            raise ValueError(f"a {self.shape} room needs at least {need} m^2, but max_area_m2 is {hi}")
        for object_type, count in self.require:
            if count < 1:
                raise ValueError(f"require count for {object_type!r} must be >= 1, got {count}")
        if self.max_attempts < 1:
            raise ValueError(f"max_attempts must be >= 1, got {self.max_attempts}")

    def area_range_m2(self) -> Span:
        lo, hi = load_catalog().room(self.kind).area_m2
        return (
            self.min_area_m2 if self.min_area_m2 is not None else lo,
            self.max_area_m2 if self.max_area_m2 is not None else hi,
        )
