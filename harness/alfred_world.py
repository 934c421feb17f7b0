"""Worlds built from an ALFRED trajectory and its AI2-THOR floor plan (issue 3 §1, second bullet).

The agent's grid is ALFRED's: floor cells are centred on the floor plan's reachable points, so the
trajectory's ``init_action`` (and every pose of its expert plan) lands on a cell centre. Around them:

1. **Receptacles** from ``layouts/FloorPlanN-openable.json`` (plus any receptacle type the floor plan does
   not list but the trajectory's plan uses, at the plan's position), each a box at the position its AI2-THOR
   id encodes, sized from the catalog, turned to face the walkway, and kept AGENT_RADIUS_M from every
   reachable point, since a reachable point is where the agent's capsule fits (moved back first, shrunk if
   that is not enough, set in front of ALFRED's interaction pose if nothing is left). Surfaces grow to cover
   the objects the trajectory rests on them and take their height from those objects; counters get extra
   segments where objects rest at counter height over nothing (AI2-THOR's counters are L-shaped single
   objects); drawers and cabinets under a surface stack from the floor to its underside; sinks and bathtubs
   become basin (the ``Sink|...|SinkBasin`` id ALFRED lists) plus deck, and sinks get a Faucet; upper units
   are pushed back onto the wall. Overlaps are cut from the later piece (or shared, or the piece moves);
   fronts are brought up to the walkway; anything left hanging stands on what is below it.
2. **Fixtures** the floor plan lists (``FloorPlanN-objects.json``) without positions: stove burners on a
   counter with a knob each on its front, toaster and coffee machine on a counter, desk lamp on a desk, side
   table or dresser, television on its stand, floor lamp, toilet and garbage can on the floor, light switch,
   towel holders and toilet-paper hanger on walls. Each goes where the trajectory's plan acts on one
   (``plan.high_pddl`` coordinates), else near the objects that hint at it, else to the first free spot of a
   fixed order, so every ALFRED task stays solvable. Objects ALFRED leaves on the floor join them.
3. **The room**: those cells plus every cell under a piece, holes closed. A cell the agent could stand on
   that ALFRED's grid does not list and nothing stands on leaves the floor (the wall comes up to the walkway,
   or a pillar stands where AI2-THOR has furniture the data does not place; in kitchens that furniture is
   counter, so such pillars are counter-height CounterTop blocks), so the reachable grid stays the floor
   plan's; floor this cuts off from the walkway is joined back by the fewest cells.
4. **Objects** from ``scene.object_poses`` (type = objectName before '_', id = AI2-THOR's id for the pose's
   position), each into or onto the accepting receptacle (the ontology) whose holding volume is nearest its
   ALFRED position, at the free spot nearest that position (``harness.physics.resting_center``); inside
   closed openables they stay closed. ``object_toggles`` set isToggled; ``dirty_and_empty`` makes dishes
   dirty and containers empty (ALFRED's meaning), else everything is clean and empty.
5. **The agent** at ``init_action``: (x, z), rotation as yaw, horizon.

Listed reachable points in pieces the agent cannot walk between are joined by a corridor of at most
MAX_BRIDGE_CELLS cells or dropped; a start point off the listed grid is joined to it. ``AlfredWorldReport``
lists those departures from the floor plan and anything that found no place.
"""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import cv2
import numpy as np

from harness.alfred_data import (
    AlfredScene,
    FloorPlan,
    InteractionPose,
    ObjectPose,
    ReceptacleSpot,
    load_alfred_trajectories,
    load_floor_plan,
    scene_of,
)
from harness.catalog import Catalog, load_catalog
from harness.invariants import (
    EPS_M,
    on_wall,
    reachable_centres,
    viewable_from,
)
from harness.navgrid import BLOCKING_BELOW_M, CLEARANCE_M, reachable_grid
from harness.physics import resting_center
from harness.tasks.alfred import AlfredTask, alfred_task_from_pddl
from harness.world import AgentState, Room, World, WorldObject, make_object_id
from harness.worldgen import walls_of
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import AGENT_RADIUS_M, GRID_STEP_M, HORIZON_MAX_DEG, HORIZON_MIN_DEG

Mount = Literal["floor", "wall"]
Vec3 = tuple[float, float, float]

# ----------------------------------------------------------------------------- the grid and the walkway

MAX_BRIDGE_CELLS = 3
"""Longest corridor (cells) added to join a piece of the listed reachable grid to the rest; longer gaps drop
the piece (AI2-THOR's grid has a few islands behind furniture that a 4-connected walk cannot reach)."""

FURNITURE_CLEARANCE_M = AGENT_RADIUS_M
"""Furniture keeps the agent's capsule radius from every reachable point, as AI2-THOR's reachability implies
(the navigation grid only needs CLEARANCE_M, so knobs and handles may stick out a little)."""

THIN_CLEARANCE_M = CLEARANCE_M + 0.005
"""Wall fixtures and objects on the floor keep just over the navigation grid's clearance."""

# ------------------------------------------------------------------------------------- pieces and cuts

MAX_RETREAT_M = 0.35
"""A piece whose front reaches into the walkway is first moved back by up to this, then shrunk."""

MAX_ADVANCE_M = 0.5
"""Farthest a piece's front is brought forward to meet the walkway (module docstring, 1)."""

MAX_SLIDE_M = 0.25
"""Farthest a rigid piece (a fridge) slides sideways to meet the walkway (``_advance``)."""
MIN_KEPT_ALONG = 0.6
"""Share of its length a piece keeps when it gives up an end to come forward (``_advance``)."""
SLIDE_STEP_M = 0.05
_SLIDES = tuple(
    dict.fromkeys(k * SLIDE_STEP_M * s for k in range(round(MAX_SLIDE_M / SLIDE_STEP_M) + 1) for s in (1, -1))
)

RELOCATE_M = 0.6
"""Farthest a piece that fits nowhere near its id's position is moved to a free spot."""

MIN_SIDE_M = 0.12
"""Narrowest a piece may be cut or shrunk to along x or z."""

MIN_HEIGHT_M = 0.03
"""Thinnest a piece may be cut to vertically."""

CUT_MARGIN_M = 1e-4
"""Cuts go this much past the limit so that rounding never leaves a point on the boundary."""

COLUMN_OVERLAP = 0.35
"""Cabinets and drawers whose footprints share this much of the smaller one stack in one column."""

UNDER_OVERLAP = 0.3
"""A cabinet or drawer is in a surface's body when this much of its footprint is under the surface."""

SHARE_MIN_KEPT = 0.5
"""A piece cut to less than this share of its volume shares the space instead (see ``_share``)."""

MAX_CLASHES = 8
"""Overlaps resolved for one piece before it is moved or dropped."""

MIN_KEPT_FRACTION = 0.5
"""A unit trimmed to what stands under it keeps at least this share of its footprint, else it stands."""

WALL_SNAP_MAX_M = 0.75
"""Farthest a wall unit is pushed back to meet the wall."""

SUPPORT_ROUNDS = 4
"""Passes of the final support fix (each can only lower pieces, so a few settle every floor plan)."""

# ------------------------------------------------------------------------- heights from ids and objects

PIVOT_AT_BASE_MAX_M = 0.15
"""Ids lower than this mark a piece standing on the floor (AI2-THOR puts most pivots at the base)."""

UPPER_UNIT_MIN_Y_M = 1.2
"""Cabinets whose id is higher than this hang on the wall (AI2-THOR's upper cabinets sit at 1.4-2.2 m)."""

UPPER_CABINET_BELOW_PIVOT_M = 0.4
"""An upper cabinet's box starts this far below its id's height (ALFRED: cups at 1.66 m in one at 2.02 m)."""

COUNTER_PIVOT_ABOVE_TOP_M = 0.05
"""CounterTop and Sink ids sit about this far above the top (ALFRED: ids at 0.95 m, objects at 0.90 m)."""

DRESSER_TOP_M = 0.8
"""Top of a dresser with no objects on it (ALFRED's: 0.67-1.23 m; the catalog sizes only its slab)."""

SLAB_M = 0.05
"""Thickness of a table or desk top that has drawers or cabinets under it."""

UNDER_TOP_MARGIN_M = 0.12
"""A drawer or cabinet whose id is at most this above a surface's estimated top is in that surface's body
(the objects that set the top may rest on a shelf below it); the top is raised over the unit."""

REST_SNAP_M = 0.15
REST_SINK_M = 0.05
"""A piece whose base is within REST_SNAP_M above (or REST_SINK_M below) a surface's top rests on it (a
microwave on a counter, a safe on a dresser)."""

FRIDGE_HEADROOM_M = 0.15
"""A fridge is at least this much taller than the highest thing ALFRED puts in it."""

MAX_TOP_M = 2.35
"""Tops stay below the reach rule's 2.4 m view limit (invariants.VIEW_TOP_MAX_M)."""

RIM_SLAB_M = 0.3
"""A piece lying lower than this above a basin's rim covers its opening; a wall cabinet higher up leaves
room to look in."""

WALL_HEIGHT_MIN_M = 2.6
CEILING_GAP_M = 0.1
"""Rooms are WALL_HEIGHT_MIN_M high, or this much above their tallest piece."""

# ------------------------------------------------------------------------------------------- surfaces

TOP_BAND_BELOW_M = 0.12
TOP_BAND_ABOVE_M = 0.4
"""Objects whose ALFRED height lies in [prior top - below, prior top + above] are taken as resting on a
surface: they set its height (the lowest one, less REST_GAP_M) and its extent (GROW_REACH_M steps)."""

REST_GAP_M = 0.005
"""A surface's top is this far below the lowest object ALFRED rests on it."""

GROW_REACH_M = 0.35
"""A surface grows to take in a resting object at most this far outside its current footprint ..."""
FIXTURE_REACH_M = 1.0
"""... or this far for a stove burner or appliance the plan uses (the counter under it runs up to it) ..."""
MAX_GROW_M = 2.5
"""... and never beyond this from its id's position (counters run along a wall, tables do not)."""

PIVOT_SLACK_M = 0.05
"""An object's ALFRED position (its pivot) lies at most its height and this much above what holds it."""

SEGMENT_JOIN_M = 0.6
"""Objects at counter height over no piece and this close to one another share one counter segment."""

SURFACE_MARGIN_M = 0.05
"""A counter segment reaches this far past the objects that rest on it."""

# ----------------------------------------------------------------------------------------- placement

FLOOR_OBJECT_MAX_Y_M = 0.25
"""Objects ALFRED leaves lower than this and on no receptacle stay on the floor (plungers, balls, boots)."""

SEARCH_STEP_M = 0.05
"""Spacing of positions tried when placing fixtures and floor objects."""

FALLBACK_SIZES_M: dict[str, Vec3] = {
    "Ottoman": (0.6, 0.42, 0.6),
    "Cart": (0.6, 0.8, 0.45),
    "Glassbottle": (0.08, 0.28, 0.08),
    "Boots": (0.3, 0.3, 0.15),
    "Footstool": (0.45, 0.35, 0.45),
}
"""Sizes (w, h, d) of AI2-THOR types that ALFRED scenes hold but harness/catalog.json does not size yet."""

_COPY = "|copy"
"""Marks the second instance of a pose ALFRED lists twice until it is placed and named."""

_DIRECTIONS: dict[int, tuple[int, int]] = {0: (0, 1), 90: (1, 0), 180: (0, -1), 270: (-1, 0)}
"""Yaw -> unit (x, z): AI2-THOR's yaw 0 faces +z and 90 faces +x."""

_KEEPS_ITS_BOX: dict[str, int] = {
    **dict.fromkeys(("Fridge", "Sink", "SinkBasin", "Bathtub", "BathtubBasin"), 0),
    **dict.fromkeys(("Cabinet", "Drawer"), 1),
    **dict.fromkeys(("Microwave", "Safe", "GarbageCan"), 2),
    "Shelf": 3,
    "CounterTop": 5,
}
"""Rank in which overlapping pieces keep their boxes (lower first; other surfaces 4, by area): fridges,
sinks and tubs have fixed shapes and move rather than shrink; counters are the most forgiving."""

_STACKED = frozenset({"Cabinet", "Drawer"})
"""Units that stack into columns under counters, desks and dressers."""

_WALL_UNITS = frozenset({"Cabinet", "Shelf", "Microwave"})
"""Types AI2-THOR hangs above counters and furniture; high up, they face where ALFRED's planner looks from."""

_STANDING_SURFACES = ("Desk", "SideTable", "Dresser", "TVStand", "CoffeeTable", "DiningTable", "CounterTop")
"""Hosts for a desk lamp in a room without a desk, side table or dresser, in order of preference."""

_SLAB_TYPES = frozenset({"CounterTop", "Dresser", "Shelf"})
"""Surfaces the catalog sizes as a slab only (their body is the units under them)."""

_COUNTER_FIXTURES = ("CoffeeMachine", "Toaster")
_ON_COUNTER = frozenset({*_COUNTER_FIXTURES, "StoveBurner"})
"""Fixtures that stand on a counter: where the plan uses one, the counter reaches."""
_FIXTURE_RULES = frozenset(
    {"StoveBurner", "StoveKnob", "CoffeeMachine", "Toaster", "DeskLamp", "FloorLamp", "Television", "Faucet"}
    | {"Toilet", "GarbageCan", "LightSwitch", "HandTowelHolder", "TowelHolder", "ToiletPaperHanger"}
)
"""Types placed by a fixture rule (module docstring, 2) rather than as a receptacle from the plan."""
_FLOOR_FIXTURES = ("Toilet", "GarbageCan", "FloorLamp")
_HANGERS: dict[str, str] = {
    "HandTowelHolder": "HandTowel",
    "TowelHolder": "Towel",
    "ToiletPaperHanger": "ToiletPaper",
}
"""Wall holders and what hangs from them (their ALFRED poses show where the holder is)."""

_MOUNT_BOTTOM_M: dict[str, float] = {
    "LightSwitch": 1.2,
    "HandTowelHolder": 1.25,
    "TowelHolder": 1.45,
    "ToiletPaperHanger": 0.75,
    "Television": 1.2,
}
"""Mounting height of each wall fixture's bottom (the middle of the catalog's bottom_m ranges)."""


@dataclass
class _Piece:
    """A box under construction: world corners that the builder cuts, moves and stretches."""

    object_id: str
    object_type: str
    lo: list[float]
    hi: list[float]
    facing: int
    mount: Mount
    pivot: Vec3
    controls: str | None = None
    seen_from: tuple[float, float, int] | None = None
    """(x, z, yaw) of the pose ALFRED's planner uses this receptacle from, if the floor plan gives one."""
    top_fixed: bool = False
    """Its top was set from the objects resting on it or from the unit above it; support fixes keep it."""

    @property
    def area(self) -> float:
        return max(self.hi[0] - self.lo[0], 0.0) * max(self.hi[2] - self.lo[2], 0.0)

    def overlaps(self, other: _Piece) -> bool:
        return all(min(self.hi[k], other.hi[k]) - max(self.lo[k], other.lo[k]) > EPS_M for k in range(3))

    def overlaps_xz(self, other: _Piece) -> bool:
        return all(min(self.hi[k], other.hi[k]) - max(self.lo[k], other.lo[k]) > EPS_M for k in (0, 2))

    def xz_overlap_area(self, other: _Piece) -> float:
        dx = min(self.hi[0], other.hi[0]) - max(self.lo[0], other.lo[0])
        dz = min(self.hi[2], other.hi[2]) - max(self.lo[2], other.lo[2])
        return max(dx, 0.0) * max(dz, 0.0)

    def contains_xz(self, x: float, z: float, margin: float = 0.0) -> bool:
        return (
            self.lo[0] - margin <= x <= self.hi[0] + margin
            and self.lo[2] - margin <= z <= self.hi[2] + margin
        )

    def copy(self) -> _Piece:
        return dataclasses.replace(self, lo=list(self.lo), hi=list(self.hi))

    def to_object(self) -> WorldObject:
        """Exact corners (no rounding: contacts decided to EPS_M here must stay contacts in the checks)."""
        center = tuple(float(a + b) / 2 for a, b in zip(self.lo, self.hi, strict=True))
        size = tuple(float(b - a) for a, b in zip(self.lo, self.hi, strict=True))
        return WorldObject(
            self.object_id,
            self.object_type,
            center,  # type: ignore[arg-type]
            size,  # type: ignore[arg-type]
            facing=self.facing,
            controls=self.controls,
        )


@dataclass(frozen=True)
class AlfredWorldReport:
    """How far a built world departs from ALFRED's floor plan (each count is small by design)."""

    layout_points: int
    missing_points: tuple[tuple[float, float], ...]
    """Listed reachable points that are not reachable here (dropped islands, points under a fixture)."""
    extra_points: tuple[tuple[float, float], ...]
    """Reachable cells the floor plan does not list (the start point, corridors joining islands)."""
    dropped: tuple[str, ...]
    """Receptacles, fixtures or object poses that found no place, each "id: reason" (rare: a few train
    trajectories lose an upper cabinet)."""


@dataclass
class _Build:
    """One trajectory's world under construction."""

    plan: FloorPlan
    scene: AlfredScene
    catalog: Catalog
    ontology: Ontology
    reachable: np.ndarray
    """float [M, 2]: the (x, z) cell centres the agent must be able to stand on."""
    pieces: list[_Piece] = field(default_factory=list)
    dropped: list[str] = field(default_factory=list)
    floor_items: set[str] = field(default_factory=set)
    """Ids of the objects ALFRED leaves on the floor, placed with the furniture (they shape the floor)."""
    decks: dict[str, tuple[str, str, float]] = field(default_factory=dict)
    """Basin id -> (deck id, deck type, deck's share of the fixture's depth) of each sink and bathtub."""

    def size_of(self, object_type: str) -> Vec3:
        if self.catalog.has_size(object_type):
            return self.catalog.nominal_size(object_type)
        if object_type in FALLBACK_SIZES_M:
            return FALLBACK_SIZES_M[object_type]
        return self.catalog.nominal_size(object_type)  # raises, naming the sized types

    def of_type(self, *types: str) -> list[_Piece]:
        return [p for p in self.pieces if p.object_type in types]


# ------------------------------------------------------------------------------------------- reachable grid


def _cell(x: float, z: float) -> tuple[int, int]:
    return round(x / GRID_STEP_M), round(z / GRID_STEP_M)


def _components(cells: set[tuple[int, int]]) -> list[set[tuple[int, int]]]:
    """4-connected pieces, largest first (ties by their smallest cell, for determinism)."""
    left = set(cells)
    parts = []
    while left:
        seed = min(left)
        part = {seed}
        frontier = [seed]
        left.discard(seed)
        while frontier:
            i, k = frontier.pop()
            for n in ((i + 1, k), (i - 1, k), (i, k + 1), (i, k - 1)):
                if n in left:
                    left.discard(n)
                    part.add(n)
                    frontier.append(n)
        parts.append(part)
    return sorted(parts, key=lambda p: (-len(p), min(p)))


def _corridor(
    source: set[tuple[int, int]], target: set[tuple[int, int]], limit: int
) -> list[tuple[int, int]] | None:
    """Fewest cells (at most ``limit``) that 4-connect ``source`` to ``target`` (breadth-first)."""
    parent: dict[tuple[int, int], tuple[int, int] | None] = {c: None for c in sorted(source)}
    frontier = collections.deque((c, 0) for c in sorted(source))
    while frontier:
        (i, k), depth = frontier.popleft()
        for n in ((i + 1, k), (i - 1, k), (i, k + 1), (i, k - 1)):
            if n in parent:
                continue
            parent[n] = (i, k)
            if n in target:
                path = []
                step = parent[n]
                while step is not None and step not in source:
                    path.append(step)
                    step = parent[step]
                return path
            if depth < limit:
                frontier.append((n, depth + 1))
    return None


def _reachable_cells(plan: FloorPlan, start: tuple[float, float]) -> set[tuple[int, int]]:
    """The listed points as cells, joined into one 4-connected piece that includes the start cell."""
    listed = {_cell(x, z) for x, z in plan.reachable}
    parts = _components(listed)
    main = set(parts[0]) if parts else set()
    start_cell = _cell(*start)
    if start_cell not in main:
        home = next((p for p in parts if start_cell in p), {start_cell})
        path = _corridor(home, main, limit=10**6) if main else []
        main |= home | set(path or [])
    for part in parts[1:]:
        if part <= main:
            continue
        path = _corridor(part, main, limit=MAX_BRIDGE_CELLS)
        if path is not None:
            main |= part | set(path)
    return main


# ----------------------------------------------------------------------------------------------- geometry


def _violators(lo: list[float], hi: list[float], points: np.ndarray, clearance: float) -> np.ndarray:
    """[V, 2] reachable points closer than ``clearance`` to the footprint (navgrid's test)."""
    c = clearance
    near = (
        (points[:, 0] > lo[0] - c)
        & (points[:, 0] < hi[0] + c)
        & (points[:, 1] > lo[2] - c)
        & (points[:, 1] < hi[2] + c)
    )
    return points[near]


def _frontal_violators(lo: list[float], hi: list[float], axis: int, points: np.ndarray) -> np.ndarray:
    """[V, 2] reachable points a piece advancing along ``axis`` must keep clear of: FURNITURE_CLEARANCE_M in
    front of it, but only the navigation grid's CLEARANCE_M beside it. A point diagonally off a fridge's
    corner, 19 cm from where its front would be, held the fridge back, and the unlisted strip left in front
    of its door became a wall that hid everything in it."""
    side = 2 - axis
    ahead = (points[:, axis // 2] > lo[axis] - FURNITURE_CLEARANCE_M) & (
        points[:, axis // 2] < hi[axis] + FURNITURE_CLEARANCE_M
    )
    beside = (points[:, side // 2] > lo[side] - CLEARANCE_M) & (points[:, side // 2] < hi[side] + CLEARANCE_M)
    return points[ahead & beside]


def _facing(x: float, z: float, points: np.ndarray, fallback: tuple[float, float]) -> int:
    """The axis yaw from a piece towards the nearest reachable point (furniture faces the floor it is used
    from); ties, and floor plans without points, go to the side ALFRED's planner stood on (``fallback``)."""
    rel = points - np.array([x, z])  # [N, 2]
    fx, fz = fallback
    options = []
    for yaw, (dx, dz) in _DIRECTIONS.items():
        along = rel[:, 0] * dx + rel[:, 1] * dz
        across = np.abs(rel[:, 0] * dz - rel[:, 1] * dx)
        cone = along >= across  # within 45 degrees of the yaw
        if cone.any():
            nearest = float(np.hypot(rel[cone, 0], rel[cone, 1]).min())
            options.append((round(nearest, 3), -(fx * dx + fz * dz), yaw))
    if options:
        return min(options)[2]
    if abs(fx) >= abs(fz):
        return 90 if fx >= 0 else 270
    return 0 if fz >= 0 else 180


def _footprint(
    x: float, z: float, width: float, depth: float, facing: int
) -> tuple[list[float], list[float]]:
    """(lo, hi) with y left 0: ``width`` along the piece's front, ``depth`` front to back."""
    sx, sz = (width, depth) if facing in (0, 180) else (depth, width)
    return [x - sx / 2, 0.0, z - sz / 2], [x + sx / 2, 0.0, z + sz / 2]


def _retreat(piece: _Piece, points: np.ndarray, clearance: float) -> None:
    """Move a piece back (away from its front) until its front keeps ``clearance``, MAX_RETREAT_M at most."""
    dx, dz = _DIRECTIONS[piece.facing]
    axis, sign = (0, dx) if dx else (2, dz)
    bad = _violators(piece.lo, piece.hi, points, clearance)
    if not len(bad):
        return
    coord = bad[:, 0] if axis == 0 else bad[:, 1]
    front = piece.hi[axis] if sign > 0 else piece.lo[axis]
    needed = (
        float((front - (coord - clearance)).max()) if sign > 0 else float(((coord + clearance) - front).max())
    )
    shift = min(max(needed, 0.0), MAX_RETREAT_M)
    piece.lo[axis] -= sign * shift
    piece.hi[axis] -= sign * shift


def _clip(piece: _Piece, points: np.ndarray, clearance: float) -> bool:
    """Cut the footprint until no reachable point is within ``clearance``; False if it gets too small.

    Greedy: each round applies the single cut (one side of one offending point) that keeps the piece's id
    position inside if possible and the most area otherwise."""
    px, _, pz = piece.pivot
    for _ in range(256):
        bad = _violators(piece.lo, piece.hi, points, clearance)
        if not len(bad):
            return True
        best: tuple[bool, float, int, int, float] | None = None
        for bx, bz in bad:
            for axis, p in ((0, bx), (2, bz)):
                for side, value in ((1, p - clearance - CUT_MARGIN_M), (0, p + clearance + CUT_MARGIN_M)):
                    lo, hi = list(piece.lo), list(piece.hi)
                    if side == 1 and value < hi[axis]:
                        hi[axis] = value
                    elif side == 0 and value > lo[axis]:
                        lo[axis] = value
                    else:
                        continue
                    if hi[0] - lo[0] < MIN_SIDE_M or hi[2] - lo[2] < MIN_SIDE_M:
                        continue
                    keeps = lo[0] <= px <= hi[0] and lo[2] <= pz <= hi[2]
                    area = (hi[0] - lo[0]) * (hi[2] - lo[2])
                    key = (keeps, area, axis, side, value)
                    if best is None or key[:2] > best[:2]:
                        best = key
        if best is None:
            return False
        _, _, axis, side, value = best
        if side == 1:
            piece.hi[axis] = min(piece.hi[axis], value)
        else:
            piece.lo[axis] = max(piece.lo[axis], value)
    return False


def _cut(piece: _Piece, other: _Piece) -> bool:
    """Remove ``other``'s box from ``piece`` by moving one face of ``piece``; False if too little is left."""
    px, py, pz = piece.pivot
    best: tuple[bool, float, int, int, float] | None = None
    volume = math.prod(b - a for a, b in zip(piece.lo, piece.hi, strict=True))
    for axis in (0, 2, 1):
        minimum = MIN_HEIGHT_M if axis == 1 else MIN_SIDE_M
        for side, value in ((1, other.lo[axis]), (0, other.hi[axis])):
            if axis == 1 and side == 1 and piece.top_fixed:
                continue  # a surface keeps its top: that is where ALFRED's objects rest
            lo, hi = list(piece.lo), list(piece.hi)
            if side == 1:
                hi[axis] = min(hi[axis], value)
            else:
                lo[axis] = max(lo[axis], value)
            if hi[axis] - lo[axis] < minimum:
                continue
            keeps = lo[0] <= px <= hi[0] and lo[2] <= pz <= hi[2]
            kept = math.prod(b - a for a, b in zip(lo, hi, strict=True)) / max(volume, 1e-12)
            if axis == 1:
                kept *= 0.5  # prefer keeping a piece's height: its top carries objects, its base the floor
            key = (keeps, kept, axis, side, value)
            if best is None or key[:2] > best[:2]:
                best = key
    if best is None:
        return False
    _, _, axis, side, value = best
    if side == 1:
        piece.hi[axis] = value
    else:
        piece.lo[axis] = value
    return True


# ------------------------------------------------------------------------------------------ receptacles


def _prior_top(spot: ReceptacleSpot, b: _Build) -> float:
    """Where a surface's top should be before looking at the objects on it."""
    y = spot.position[1]
    kind = spot.object_type
    if kind == "CounterTop":
        return y - COUNTER_PIVOT_ABOVE_TOP_M if y > PIVOT_AT_BASE_MAX_M else b.catalog.counter.top_m
    if kind == "Shelf":
        return y
    default = DRESSER_TOP_M if kind == "Dresser" else b.size_of(kind)[1]
    return max(default, y) if y > PIVOT_AT_BASE_MAX_M else default


def _resting_poses(b: _Build, top: float, below: float = TOP_BAND_BELOW_M) -> list[ObjectPose]:
    return [
        p
        for p in b.scene.object_poses
        if top - below <= p.position[1] <= top + TOP_BAND_ABOVE_M and b.ontology.get(p.object_type).pickupable
    ]


def _claimed(
    pose: ObjectPose, owner: ReceptacleSpot, nominal: Mapping[str, tuple[_Piece, float, float]]
) -> bool:
    """Whether another receptacle's nominal box holds the pose (so it must not pull ``owner``'s surface)."""
    x, y, z = pose.position
    for oid, (box, y0, y1) in nominal.items():
        if oid != owner.object_id and box.contains_xz(x, z) and y0 <= y <= y1:
            return True
    return False


def _grow_surface(
    piece: _Piece, spot: ReceptacleSpot, b: _Build, nominal: Mapping[str, tuple[_Piece, float, float]]
) -> float:
    """Take in the objects resting on the surface: its footprint covers them and its top is just below the
    lowest of them. Returns the top height."""
    prior = _prior_top(spot, b)
    below = REST_GAP_M if spot.object_type == "Shelf" else TOP_BAND_BELOW_M
    candidates = [p for p in _resting_poses(b, prior, below) if not _claimed(p, spot, nominal)]
    if spot.object_type == "CounterTop":  # the stove and appliances the plan uses stand on a counter
        candidates += [
            ObjectPose(f"planned {kind}", kind, position, 0.0)
            for kind, position in b.scene.planned
            if kind in _ON_COUNTER and prior - TOP_BAND_BELOW_M <= position[1] <= prior + TOP_BAND_ABOVE_M
        ]
    taken: list[ObjectPose] = []
    px, _, pz = spot.position
    changed = True
    while changed:
        changed = False
        for pose in candidates:
            if pose in taken:
                continue
            x, _, z = pose.position
            reach = FIXTURE_REACH_M if pose.object_type in _ON_COUNTER else GROW_REACH_M
            if not piece.contains_xz(x, z, reach) or math.hypot(x - px, z - pz) > MAX_GROW_M:
                continue
            w, _, d = b.size_of(pose.object_type)
            half = max(w, d) / 2
            lo = [min(piece.lo[0], x - half), piece.lo[1], min(piece.lo[2], z - half)]
            hi = [max(piece.hi[0], x + half), piece.hi[1], max(piece.hi[2], z + half)]
            crossing = len(_violators(lo, hi, b.reachable, 0.0)) > len(
                _violators(piece.lo, piece.hi, b.reachable, 0.0)
            )
            if crossing:
                continue  # never across the walkway: that object is on something else
            piece.lo, piece.hi = lo, hi
            taken.append(pose)
            changed = True
    resting = [p.position[1] for p in taken if p.object_type not in _ON_COUNTER]
    if not resting or spot.object_type == "Shelf":
        return prior  # a shelf's id is at its top surface; what rests on it may have its pivot anywhere
    return max(min(resting) - REST_GAP_M, prior - TOP_BAND_BELOW_M)


def _nominal_pieces(b: _Build) -> dict[str, tuple[_Piece, float, float]]:
    """id -> (footprint at the id's position, y range it holds objects in): for telling who owns an object."""
    out = {}
    for spot in b.plan.receptacles:
        x, y, z = spot.position
        w, h, d = b.size_of(spot.object_type)
        over_furniture = y >= UPPER_UNIT_MIN_Y_M and spot.object_type in _WALL_UNITS
        if over_furniture or spot.object_type == "Fridge":  # its door faces where ALFRED's planner opens it
            facing = (round(spot.pose.rotation / 90) * 90 + 180) % 360
        else:
            facing = _facing(x, z, b.reachable, (spot.pose.x - x, spot.pose.z - z))
        lo, hi = _footprint(x, z, w, d, facing)
        box = _Piece(spot.object_id, spot.object_type, lo, hi, facing, "floor", (x, y, z))
        if spot.fixture_type == "Sink":  # the basin hangs below the counter top its id is level with
            top = y - COUNTER_PIVOT_ABOVE_TOP_M if y > PIVOT_AT_BASE_MAX_M else b.catalog.counter.top_m
            y0, y1 = top - h, top
        elif b.catalog.placement(spot.object_type) == "inside" or spot.fixture_type == "Bathtub":
            y0, y1 = (y - h / 2, y + h / 2) if y > PIVOT_AT_BASE_MAX_M else (0.0, h)
        else:
            top = _prior_top(spot, b)
            y0, y1 = top - TOP_BAND_BELOW_M, top + TOP_BAND_ABOVE_M
        out[spot.object_id] = (box, y0, y1)
    return out


def _make_piece(spot: ReceptacleSpot, b: _Build, facing: int, width: float, depth: float) -> _Piece:
    x, y, z = spot.position
    lo, hi = _footprint(x, z, width, depth, facing)
    seen_from = (spot.pose.x, spot.pose.z, round(spot.pose.rotation / 90) % 4 * 90)
    return _Piece(spot.object_id, spot.object_type, lo, hi, facing, "floor", (x, y, z), seen_from=seen_from)


def _basin_piece(spot: ReceptacleSpot, b: _Build, facing: int) -> _Piece:
    """A sink or bathtub as one rigid piece: the basin (the id ALFRED lists) in front, the fixture's deck
    behind it (AI2-THOR's Sink or Bathtub object); ``_split_decks`` cuts the deck off once it stands."""
    x, y, z = spot.position
    deck_type = spot.fixture_type
    width, height, basin_depth = b.size_of("BathtubBasin" if deck_type == "Bathtub" else "SinkBasin")
    deck_depth = b.size_of(deck_type)[2]
    piece = _make_piece(spot, b, facing, width, basin_depth + deck_depth)
    if deck_type == "Bathtub":
        piece.lo[1], piece.hi[1] = 0.0, b.size_of("Bathtub")[1]
    else:
        top = y - COUNTER_PIVOT_ABOVE_TOP_M if y > PIVOT_AT_BASE_MAX_M else b.catalog.counter.top_m
        piece.lo[1], piece.hi[1] = top - height, top
    piece.top_fixed = True
    b.decks[spot.object_id] = (
        spot.object_id.rsplit("|", 1)[0],
        deck_type,
        deck_depth / (basin_depth + deck_depth),
    )
    return piece


def _split_decks(b: _Build) -> None:
    """Each sink or bathtub piece becomes its basin (front) and its deck (back, the catalog's share of the
    depth). A sink that had to be stretched down to stand on something (the floor, or a low cabinet under
    it) becomes a basin of the catalog's depth on its Sink pedestal instead, the deck strip behind the basin
    left for the faucet: a basin stretched half a metre deep would hide what lies in it from every pose."""
    for piece in list(b.pieces):
        if piece.object_id not in b.decks:
            continue
        deck_id, deck_type, share = b.decks[piece.object_id]
        fx, fz = _DIRECTIONS[piece.facing]
        axis, sign = (0, fx) if fx else (2, fz)
        depth = piece.hi[axis] - piece.lo[axis]
        deck = dataclasses.replace(piece.copy(), object_id=deck_id, object_type=deck_type)
        split = (piece.lo[axis] + share * depth) if sign > 0 else (piece.hi[axis] - share * depth)
        basin_height = b.size_of("SinkBasin")[1]
        if deck_type == "Sink" and piece.hi[1] - piece.lo[1] > basin_height + EPS_M:
            deck.hi[1] = piece.lo[1] = piece.hi[1] - basin_height
        elif sign > 0:
            deck.hi[axis] = split
        else:
            deck.lo[axis] = split
        if sign > 0:
            piece.lo[axis] = split
        else:
            piece.hi[axis] = split
        b.pieces.append(deck)
        _uncover(b, piece)


def _uncover(b: _Build, basin: _Piece) -> None:
    """Cut back what lies on a basin's rim over its opening (up to RIM_SLAB_M above it): AI2-THOR's counter
    top has the sink cut out of it, but a box cannot, and a counter slab over the basin hides all in it."""
    above = dataclasses.replace(basin.copy(), lo=[basin.lo[0], basin.hi[1], basin.lo[2]])
    above.hi[1] = basin.hi[1] + RIM_SLAB_M
    for piece in list(b.pieces):
        if piece is not basin and piece.overlaps(above) and not _cut(piece, above):
            b.dropped.append(f"{piece.object_id}: covers the basin {basin.object_id}")
            b.pieces.remove(piece)


def _planned_spots(b: _Build) -> list[ReceptacleSpot]:
    """Receptacles of types the floor plan does not list that the trajectory's plan acts on (a sink, a
    drawer), at the plan's position, used from the nearest reachable point; fixtures with their own rule are
    left to it."""
    listed = [(s.object_type, s.position) for s in b.plan.receptacles]
    spots: list[ReceptacleSpot] = []
    for kind, (x, y, z) in b.scene.planned:
        info = b.ontology.get(kind) if kind in b.ontology else None
        if info is None or not info.receptacle or info.pickupable or kind in _FIXTURE_RULES:
            continue
        if any(t == kind for t, _ in listed):
            continue  # floor plans list all receptacles of a type or none (the plan's point is a box centre)
        fixture = {"SinkBasin": "Sink", "BathtubBasin": "Bathtub"}.get(kind, kind)
        object_id = make_object_id(fixture, (x, y, z)) + (f"|{kind}" if fixture != kind else "")
        nearest = b.reachable[int(np.argmin(np.hypot(b.reachable[:, 0] - x, b.reachable[:, 1] - z)))]
        yaw = _facing(
            float(nearest[0]), float(nearest[1]), np.array([[x, z]]), (x - nearest[0], z - nearest[1])
        )
        pose = InteractionPose(float(nearest[0]), float(nearest[1]), yaw, 30.0)
        spots.append(ReceptacleSpot(object_id, kind, fixture, (x, y, z), pose))
        listed.append((kind, (x, y, z)))
    return spots


def _surface_pieces(b: _Build) -> tuple[list[_Piece], dict[str, float]]:
    """Every receptacle of the floor plan as a piece with a footprint; surfaces' tops by id."""
    nominal = _nominal_pieces(b)
    pieces: list[_Piece] = []
    tops: dict[str, float] = {}
    for spot in b.plan.receptacles:
        box, _, _ = nominal[spot.object_id]
        facing = box.facing
        if spot.fixture_type in ("Sink", "Bathtub"):
            pieces.append(_basin_piece(spot, b, facing))
            continue
        w, h, d = b.size_of(spot.object_type)
        if spot.object_type == "Cabinet" and spot.position[1] >= UPPER_UNIT_MIN_Y_M:
            d = b.catalog.counter.upper_cabinet_depth_m
        piece = _make_piece(spot, b, facing, w, d)
        if b.catalog.placement(spot.object_type) == "on":
            tops[spot.object_id] = _grow_surface(piece, spot, b, nominal)
        pieces.append(piece)
    return pieces, tops


def _content_heights(b: _Build, piece: _Piece) -> list[float]:
    """ALFRED heights of the object poses over a piece's footprint."""
    return [p.position[1] for p in b.scene.object_poses if piece.contains_xz(p.position[0], p.position[2])]


def _stack_columns(units: list[_Piece]) -> list[list[_Piece]]:
    """Cabinets and drawers whose footprints mostly coincide, as columns (union-find over the pairs)."""
    root = list(range(len(units)))

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for i, a in enumerate(units):
        for j in range(i + 1, len(units)):
            c = units[j]
            if a.xz_overlap_area(c) >= COLUMN_OVERLAP * min(a.area, c.area):
                root[find(i)] = find(j)
    groups: dict[int, list[_Piece]] = collections.defaultdict(list)
    for i, unit in enumerate(units):
        groups[find(i)].append(unit)
    return [sorted(g, key=lambda p: (p.pivot[1], p.object_id)) for _, g in sorted(groups.items())]


def _vertical_structure(b: _Build, pieces: list[_Piece], tops: dict[str, float]) -> None:
    """Heights: surfaces at their tops (slabs over units, blocks otherwise), unit columns from the floor up to
    the surface above them, upper units on the wall, appliances on the surface under them."""
    surfaces = [p for p in pieces if p.object_id in tops]
    units = [p for p in pieces if p.object_type in _STACKED and p.pivot[1] < UPPER_UNIT_MIN_Y_M]
    caps = _unit_caps(b, units, surfaces, tops)
    slabbed = {oid for over in caps.values() for oid in over}
    kinds = {s.object_id: s.object_type for s in surfaces}
    for s in surfaces:
        top = min(tops[s.object_id], MAX_TOP_M)
        s.hi[1], s.top_fixed = top, True
        slab = s.object_id in slabbed or s.object_type == "Shelf"
        s.lo[1] = top - _slab_thickness(b, s.object_type) if slab else 0.0
        if s.object_type == "Shelf" and s.lo[1] > PIVOT_AT_BASE_MAX_M:
            s.mount = "wall"
        elif s.object_type == "Shelf":
            s.lo[1] = 0.0  # the bottom shelf of a stand is the stand
    for column in _stack_columns(units):
        bottom = 0.0
        for i, unit in enumerate(column):
            if i + 1 < len(column):
                top = (unit.pivot[1] + column[i + 1].pivot[1]) / 2
            elif unit.object_id in caps:
                low = min(caps[unit.object_id], key=lambda oid: (tops[oid], oid))
                top = tops[low] - _slab_thickness(b, kinds[low])
                unit.top_fixed = True
            else:
                top = unit.pivot[1] + b.size_of(unit.object_type)[1] / 2
            unit.lo[1], unit.hi[1] = bottom, max(top, bottom + MIN_HEIGHT_M)
            bottom = unit.hi[1]
    for p in pieces:
        if p not in surfaces and p not in units and p.object_id not in b.decks:
            _own_height(b, p)
    for p in pieces:
        _rest_on_surface(p, surfaces)


def _unit_caps(
    b: _Build, units: list[_Piece], surfaces: list[_Piece], tops: dict[str, float]
) -> dict[str, list[str]]:
    """unit id -> ids of the surfaces whose body it is in (mostly under it, top above the unit's id); each
    such surface's top is raised to clear the unit."""
    caps: dict[str, list[str]] = {}
    for unit in units:
        over = [
            s
            for s in surfaces
            if tops[s.object_id] + UNDER_TOP_MARGIN_M > unit.pivot[1]
            and s.xz_overlap_area(unit) >= UNDER_OVERLAP * unit.area
            and s.object_type != "Shelf"
        ]
        for s in over:
            need = unit.pivot[1] + b.size_of(unit.object_type)[1] / 2 + _slab_thickness(b, s.object_type)
            tops[s.object_id] = max(tops[s.object_id], need)
        if over:
            caps[unit.object_id] = sorted(s.object_id for s in over)
    return caps


def _own_height(b: _Build, piece: _Piece) -> None:
    """Pieces that are neither surfaces nor stacked units: upper cabinets on the wall below their ids, fridges
    tall enough for what ALFRED put in them, the rest from their ids' height (on the floor or mounted)."""
    kind, y = piece.object_type, piece.pivot[1]
    h = b.size_of(kind)[1]
    if kind == "Cabinet":
        piece.lo[1] = y - UPPER_CABINET_BELOW_PIVOT_M
        piece.hi[1] = min(piece.lo[1] + b.catalog.counter.upper_cabinet_height_m, MAX_TOP_M)
        piece.mount = "wall"
    elif kind == "Fridge":
        contents = [c + FRIDGE_HEADROOM_M for c in _content_heights(b, piece)]
        piece.lo[1], piece.hi[1] = 0.0, min(max([h, *contents]), MAX_TOP_M)
    else:
        base = y if y > PIVOT_AT_BASE_MAX_M else 0.0
        piece.lo[1], piece.hi[1] = base, base + h
        if base > 0 and b.catalog.wall_mountable(kind):
            piece.mount = "wall"


def _slab_thickness(b: _Build, object_type: str) -> float:
    return b.size_of(object_type)[1] if object_type in _SLAB_TYPES else SLAB_M


def _rest_on_surface(piece: _Piece, surfaces: list[_Piece]) -> None:
    """A piece whose base is just above a surface's top rests on that surface (a microwave on a counter)."""
    if piece.lo[1] <= EPS_M or piece.top_fixed or piece.object_type in _STACKED:
        return
    under = [
        s
        for s in surfaces
        if s is not piece and s.overlaps_xz(piece) and -REST_SINK_M <= piece.lo[1] - s.hi[1] <= REST_SNAP_M
    ]
    if under:
        top = max(s.hi[1] for s in under)
        height = piece.hi[1] - piece.lo[1]
        piece.lo[1], piece.hi[1] = top, top + height
        piece.mount = "floor"


# ------------------------------------------------------------------------------------------- resolution


def _priority(piece: _Piece) -> tuple[int, float, str]:
    """Who keeps its box when two overlap: fixed-shape fixtures, then units, then surfaces small to large."""
    return _KEEPS_ITS_BOX.get(piece.object_type, 4), piece.area, piece.object_id


def _volume(piece: _Piece) -> float:
    return math.prod(max(b - a, 0.0) for a, b in zip(piece.lo, piece.hi, strict=True))


def _share(piece: _Piece, other: _Piece) -> bool:
    """Split the space two pieces both claim at the midpoint between their ids' positions (AI2-THOR's double
    cabinets have their two ids a few centimetres apart, one door each way), along the axis where both keep
    the most; only if both keep at least SHARE_MIN_KEPT of their extent."""
    best: tuple[float, int, float] | None = None
    for axis in (0, 2):
        a, c = piece.pivot[axis], other.pivot[axis]
        if abs(a - c) < 2 * CUT_MARGIN_M:
            continue
        lo, hi = max(piece.lo[axis], other.lo[axis]), min(piece.hi[axis], other.hi[axis])
        m = min(max((a + c) / 2, lo), hi)
        kept_mine = (m - piece.lo[axis]) if a < c else (piece.hi[axis] - m)
        kept_theirs = (other.hi[axis] - m) if a < c else (m - other.lo[axis])
        if min(kept_mine, kept_theirs) < MIN_SIDE_M:
            continue
        kept = min(
            kept_mine / (piece.hi[axis] - piece.lo[axis]), kept_theirs / (other.hi[axis] - other.lo[axis])
        )
        if kept >= SHARE_MIN_KEPT and (best is None or kept > best[0]):
            best = (kept, axis, m)
    if best is None:
        return False
    _, axis, m = best
    if piece.pivot[axis] < other.pivot[axis]:
        piece.hi[axis], other.lo[axis] = m, m
    else:
        piece.lo[axis], other.hi[axis] = m, m
    return True


def _in_view_of_pose(piece: _Piece, b: _Build) -> None:
    """Put a piece that has no room at its id's position straight ahead of where ALFRED's planner stands to
    use it, at its catalog size, facing the planner (an L-shaped counter's id may lie off the counter)."""
    w, _, d = b.size_of(piece.object_type)
    if piece.seen_from is None:
        x, z, facing = piece.pivot[0], piece.pivot[2], piece.facing
    else:
        px, pz, rotation = piece.seen_from
        dx, dz = _DIRECTIONS[rotation]
        gap = FURNITURE_CLEARANCE_M + d / 2 + CUT_MARGIN_M
        x, z, facing = px + dx * gap, pz + dz * gap, (rotation + 180) % 360
    lo, hi = _footprint(x, z, w, d, facing)
    piece.lo[0], piece.lo[2], piece.hi[0], piece.hi[2] = lo[0], lo[2], hi[0], hi[2]
    piece.facing = facing
    if piece.top_fixed and b.catalog.placement(piece.object_type) == "on":
        piece.lo[1] = piece.hi[1] - _slab_thickness(b, piece.object_type)  # over whatever units stand there


def _lift(upper: _Piece, lower: _Piece) -> bool:
    """Stand ``upper`` on ``lower`` when ``lower`` sits inside its footprint and below its top (a bunk bed's
    upper bunk on the lower one)."""
    if not lower.pivot[1] < upper.pivot[1] or upper.hi[1] - lower.hi[1] < MIN_HEIGHT_M:
        return False
    upper.lo[1] = lower.hi[1]
    return True


def _resolve(b: _Build, pieces: list[_Piece]) -> list[_Piece]:
    """Clearance from the walkway, then overlaps: cut from the later piece, or shared with the earlier one
    when cutting would leave the later one less than SHARE_MIN_KEPT, or the earlier stood on the later (a
    bunk), or the later moved; hopeless pieces are dropped."""
    placed: list[_Piece] = []
    for piece in sorted(pieces, key=_priority):
        if piece.lo[1] < BLOCKING_BELOW_M:
            _retreat(piece, b.reachable, FURNITURE_CLEARANCE_M)
            if not _clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
                _in_view_of_pose(piece, b)
                if not _clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
                    b.dropped.append(f"{piece.object_id}: no room beside the walkway")
                    continue
        for _ in range(MAX_CLASHES):
            clash = next((q for q in placed if piece.overlaps(q)), None)
            if clash is None:
                break
            trial = piece.copy()
            cut_ok = _cut(trial, clash)
            if cut_ok and _volume(trial) >= SHARE_MIN_KEPT * _volume(piece):
                piece.lo, piece.hi = trial.lo, trial.hi
            elif _share(piece, clash):
                continue
            elif cut_ok:
                piece.lo, piece.hi = trial.lo, trial.hi
            elif not _lift(clash, piece):
                break
        if any(piece.overlaps(q) for q in placed) and not _relocate(piece, placed, b.reachable):
            b.dropped.append(f"{piece.object_id}: overlaps what was placed before")
            continue
        placed.append(piece)
    return placed


def _relocate(piece: _Piece, placed: list[_Piece], points: np.ndarray) -> bool:
    """Move a piece that neither a cut nor a share could fit to the nearest free spot within RELOCATE_M
    (a garbage can inside the vanity it stood beside, the second door of a double cabinet)."""
    if not placed:
        return True
    lo = np.array([q.lo for q in placed])  # [N, 3]
    hi = np.array([q.hi for q in placed])  # [N, 3]
    n = int(RELOCATE_M / SEARCH_STEP_M)
    offsets = sorted(
        ((i, k) for i in range(-n, n + 1) for k in range(-n, n + 1)),
        key=lambda ik: (ik[0] ** 2 + ik[1] ** 2, ik),
    )
    for i, k in offsets:
        shift = np.array([i * SEARCH_STEP_M, 0.0, k * SEARCH_STEP_M])
        p_lo, p_hi = np.array(piece.lo) + shift, np.array(piece.hi) + shift
        overlap = np.minimum(hi, p_hi) - np.maximum(lo, p_lo)  # [N, 3]
        if (overlap > EPS_M).all(axis=1).any():
            continue
        if p_lo[1] < BLOCKING_BELOW_M and len(
            _violators(list(p_lo), list(p_hi), points, FURNITURE_CLEARANCE_M)
        ):
            continue
        piece.lo, piece.hi = [float(v) for v in p_lo], [float(v) for v in p_hi]
        return True
    return False


def _supported(piece: _Piece, others: Iterable[_Piece], world: World | None = None) -> bool:
    """The world checks' support rule for one piece: on the floor, resting on another piece's top, held by
    the side of the furniture it touches (a stove knob), or hung on a wall (given the room to tell)."""
    if piece.lo[1] <= EPS_M:
        return True
    catalog = load_catalog()
    mountable = world is not None and catalog.wall_mountable(piece.object_type)
    if mountable and on_wall(world, tuple(piece.lo), tuple(piece.hi)):  # type: ignore[arg-type]
        return True
    side = catalog.side_attached(piece.object_type)
    for o in others:
        if o is piece:
            continue
        if abs(piece.lo[1] - o.hi[1]) <= EPS_M and piece.overlaps_xz(o):
            return True
        if side and _flush_beside(piece, o):
            return True
    return False


def _flush_beside(a: _Piece, b: _Piece) -> bool:
    """Faces touching along x or z, with the boxes overlapping in height and along the touching face."""
    if min(a.hi[1], b.hi[1]) - max(a.lo[1], b.lo[1]) <= EPS_M:
        return False
    for axis, other in ((0, 2), (2, 0)):
        touching = abs(a.lo[axis] - b.hi[axis]) <= EPS_M or abs(a.hi[axis] - b.lo[axis]) <= EPS_M
        if touching and min(a.hi[other], b.hi[other]) - max(a.lo[other], b.lo[other]) > EPS_M:
            return True
    return False


def _highest_top_below(piece: _Piece, pieces: Iterable[_Piece]) -> float:
    """The top of the highest piece under ``piece``'s footprint and not above its base, else the floor."""
    tops = [
        o.hi[1] for o in pieces if o is not piece and o.overlaps_xz(piece) and o.hi[1] <= piece.lo[1] + EPS_M
    ]
    return max(tops, default=0.0)


def _settle(b: _Build) -> None:
    """Floor pieces left hanging are extended down onto the highest thing under them, or the floor."""
    for piece in sorted(b.pieces, key=lambda p: (p.lo[1], p.object_id)):
        if piece.mount == "wall" or _supported(piece, b.pieces):
            continue
        piece.lo[1] = _highest_top_below(piece, b.pieces)


def _counter_segments(b: _Build) -> None:
    """AI2-THOR's counter tops are single objects that run along several walls (L- and U-shaped); a box can
    only be one straight run. Objects ALFRED leaves at counter height where no piece reaches up to them (over
    the floor, or over base units lower than the counter) get a CounterTop segment under them (each cluster of
    them one segment, as high as the counter nearest in height, lying on a base unit under it, cut back from
    anything else there)."""
    tops = [c.hi[1] for c in b.of_type("CounterTop")]
    if not tops:
        return
    clusters: list[list[tuple[float, float, float, float]]] = []
    for pose in sorted(b.scene.object_poses, key=lambda p: p.object_name):
        x, y, z = pose.position
        top = min(tops, key=lambda t: abs(t - y))
        if not (
            top - REST_GAP_M <= y <= top + TOP_BAND_ABOVE_M and b.ontology.get(pose.object_type).pickupable
        ):
            continue
        height = b.size_of(pose.object_type)[1]
        if any(
            p.contains_xz(x, z, SURFACE_MARGIN_M)
            and (p.object_id in b.decks or p.lo[1] <= y <= p.hi[1] + height + PIVOT_SLACK_M)
            for p in b.pieces
        ):
            continue  # a sink, or a piece reaching up to it, holds it (a wall cabinet above does not)
        half = max(b.size_of(pose.object_type)[0], b.size_of(pose.object_type)[2]) / 2 + SURFACE_MARGIN_M
        home = next(
            (c for c in clusters if any(math.hypot(x - cx, z - cz) <= SEGMENT_JOIN_M for cx, cz, _, _ in c)),
            None,
        )
        if home is None:
            clusters.append([(x, z, half, top)])
        else:
            home.append((x, z, half, top))
    for cluster in clusters:
        lo = [min(x - h for x, _, h, _ in cluster), 0.0, min(z - h for _, z, h, _ in cluster)]
        hi = [
            max(x + h for x, _, h, _ in cluster),
            min(t for *_, t in cluster),
            max(z + h for _, z, h, _ in cluster),
        ]
        centre = ((lo[0] + hi[0]) / 2, hi[1], (lo[2] + hi[2]) / 2)
        facing = _facing(centre[0], centre[2], b.reachable, (0.0, 0.0))
        piece = _Piece(
            make_object_id("CounterTop", centre),
            "CounterTop",
            lo,
            hi,
            facing,
            "floor",
            centre,
            top_fixed=True,
        )
        if not _clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
            continue
        for _ in range(MAX_CLASHES):
            clash = next((q for q in b.pieces if piece.overlaps(q)), None)
            if clash is not None and clash.object_id not in b.decks and clash.hi[1] <= piece.hi[1] - SLAB_M:
                piece.lo[1] = max(piece.lo[1], clash.hi[1])  # the counter top lies on the base unit
            elif clash is None or not _cut(piece, clash):
                break
        if not any(piece.overlaps(q) for q in b.pieces) and piece.hi[1] - piece.lo[1] >= SLAB_M:
            b.pieces.append(piece)


def _keep_walkway_clear(b: _Build) -> None:
    """Pieces lowered since the walkway was cleared (a loft bed stood on the dresser under it) are trimmed
    away from it too, or dropped."""
    for piece in list(b.pieces):
        if piece.lo[1] >= BLOCKING_BELOW_M:
            continue
        if len(_violators(piece.lo, piece.hi, b.reachable, FURNITURE_CLEARANCE_M)) and not _clip(
            piece, b.reachable, FURNITURE_CLEARANCE_M
        ):
            b.pieces.remove(piece)
            b.dropped.append(f"{piece.object_id}: no room beside the walkway")


def _advance(b: _Build) -> None:
    """Bring each floor piece's front up to AGENT_RADIUS_M from the walkway (by MAX_ADVANCE_M at most): the
    floor plan says nothing stands between, and a gap would be floor the agent could walk on (it becomes a
    wall before the piece, hiding what is on or in it). Rigid pieces (fridges, sinks, tubs) move instead of
    stretching, and may slide sideways by up to MAX_SLIDE_M to do it: an AI2-THOR id's position is the
    object's pivot, not its centre. Other pieces held back by a neighbour at one end (a side table at the
    bed's head) may give up that end, keeping their pivot and at least MIN_KEPT_ALONG of their length."""
    for piece in sorted(b.pieces, key=_priority):
        if piece.lo[1] >= BLOCKING_BELOW_M or piece.mount == "wall":
            continue
        fx, fz = _DIRECTIONS[piece.facing]
        axis, sign = (0, fx) if fx else (2, fz)
        side = 2 - axis
        rigid = _priority(piece)[0] == 0
        spans = _slid_spans(piece, side) if rigid else _trimmed_spans(b, piece, axis, sign)
        feasible = [
            (gain, span[1] - span[0], -abs(span[0] - piece.lo[side]), span)
            for span in spans
            if (gain := _advance_room(b, piece, axis, sign, span)) is not None
        ]
        gain, _, _, span = max(feasible)  # the piece's own span is always feasible
        if gain <= 0.0:
            continue
        piece.lo[side], piece.hi[side] = span
        if rigid:
            piece.lo[axis] += sign * gain
            piece.hi[axis] += sign * gain
        elif sign > 0:
            piece.hi[axis] += gain
        else:
            piece.lo[axis] -= gain


def _slid_spans(piece: _Piece, side: int) -> list[tuple[float, float]]:
    """The piece's extent along ``side``, and that extent slid by every step up to MAX_SLIDE_M."""
    return [(piece.lo[side] + slide, piece.hi[side] + slide) for slide in _SLIDES]


def _trimmed_spans(b: _Build, piece: _Piece, axis: int, sign: int) -> list[tuple[float, float]]:
    """The piece's extent along the other axis, and that extent cut back from a neighbour standing in front
    of one of its ends (keeping the pivot and MIN_KEPT_ALONG of the length)."""
    side = 2 - axis
    lo, hi = piece.lo[side], piece.hi[side]
    spans = [(lo, hi)]
    ahead_lo, ahead_hi = list(piece.lo), list(piece.hi)
    front = piece.hi[axis] if sign > 0 else piece.lo[axis]
    ahead_lo[axis], ahead_hi[axis] = sorted((front, front + sign * MAX_ADVANCE_M))
    ahead = _Piece("", "", ahead_lo, ahead_hi, 0, "floor", piece.pivot)
    pivot = piece.pivot[side]
    for other in b.pieces:
        if other is piece or not ahead.overlaps(other):
            continue
        for cut in ((other.hi[side], hi), (lo, other.lo[side])):
            if cut[0] <= pivot <= cut[1] and cut[1] - cut[0] >= MIN_KEPT_ALONG * (hi - lo):
                spans.append(cut)
    return spans


def _advance_room(b: _Build, piece: _Piece, axis: int, sign: int, span: tuple[float, float]) -> float | None:
    """How far the piece's front can come forward (metres, ≥ 0) with its extent along the other axis set to
    ``span``; None if that extent is not free (it would overlap a piece or crowd a walkway point)."""
    side = 2 - axis
    lo, hi = list(piece.lo), list(piece.hi)
    lo[side], hi[side] = span
    if lo[side] < piece.lo[side] - EPS_M or hi[side] > piece.hi[side] + EPS_M:  # it slid onto new ground
        moved = _Piece("", "", lo, hi, 0, "floor", piece.pivot)
        if len(_violators(lo, hi, b.reachable, CLEARANCE_M)) or any(
            moved.overlaps(o) for o in b.pieces if o is not piece
        ):
            return None
    front = hi[axis] if sign > 0 else lo[axis]
    if sign > 0:
        hi[axis] = front + MAX_ADVANCE_M
    else:
        lo[axis] = front - MAX_ADVANCE_M
    limit = front + sign * MAX_ADVANCE_M
    bad = _frontal_violators(lo, hi, axis, b.reachable)
    if len(bad):
        coord = bad[:, axis // 2]
        near = (coord.min() - FURNITURE_CLEARANCE_M) if sign > 0 else (coord.max() + FURNITURE_CLEARANCE_M)
        limit = min(limit, near - CUT_MARGIN_M) if sign > 0 else max(limit, near + CUT_MARGIN_M)
    probe = _Piece("", "", lo, hi, 0, "floor", piece.pivot)
    for other in b.pieces:
        if other is not piece and probe.overlaps(other):
            edge = other.lo[axis] if sign > 0 else other.hi[axis]
            limit = min(limit, edge) if sign > 0 else max(limit, edge)
    return max((limit - front) * sign, 0.0)


# ------------------------------------------------------------------------------------------------ fixtures


def _free(b: _Build, lo: list[float], hi: list[float], clearance: float | None) -> bool:
    """The box overlaps no piece and, if it is low enough to block, keeps ``clearance`` from the walkway."""
    probe = _Piece("", "", lo, hi, 0, "floor", (0.0, 0.0, 0.0))
    if any(probe.overlaps(p) for p in b.pieces):
        return False
    if clearance is None or lo[1] >= BLOCKING_BELOW_M:
        return True
    return not len(_violators(lo, hi, b.reachable, clearance))


def _hint(
    b: _Build, fixture: str, accepted_by: str | None = None, types: Iterable[str] = ()
) -> tuple[float, float] | None:
    """Where a fixture should stand: where the trajectory's plan acts on one, else the mean (x, z) of the
    poses that suggest it (objects only it would hold, or objects of ``types``)."""
    planned = [(x, z) for kind, (x, _, z) in b.scene.planned if kind == fixture]
    if planned:
        return planned[0]
    wanted = set(types)
    xs = []
    for pose in b.scene.object_poses:
        if pose.object_type in wanted or (
            accepted_by is not None
            and b.ontology.accepts(accepted_by, pose.object_type)
            and not any(
                p.contains_xz(pose.position[0], pose.position[2], SURFACE_MARGIN_M)
                and b.ontology.accepts(p.object_type, pose.object_type)
                for p in b.pieces
            )
        ):
            xs.append((pose.position[0], pose.position[2]))
    if not xs:
        return None
    return float(np.mean([x for x, _ in xs])), float(np.mean([z for _, z in xs]))


def _by_hint(options: list[tuple[float, float, Any]], hint: tuple[float, float] | None) -> list[Any]:
    """Options (x, z, payload) nearest the hint first; without a hint in their given (deterministic) order."""
    if hint is None:
        return [o for _, _, o in options]
    hx, hz = hint
    order = sorted(range(len(options)), key=lambda i: (math.hypot(options[i][0] - hx, options[i][1] - hz), i))
    return [options[i][2] for i in order]


def _add(b: _Build, object_type: str, lo: list[float], hi: list[float], facing: int, mount: Mount) -> _Piece:
    """A new fixture, named by AI2-THOR's id for where it stands."""
    center = tuple(round((a + c) / 2, 4) for a, c in zip(lo, hi, strict=True))
    piece = _Piece(make_object_id(object_type, center), object_type, lo, hi, facing, mount, center)  # type: ignore[arg-type]
    b.pieces.append(piece)
    return piece


def _place_on_floor(
    b: _Build, object_type: str, hint: tuple[float, float] | None = None, object_id: str | None = None
) -> _Piece | None:
    """Something standing on the floor: at the hint (the plan's position, else the objects only it would hold)
    or the free spot nearest it within RELOCATE_M, facing the walkway; otherwise with its front AGENT_RADIUS_M
    from a cell on the walkway's edge, the spot nearest the hint first."""
    w, h, d = b.size_of(object_type)
    if hint is None:
        hint = _hint(b, object_type, object_type if b.ontology.get(object_type).receptacle else None)
    options: list[tuple[list[float], list[float], int]] = []
    if hint is not None:
        hx, hz = hint
        facing = _facing(hx, hz, b.reachable, (0.0, 0.0))
        n = int(RELOCATE_M / SEARCH_STEP_M)
        steps = sorted(
            ((i, k) for i in range(-n, n + 1) for k in range(-n, n + 1)),
            key=lambda ik: (ik[0] ** 2 + ik[1] ** 2, ik),
        )
        for i, k in steps:
            lo, hi = _footprint(hx + i * SEARCH_STEP_M, hz + k * SEARCH_STEP_M, w, d, facing)
            lo[1], hi[1] = 0.0, h
            options.append((lo, hi, facing))
    reach = {_cell(x, z) for x, z in b.reachable}
    edge: list[tuple[float, float, tuple[list[float], list[float], int]]] = []
    for x, z in b.reachable:
        i, k = _cell(x, z)
        for yaw, (dx, dz) in _DIRECTIONS.items():
            if (i + dx, k + dz) in reach:
                continue
            gap = FURNITURE_CLEARANCE_M + d / 2
            lo, hi = _footprint(x + dx * gap, z + dz * gap, w, d, (yaw + 180) % 360)
            lo[1], hi[1] = 0.0, h
            edge.append((x, z, (lo, hi, (yaw + 180) % 360)))
    candidates = options + _by_hint(edge, hint)
    if not candidates:
        return None
    lo_all, hi_all = np.array([c[0] for c in candidates]), np.array([c[1] for c in candidates])  # [C, 3]
    ok = _free_boxes(b, lo_all, hi_all)
    idx = np.flatnonzero(ok)
    if len(idx):
        ok[idx] = viewable_from(b.reachable, lo_all[idx], hi_all[idx])
    for i in np.flatnonzero(ok)[:1]:
        lo, hi, facing = candidates[i]
        piece = _add(b, object_type, lo, hi, facing, "floor")
        if object_id is not None:
            piece.object_id = object_id
        return piece
    return None


def _free_boxes(b: _Build, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """[C] bool: boxes lo/hi [C, 3] overlap no piece and keep AGENT_RADIUS_M from the walkway (vectorised
    ``_free`` for the many candidate spots of a floor fixture)."""
    ok = np.ones(len(lo), dtype=bool)
    if b.pieces:
        p_lo = np.array([p.lo for p in b.pieces])  # [P, 3]
        p_hi = np.array([p.hi for p in b.pieces])  # [P, 3]
        overlap = np.minimum(hi[:, None], p_hi[None]) - np.maximum(lo[:, None], p_lo[None])  # [C, P, 3]
        ok &= ~(overlap > EPS_M).all(axis=2).any(axis=1)
    c, pts = FURNITURE_CLEARANCE_M, b.reachable  # [N, 2]
    near = (
        (pts[None, :, 0] > lo[:, None, 0] - c)
        & (pts[None, :, 0] < hi[:, None, 0] + c)
        & (pts[None, :, 1] > lo[:, None, 2] - c)
        & (pts[None, :, 1] < hi[:, None, 2] + c)
    )  # [C, N]
    return ok & ~near.any(axis=1)


def _could_hold(b: _Build, piece: _Piece, pose: ObjectPose) -> bool:
    """Whether the object fits the receptacle the way physics puts things in (upright, turned about y)."""
    if b.catalog.placement(piece.object_type) != "inside":
        return True
    w, h, d = b.size_of(pose.object_type)
    wall = b.catalog.wall_thickness(piece.object_type)
    inner = [hi - lo - 2 * wall for lo, hi in zip(piece.lo, piece.hi, strict=True)]
    spacing = b.catalog.shelf_spacing(piece.object_type) or math.inf
    return (
        h <= min(inner[1], spacing)
        and min(w, d) <= min(inner[0], inner[2])
        and max(w, d) <= max(inner[0], inner[2])
    )


def _place_floor_items(b: _Build) -> None:
    """Objects ALFRED leaves on the floor and over no receptacle (a plunger by the toilet, boots, a ball)."""
    for pose in sorted(b.scene.object_poses, key=lambda p: p.object_name):
        x, y, z = pose.position
        info = b.ontology.get(pose.object_type)
        held = any(
            p.contains_xz(x, z)
            and b.ontology.accepts(p.object_type, pose.object_type)
            and _could_hold(b, p, pose)
            for p in b.pieces
            if b.ontology.get(p.object_type).receptacle
        )
        if info.pickupable and (y >= FLOOR_OBJECT_MAX_Y_M or held):
            continue
        object_id = make_object_id(pose.object_type, pose.position)
        if object_id not in b.floor_items and _place_on_floor(b, pose.object_type, (x, z), object_id):
            b.floor_items.add(object_id)


def _surface_spots(host: _Piece, w: float, d: float, h: float) -> Iterator[tuple[list[float], list[float]]]:
    """Boxes (w along the host's front, d deep) resting on the host's top, backs to its back, along it."""
    dx, dz = _DIRECTIONS[host.facing]
    along = 0 if dx == 0 else 2
    back_axis = 2 if dx == 0 else 0
    sign = dz if dx == 0 else dx
    length = host.hi[along] - host.lo[along]
    depth = host.hi[back_axis] - host.lo[back_axis]
    if w > length or d > depth:
        return
    n = int((length - w) / SEARCH_STEP_M) + 1
    offsets = sorted(range(n), key=lambda i: abs(i - (n - 1) / 2))
    for i in offsets:
        lo, hi = [0.0, host.hi[1], 0.0], [0.0, host.hi[1] + h, 0.0]
        lo[along] = host.lo[along] + i * SEARCH_STEP_M
        hi[along] = lo[along] + w
        if sign > 0:
            lo[back_axis], hi[back_axis] = host.lo[back_axis], host.lo[back_axis] + d
        else:
            lo[back_axis], hi[back_axis] = host.hi[back_axis] - d, host.hi[back_axis]
        yield lo, hi


def _place_on_surface(
    b: _Build,
    object_type: str,
    hosts: list[_Piece],
    hint: tuple[float, float] | None,
    size: Vec3 | None = None,
) -> _Piece | None:
    """A fixture resting on one of ``hosts`` at the back of its top, nearest the hint (else the middle)."""
    w, h, d = size or b.size_of(object_type)
    options = []
    for host in hosts:
        for lo, hi in _surface_spots(host, w, d, h):
            options.append(((lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2, (lo, hi, host.facing)))
    for lo, hi, facing in _by_hint(options, hint):
        if hi[1] <= MAX_TOP_M and _free(b, lo, hi, None) and _in_reach(b.reachable, lo, hi):
            return _add(b, object_type, lo, hi, facing, "floor")
    return None


def _counters(b: _Build) -> list[_Piece]:
    """Counter tops that are slabs or blocks one can set appliances on, largest first."""
    return sorted(b.of_type("CounterTop"), key=lambda p: (-p.area, p.object_id))


def _place_stove(b: _Build) -> None:
    """Burners on a counter where the trajectory's plan uses one (else where its pans and pots sit), four
    sites if the counter is deep enough there and two otherwise, a knob for each on the counter's front."""
    bw, bh, bd = b.size_of("StoveBurner")
    kw, kh, kd = b.size_of("StoveKnob")
    offsets = b.catalog.counter.burner_offsets_m
    unit = b.catalog.counter.stove_width_m
    front_row = min(v for _, v in offsets)
    layouts = [list(offsets), [o for o in offsets if o[1] == front_row]]
    options = []
    for host in _counters(b):
        for sites in layouts:
            depth = max(v for _, v in sites) + bd / 2
            for lo, hi in _surface_spots(host, unit, depth, bh):
                options.append(((lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2, (host, lo, hi, sites)))
    for host, lo, hi, sites in _by_hint(options, _hint(b, "StoveBurner", None, ("Pot", "Pan", "Kettle"))):
        if _try_stove(b, host, lo, hi, sites, (bw, bh, bd), (kw, kh, kd)):
            return


def _try_stove(
    b: _Build,
    host: _Piece,
    lo: list[float],
    hi: list[float],
    sites: list[tuple[float, float]],
    burner: Vec3,
    knob: Vec3,
) -> bool:
    """Burners at the catalog's sites of a stove unit (lo, hi) on ``host``; knobs on the host's front edge,
    left to right in the burners' order, each controlling its burner (AI2-THOR's StoveKnob)."""
    bw, bh, bd = burner
    kw, kh, kd = knob
    fx, fz = _DIRECTIONS[host.facing]
    rx, rz = fz, -fx  # the host's right along its front
    cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
    depth = hi[0] - lo[0] if fx else hi[2] - lo[2]
    width = hi[2] - lo[2] if fx else hi[0] - lo[0]
    back_x, back_z = cx - fx * depth / 2, cz - fz * depth / 2
    burners = []
    for along, from_back in sorted(sites):
        x, z = back_x + rx * along + fx * from_back, back_z + rz * along + fz * from_back
        blo, bhi = _footprint(x, z, bw, bd, host.facing)
        blo[1], bhi[1] = host.hi[1], host.hi[1] + bh
        if not (host.contains_xz(blo[0], blo[2]) and host.contains_xz(bhi[0], bhi[2])):
            return False
        burners.append((blo, bhi))
    front = (host.hi[0] if fx > 0 else host.lo[0]) if fx else (host.hi[2] if fz > 0 else host.lo[2])
    knob_y = host.hi[1] - min(host.hi[1] - host.lo[1], SLAB_M) / 2
    knobs = []
    for i in range(len(burners)):
        along = -width / 2 + width * (i + 1) / (len(burners) + 1)
        x, z = cx + rx * along, cz + rz * along
        if fx:
            x = front + fx * kd / 2
        else:
            z = front + fz * kd / 2
        klo, khi = _footprint(x, z, kw, kd, host.facing)
        klo[1], khi[1] = knob_y - kh / 2, knob_y + kh / 2
        knobs.append((klo, khi))
    if not all(
        _free(b, blo, bhi, THIN_CLEARANCE_M) and _in_reach(b.reachable, blo, bhi)
        for blo, bhi in burners + knobs
    ):
        return False
    made = [_add(b, "StoveBurner", blo, bhi, host.facing, "floor") for blo, bhi in burners]
    for (klo, khi), burner_piece in zip(knobs, made, strict=True):
        _add(b, "StoveKnob", klo, khi, host.facing, "floor").controls = burner_piece.object_id
    return True


def _place_faucets(b: _Build) -> None:
    """A Faucet on each sink's deck behind its basin, running into it (``controls``); where a counter covers
    the deck, on the counter right behind the basin."""
    w, h, d = b.size_of("Faucet")
    ids = {p.object_id for p in b.pieces}
    for deck in b.of_type("Sink"):
        basin = next((i for i in sorted(ids) if i.startswith(deck.object_id + "|")), None)
        if basin is None:
            continue
        centre = ((deck.lo[0] + deck.hi[0]) / 2, (deck.lo[2] + deck.hi[2]) / 2)
        covers = sorted(
            (
                p
                for p in b.pieces
                if p.overlaps_xz(deck) and p.lo[1] >= deck.hi[1] - EPS_M and p.mount == "floor"
            ),
            key=lambda p: (p.lo[1], p.object_id),
        )
        for host in [deck, *covers]:
            spot = _place_on_surface(b, "Faucet", [host], centre, (w, h, min(d, _depth(host))))
            if spot is not None:
                spot.controls = basin
                break


def _surfaces_at(b: _Build, hint: tuple[float, float] | None) -> list[_Piece]:
    """The surfaces (tops that hold things) over the point the plan gives for a fixture."""
    if hint is None:
        return []
    return [
        p
        for p in b.pieces
        if p.top_fixed and b.catalog.placement(p.object_type) == "on" and p.contains_xz(*hint)
    ]


def _depth(piece: _Piece) -> float:
    """A piece's extent front to back."""
    fx, _ = _DIRECTIONS[piece.facing]
    return piece.hi[0] - piece.lo[0] if fx else piece.hi[2] - piece.lo[2]


def _place_fixtures(b: _Build, task: Mapping[str, Any]) -> None:
    """The fixtures ALFRED's floor plan lists without positions, each by its rule (module docstring, 2)."""
    listed = b.plan.object_types
    present = {p.object_type for p in b.pieces}
    missing = [t for t in sorted(listed) if t not in present]
    _place_faucets(b)
    if "StoveBurner" in missing:
        _place_stove(b)
    for kind in _COUNTER_FIXTURES:
        if kind in missing:
            hint = _hint(b, kind)
            _place_on_surface(b, kind, _surfaces_at(b, hint) + _counters(b), hint)
    if "DeskLamp" in missing:
        hint = _hint(b, "DeskLamp", None, (str(task.get("object_target", "")),))
        hosts = b.of_type("Desk", "SideTable", "Dresser") or b.of_type(*_STANDING_SURFACES)
        _place_on_surface(
            b, "DeskLamp", _surfaces_at(b, hint) + sorted(hosts, key=lambda p: p.object_id), hint
        )
    if "Television" in missing:
        hint = _hint(b, "Television")
        stands = sorted(b.of_type("TVStand", "Dresser"), key=lambda p: p.object_id)
        _place_on_surface(b, "Television", _surfaces_at(b, hint) + stands, hint)
    for kind in _FLOOR_FIXTURES:
        if kind in missing:
            _place_on_floor(b, kind)
    _place_floor_items(b)


# -------------------------------------------------------------------------------- units above head height


def _cells_under(lo: list[float], hi: list[float]) -> list[tuple[int, int]]:
    """Grid cells (indexed by centre / GRID_STEP_M) a footprint reaches into."""
    return [(i, k) for i in _cell_span(lo[0], hi[0]) for k in _cell_span(lo[2], hi[2])]


def _fit_to_cells(piece: _Piece, allowed: set[tuple[int, int]], supports: list[_Piece] | None = None) -> bool:
    """Trim a footprint to the largest block of whole allowed cells under it (preferring one that keeps its id
    position, and that still overlaps one of ``supports`` if given); False if there is none."""
    xs, zs = _cell_span(piece.lo[0], piece.hi[0]), _cell_span(piece.lo[2], piece.hi[2])
    px, _, pz = piece.pivot
    half = GRID_STEP_M / 2
    best: tuple[bool, float, list[float], list[float]] | None = None
    for i0 in xs:
        for i1 in range(i0, xs[-1] + 1):
            for k0 in zs:
                for k1 in range(k0, zs[-1] + 1):
                    if not all((i, k) in allowed for i in range(i0, i1 + 1) for k in range(k0, k1 + 1)):
                        break
                    lo, hi = list(piece.lo), list(piece.hi)
                    lo[0], hi[0] = max(lo[0], i0 * GRID_STEP_M - half), min(hi[0], i1 * GRID_STEP_M + half)
                    lo[2], hi[2] = max(lo[2], k0 * GRID_STEP_M - half), min(hi[2], k1 * GRID_STEP_M + half)
                    if hi[0] - lo[0] < MIN_SIDE_M or hi[2] - lo[2] < MIN_SIDE_M:
                        continue
                    trial = dataclasses.replace(piece, lo=lo, hi=hi)
                    if supports is not None and not any(trial.overlaps_xz(s) for s in supports):
                        continue
                    key = (lo[0] <= px <= hi[0] and lo[2] <= pz <= hi[2], trial.area)
                    if best is None or key > best[:2]:
                        best = (*key, lo, hi)
    if best is None:
        return False
    piece.lo, piece.hi = best[2], best[3]
    return True


def _over_standing_ground(b: _Build) -> None:
    """Units above head height must hang over the walkway or over furniture: floor under anything else would
    be floor the agent could stand on. Mostly so, they are trimmed to it; otherwise they stand on the floor
    (a shelf nothing stands under becomes a bookcase)."""
    for piece in sorted(b.pieces, key=_priority):
        if piece.lo[1] < BLOCKING_BELOW_M:
            continue
        allowed = {_cell(x, z) for x, z in b.reachable}
        for low in b.pieces:
            if low.lo[1] < BLOCKING_BELOW_M:
                allowed.update(_cells_under(low.lo, low.hi))
        trial = piece.copy()
        if _fit_to_cells(trial, allowed) and trial.area >= MIN_KEPT_FRACTION * piece.area:
            piece.lo, piece.hi = trial.lo, trial.hi
            continue
        piece.mount = "floor"
        piece.lo[1] = _highest_top_below(piece, b.pieces)
        if piece.lo[1] >= BLOCKING_BELOW_M:  # it rests on a tall unit: still over standing ground only
            supports = [o for o in b.pieces if o.overlaps_xz(piece) and abs(o.hi[1] - piece.lo[1]) <= EPS_M]
            fits = _fit_to_cells(piece, allowed, supports)
        else:
            fits = _clip(piece, b.reachable, FURNITURE_CLEARANCE_M)
        if not fits:
            b.pieces.remove(piece)
            b.dropped.append(f"{piece.object_id}: no room beside the walkway")


# ------------------------------------------------------------------------------------------------ the room


def _cell_span(lo: float, hi: float) -> range:
    """Indices of the grid cells (centred on multiples of GRID_STEP_M) that [lo, hi] reaches into."""
    half = GRID_STEP_M / 2
    return range(
        math.floor((lo + EPS_M + half) / GRID_STEP_M), math.floor((hi - EPS_M + half) / GRID_STEP_M) + 1
    )


def _room(b: _Build) -> Room:
    """Floor = the agent's cells and every cell under a piece, with enclosed holes closed."""
    cells = {_cell(x, z) for x, z in b.reachable}
    for p in b.pieces:
        cells.update((i, k) for i in _cell_span(p.lo[0], p.hi[0]) for k in _cell_span(p.lo[2], p.hi[2]))
    i0, k0 = min(i for i, _ in cells), min(k for _, k in cells)
    i1, k1 = max(i for i, _ in cells), max(k for _, k in cells)
    floor = np.zeros((i1 - i0 + 3, k1 - k0 + 3), dtype=bool)  # one empty cell all round
    for i, k in cells:
        floor[i - i0 + 1, k - k0 + 1] = True
    _, labels = cv2.connectedComponents((~floor).astype(np.uint8), connectivity=4)
    floor |= labels != labels[0, 0]
    half = GRID_STEP_M / 2
    top = max((p.hi[1] for p in b.pieces), default=0.0)
    wall_height = max(WALL_HEIGHT_MIN_M, math.ceil((top + CEILING_GAP_M) / 0.05) * 0.05)
    return Room(
        kind=b.plan.kind,
        floor=floor,
        origin=((i0 - 1) * GRID_STEP_M - half, (k0 - 1) * GRID_STEP_M - half),
        wall_height=round(wall_height, 4),
    )


def _touched(room: Room, objects: Iterable[WorldObject]) -> np.ndarray:
    """bool [NX, NZ]: cells some object's footprint reaches into."""
    mask = np.zeros(room.shape, dtype=bool)
    for o in objects:
        (x0, _, z0), (x1, _, z1) = o.min_corner, o.max_corner
        ix0, iz0 = room.cell_of(x0 + EPS_M, z0 + EPS_M)
        ix1, iz1 = room.cell_of(x1 - EPS_M, z1 - EPS_M)
        mask[max(ix0, 0) : ix1 + 1, max(iz0, 0) : iz1 + 1] = True
    return mask


def _wanted_mask(room: Room, points: np.ndarray) -> np.ndarray:
    """bool [NX, NZ]: the cells of the agent's reachable points."""
    mask = np.zeros(room.shape, dtype=bool)
    for x, z in points:
        ix, iz = room.cell_of(x, z)
        mask[ix, iz] = True
    return mask


def _plug(world: World, points: np.ndarray, standing: list[WorldObject]) -> np.ndarray:
    """Cells the agent could stand on that ALFRED's grid does not list and nothing stands on leave the floor
    (on the room's edge the wall comes up to the walkway, as AI2-THOR's walls do; inside it they become
    pillars where AI2-THOR has furniture the data does not place); then any part of the floor this cut off
    from the walkway is joined back by the fewest cells. Returns the joining cells the agent can stand on,
    which the walkway then includes."""
    probe = World(
        world.name, world.room, {o.object_id: o for o in standing}, world.agent
    )  # high ones block nothing
    wanted = _wanted_mask(world.room, points)
    free = reachable_grid(probe) & ~wanted & ~_touched(world.room, standing)
    floor = world.room.floor
    floor &= ~free
    everywhere = dataclasses.replace(world.room, floor=np.ones_like(floor))
    walkable = reachable_grid(World(world.name, everywhere, probe.objects, world.agent))
    _, labels = cv2.connectedComponents(floor.astype(np.uint8), connectivity=4)
    joined: list[tuple[float, float]] = []
    for label in sorted(set(np.unique(labels[floor]).tolist()) - set(np.unique(labels[wanted]).tolist())):
        for cell in _floor_path(floor, wanted, labels == label, walkable):
            floor[cell] = True
            if walkable[cell]:
                joined.append(world.room.cell_center(*cell))
    return np.array(joined, dtype=np.float64).reshape(-1, 2)  # [J, 2] new cells the agent can walk on


def _floor_path(
    floor: np.ndarray, source: np.ndarray, target: np.ndarray, walkable: np.ndarray
) -> list[tuple[int, int]]:
    """Fewest non-floor cells joining ``source`` to ``target`` (0-1 breadth-first: ``source`` cells are free).

    The path leaves the walkway, crosses new cells and ends in the target; a new cell the agent could stand on
    (``walkable``) is only entered from another, so none of them ends up cut off from the walkway."""
    NX, NZ = floor.shape
    cost = np.full(floor.shape, np.iinfo(np.int32).max, dtype=np.int64)
    parent: dict[tuple[int, int], tuple[int, int]] = {}
    queue: collections.deque[tuple[int, int]] = collections.deque()
    for ix, iz in zip(*np.nonzero(source), strict=True):
        cost[ix, iz] = 0
        queue.append((int(ix), int(iz)))
    while queue:
        ix, iz = queue.popleft()
        if target[ix, iz]:
            path = []
            cell = (ix, iz)
            while cell in parent:
                if not floor[cell]:
                    path.append(cell)
                cell = parent[cell]
            return path
        for nx, nz in ((ix + 1, iz), (ix - 1, iz), (ix, iz + 1), (ix, iz - 1)):
            if not (0 <= nx < NX and 0 <= nz < NZ) or (
                floor[nx, nz] and not (source[nx, nz] or target[nx, nz])
            ):
                continue  # through the walkway and new cells only, so the new cells join the walkway
            if walkable[nx, nz] and not walkable[ix, iz]:
                continue
            step = 0 if floor[nx, nz] else 1
            if cost[ix, iz] + step < cost[nx, nz]:
                cost[nx, nz] = cost[ix, iz] + step
                parent[(nx, nz)] = (ix, iz)
                if step:
                    queue.append((nx, nz))
                else:
                    queue.appendleft((nx, nz))
    return []


def _on_floor(room: Room, lo: list[float], hi: list[float]) -> bool:
    """Whether a footprint lies over floor cells only (the world checks' bounds rule)."""
    ix0, iz0 = room.cell_of(lo[0] + EPS_M, lo[2] + EPS_M)
    ix1, iz1 = room.cell_of(hi[0] - EPS_M, hi[2] - EPS_M)
    NX, NZ = room.shape
    return (
        ix0 >= 0
        and iz0 >= 0
        and ix1 < NX
        and iz1 < NZ
        and bool(room.floor[ix0 : ix1 + 1, iz0 : iz1 + 1].all())
    )


def _snap_to_wall(b: _Build, world: World, piece: _Piece) -> bool:
    """Stretch a wall unit's back onto the wall behind it (AI2-THOR's upper cabinets and shelves hang so)."""
    fx, fz = _DIRECTIONS[piece.facing]
    axis, sign = (0, -fx) if fx else (2, -fz)
    origin = world.room.origin[0] if axis == 0 else world.room.origin[1]
    back = piece.hi[axis] if sign > 0 else piece.lo[axis]
    depth = piece.hi[axis] - piece.lo[axis]
    thin = depth < MIN_SIDE_M
    others = [p for p in b.pieces if p is not piece]
    steps = int(WALL_SNAP_MAX_M / GRID_STEP_M) + 2
    first = (math.ceil if sign > 0 else math.floor)((back - sign * EPS_M - origin) / GRID_STEP_M)
    for n in range(steps):
        line = origin + (first + sign * n) * GRID_STEP_M
        if abs(line - back) > WALL_SNAP_MAX_M:
            break
        lo, hi = list(piece.lo), list(piece.hi)
        if thin:  # a towel bar or a switch moves back whole; a cabinet grows back to the wall
            lo[axis], hi[axis] = (line - depth, line) if sign > 0 else (line, line + depth)
        elif sign > 0:
            hi[axis] = line
        else:
            lo[axis] = line
        if hi[axis] - lo[axis] < min(depth, MIN_SIDE_M) or not _on_floor(world.room, lo, hi):
            continue
        probe = _Piece(piece.object_id, piece.object_type, lo, hi, piece.facing, "wall", piece.pivot)
        under = [o for o in others if probe.overlaps(o)]
        if under:  # over a fridge or a tall unit on the way to the wall: sit above it, or stop here
            lo[1] = max(o.hi[1] for o in under)
            if hi[1] - lo[1] < MIN_SIDE_M or any(probe.overlaps(o) for o in others if o.lo[1] >= lo[1]):
                break
            probe.lo = lo
            if any(probe.overlaps(o) for o in others):
                break
        if not on_wall(world, tuple(lo), tuple(hi)):  # type: ignore[arg-type]
            _trim_to_wall(world.room, lo, hi, axis, sign, line, piece.pivot)
        if hi[2 - axis] - lo[2 - axis] >= MIN_SIDE_M and on_wall(world, tuple(lo), tuple(hi)):  # type: ignore[arg-type]
            piece.lo, piece.hi = lo, hi
            return True
    return False


def _trim_to_wall(
    room: Room, lo: list[float], hi: list[float], axis: int, sign: int, line: float, pivot: Vec3
) -> None:
    """Narrow a box whose back is on ``line`` to the stretch where a wall runs behind it all along (the run of
    cells holding its id's position, else the longest); the wall behind a unit can be jagged."""
    side = 2 - axis
    k = round((line - room.origin[axis // 2]) / GRID_STEP_M)
    inside, outside = (k - 1, k) if sign > 0 else (k, k - 1)
    origin = room.origin[side // 2]
    first = math.floor((lo[side] + EPS_M - origin) / GRID_STEP_M)
    last = math.floor((hi[side] - EPS_M - origin) / GRID_STEP_M)
    NX, NZ = room.shape

    def floor_at(i_axis: int, j: int) -> bool:
        ix, iz = (i_axis, j) if axis == 0 else (j, i_axis)
        return 0 <= ix < NX and 0 <= iz < NZ and bool(room.floor[ix, iz])

    good = [floor_at(inside, j) and not floor_at(outside, j) for j in range(first, last + 1)]
    runs: list[tuple[int, int]] = []
    for j, ok in enumerate(good):
        if ok and (not runs or runs[-1][1] != j - 1):
            runs.append((j, j))
        elif ok:
            runs[-1] = (runs[-1][0], j)
    if not runs:
        hi[side] = lo[side]
        return
    home = math.floor((pivot[side] - origin) / GRID_STEP_M) - first
    a, c = max(runs, key=lambda r: (r[0] <= home <= r[1], r[1] - r[0], -r[0]))
    lo[side] = max(lo[side], origin + (first + a) * GRID_STEP_M)
    hi[side] = min(hi[side], origin + (first + c + 1) * GRID_STEP_M)


def _hang_on_walls(b: _Build, world: World) -> None:
    """Wall units flush with a wall; any that cannot reach one stands on what is under it instead. Repeated
    until every piece is held up, since a unit lowered or trimmed may leave what stood on it hanging."""
    for piece in sorted(b.pieces, key=lambda p: p.object_id):
        if piece.mount == "wall" and not _supported(piece, b.pieces, world):
            _snap_to_wall(b, world, piece)
    for _ in range(SUPPORT_ROUNDS):
        hanging = [p for p in b.pieces if not _supported(p, b.pieces, world)]
        for piece in sorted(hanging, key=lambda p: (p.lo[1], p.object_id)):
            piece.mount = "floor"
            piece.lo[1] = _highest_top_below(piece, b.pieces)
            if piece.lo[1] < BLOCKING_BELOW_M and not _clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
                b.pieces.remove(piece)
                b.dropped.append(f"{piece.object_id}: no wall and no room below")
        if not hanging:
            return


def _in_reach(points: np.ndarray, lo: list[float], hi: list[float]) -> bool:
    """The world checks' reach rule (within AI2-THOR's reach cylinder), from the agent's cells."""
    return bool(viewable_from(points, np.array([lo]), np.array([hi]))[0])


def _mount_on_wall(
    b: _Build, world: World, object_type: str, hint: tuple[float, float] | None, below: float = 0.0
) -> _Piece | None:
    """A wall fixture flush with a wall at its mounting height (or at BLOCKING_BELOW_M where the wall is by
    the walkway), with ``below`` metres kept free under it for what hangs from it."""
    w, h, d = b.size_of(object_type)
    default = _MOUNT_BOTTOM_M.get(object_type, 1.2)
    options = []
    for wall in walls_of(world.room):
        n = int((wall.hi - wall.lo - w) / SEARCH_STEP_M) + 1
        for i in range(max(n, 0)):
            pose = wall.pose(wall.lo + i * SEARCH_STEP_M, w, d)
            options.append((pose.cx, pose.cz, (pose.cx, pose.cz, wall.facing)))
    for cx, cz, facing in _by_hint(options, hint):
        for bottom in (default, max(default, BLOCKING_BELOW_M)):
            lo, hi = _footprint(cx, cz, w, d, facing)
            lo[1], hi[1] = bottom, bottom + h
            space = [lo[0], bottom - below, lo[2]], [hi[0], bottom, hi[2]]
            if not on_wall(world, tuple(lo), tuple(hi)) or not _on_floor(world.room, lo, hi):  # type: ignore[arg-type]
                continue
            if not _free(b, lo, hi, THIN_CLEARANCE_M) or (below > 0 and not _free(b, *space, None)):
                continue
            if _in_reach(b.reachable, lo, hi):
                return _add(b, object_type, lo, hi, facing, "wall")
    return None


def _place_wall_fixtures(b: _Build, world: World) -> None:
    """Holders (one per towel ALFRED hangs, at least one if the floor plan lists them), a light switch, and
    a television on a wall if no stand took it."""
    listed = b.plan.object_types
    for holder, hung in sorted(_HANGERS.items()):
        if holder not in listed:
            continue
        poses = [p for p in b.scene.object_poses if p.object_type == hung]
        have = len(b.of_type(holder))
        hints: list[tuple[float, float] | None] = [(p.position[0], p.position[2]) for p in poses]
        if holder == "ToiletPaperHanger":
            hints = [
                _hint(b, holder, None, (hung,))
            ]  # rolls also stand on toilets: one hanger, as AI2-THOR's
        for hint in (hints or [None])[have:]:
            _mount_on_wall(b, world, holder, hint, below=b.size_of(hung)[1])
    if "LightSwitch" in listed:
        _mount_on_wall(b, world, "LightSwitch", None)
    if "Television" in listed and not b.of_type("Television"):
        _mount_on_wall(b, world, "Television", _hint(b, "Television"))


# ------------------------------------------------------------------------------------------------- objects


def _holding_distance(catalog: Catalog, receptacle: WorldObject, point: Vec3) -> float:
    """Metres from an ALFRED position to the volume where ``receptacle`` holds things (0 when inside it)."""
    lo, hi = list(receptacle.min_corner), list(receptacle.max_corner)
    mode = catalog.placement(receptacle.object_type)
    if mode == "on":
        lo[1], hi[1] = receptacle.top, receptacle.top + TOP_BAND_ABOVE_M
    elif mode == "hanging":
        lo[1], hi[1] = receptacle.bottom - 1.0, receptacle.bottom
    else:
        wall = catalog.wall_thickness(receptacle.object_type)
        lo = [v + wall for v in lo]
        hi = [v - wall for v in hi]
    gaps = [max(a - p, 0.0, p - c) for a, c, p in zip(lo, hi, point, strict=True)]
    return math.hypot(*gaps)


def _oriented(size: Vec3, yaw: float) -> Vec3:
    """A catalog size (w along the front, h, d) as extents along x, y, z for an object turned to ``yaw``."""
    w, h, d = size
    return (w, h, d) if round(yaw / 90) % 2 == 0 else (d, h, w)


def _fits(world: World, cells: np.ndarray, center: Vec3, size: Vec3, parent: str | None) -> bool:
    """In reach, over the floor, and clear of everything but the receptacles it is in."""
    lo = [c - s / 2 for c, s in zip(center, size, strict=True)]
    hi = [c + s / 2 for c, s in zip(center, size, strict=True)]
    if not (_on_floor(world.room, lo, hi) and hi[1] <= world.room.wall_height and _in_reach(cells, lo, hi)):
        return False
    holders = set(world.parent_chain(parent)) | {parent} if parent is not None else set()
    others = [o for o in world.objects.values() if o.object_id not in holders]
    if not others:
        return True
    o_lo = np.array([o.min_corner for o in others])  # [N, 3]
    o_hi = np.array([o.max_corner for o in others])  # [N, 3]
    overlap = np.minimum(o_hi, np.array(hi)) - np.maximum(o_lo, np.array(lo))  # [N, 3]
    return not bool((overlap > EPS_M).all(axis=1).any())


def _on_the_floor(b: _Build, world: World, obj: WorldObject, cells: np.ndarray, near: Vec3) -> bool:
    """Put ``obj`` on the floor at the free spot nearest ``near`` (off the walkway, in view of it)."""
    sx, sy, sz = obj.size
    n = int(RELOCATE_M * 2 / SEARCH_STEP_M)
    grid = np.arange(-n, n + 1) * SEARCH_STEP_M
    dx, dz = (a.ravel() for a in np.meshgrid(grid, grid, indexing="ij"))  # [C] each
    order = np.lexsort((dz, dx, dx**2 + dz**2))
    xs, zs = near[0] + dx[order], near[2] + dz[order]  # [C] candidate centres, nearest first
    lo = np.stack([xs - sx / 2, np.zeros_like(xs), zs - sz / 2], axis=1)  # [C, 3]
    hi = np.stack([xs + sx / 2, np.full_like(xs, sy), zs + sz / 2], axis=1)  # [C, 3]
    ok = _rects_on_floor(world.room, lo, hi)
    c = THIN_CLEARANCE_M
    pts = b.reachable  # [N, 2]
    near_walkway = (
        (pts[None, :, 0] > lo[:, None, 0] - c)
        & (pts[None, :, 0] < hi[:, None, 0] + c)
        & (pts[None, :, 1] > lo[:, None, 2] - c)
        & (pts[None, :, 1] < hi[:, None, 2] + c)
    ).any(axis=1)  # [C]
    ok &= ~near_walkway
    if world.objects:
        o_lo = np.array([o.min_corner for o in world.objects.values()])  # [M, 3]
        o_hi = np.array([o.max_corner for o in world.objects.values()])  # [M, 3]
        overlap = np.minimum(hi[:, None], o_hi[None]) - np.maximum(lo[:, None], o_lo[None])  # [C, M, 3]
        ok &= ~(overlap > EPS_M).all(axis=2).any(axis=1)
    for i in np.flatnonzero(ok):
        center = (round(float(xs[i]), 4), round(sy / 2, 4), round(float(zs[i]), 4))
        if _fits(world, cells, center, obj.size, None):
            obj.center, obj.parent_id = center, None
            return _add_object(world, obj)
    return False


def _rects_on_floor(room: Room, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """[C] bool: footprints lo/hi [C, 3] lie over floor cells only (an integral image counts the others)."""
    NX, NZ = room.shape
    holes = np.pad((~room.floor).astype(np.int64), ((1, 0), (1, 0))).cumsum(0).cumsum(1)  # [NX+1, NZ+1]
    ix0 = np.floor((lo[:, 0] + EPS_M - room.origin[0]) / GRID_STEP_M).astype(np.int64)
    iz0 = np.floor((lo[:, 2] + EPS_M - room.origin[1]) / GRID_STEP_M).astype(np.int64)
    ix1 = np.floor((hi[:, 0] - EPS_M - room.origin[0]) / GRID_STEP_M).astype(np.int64)
    iz1 = np.floor((hi[:, 2] - EPS_M - room.origin[1]) / GRID_STEP_M).astype(np.int64)
    inside = (ix0 >= 0) & (iz0 >= 0) & (ix1 < NX) & (iz1 < NZ)
    a0, b0 = np.clip(ix0, 0, NX - 1), np.clip(iz0, 0, NZ - 1)
    a1, b1 = np.clip(ix1, 0, NX - 1) + 1, np.clip(iz1, 0, NZ - 1) + 1
    count = holes[a1, b1] - holes[a0, b1] - holes[a1, b0] + holes[a0, b0]
    return inside & (count == 0)


def _put(world: World, obj: WorldObject, receptacle: WorldObject, cells: np.ndarray, near: Vec3) -> bool:
    """Into or onto ``receptacle`` at the free spot nearest ``near`` (physics' own placement rule), or, if
    that is out of reach, at the free spot nearest the walkway."""
    if load_catalog().placement(receptacle.object_type) == "hanging":  # flat against the wall, like its bar
        sx, sy, sz = obj.size
        wide, thin = max(sx, sz), min(sx, sz)
        obj.size = (wide, sy, thin) if receptacle.facing in (0, 180) else (thin, sy, wide)
    (x0, _, z0), (x1, _, z1) = receptacle.min_corner, receptacle.max_corner
    inside = np.clip(cells, [x0, z0], [x1, z1])  # [M, 2] each cell's nearest point of the footprint
    cx, cz = inside[int(np.argmin(np.hypot(*(inside - cells).T)))] if len(cells) else (near[0], near[2])
    for target in (near, (float(cx), near[1], float(cz))):
        spot = resting_center(world, obj, receptacle, near=target)
        if spot is None:
            return False
        center = tuple(round(v, 4) for v in spot[0])
        if _fits(world, cells, center, spot[1], receptacle.object_id):  # type: ignore[arg-type]
            obj.center, obj.size, obj.parent_id = center, spot[1], receptacle.object_id  # type: ignore[assignment]
            return _add_object(world, obj)
    return False


def _add_object(world: World, obj: WorldObject) -> bool:
    """Add a placed object; a second instance of a pose ALFRED lists twice is named where it landed."""
    if obj.object_id.endswith(_COPY):
        obj.object_id = make_object_id(obj.object_type, obj.center)
        if obj.object_id in world.objects:
            return False
    world.add(obj)
    return True


def _start_state(b: _Build, obj: WorldObject) -> None:
    """ALFRED's dirty_and_empty: every dish dirty and every container empty; otherwise clean (and empty, as
    AI2-THOR's scenes start)."""
    info = b.ontology.get(obj.object_type)
    obj.is_dirty = b.scene.dirty_and_empty and info.dirtyable
    obj.liquid = None


def _place_objects(b: _Build, world: World) -> None:
    """Every ALFRED object pose into or onto the accepting receptacle nearest it, else onto the floor."""
    catalog = b.catalog
    cells = reachable_centres(world, reachable_grid(world))  # [M, 2]
    decks = {deck_id for deck_id, _, _ in b.decks.values()}  # ALFRED puts things in the basin, not on its rim
    order = sorted(
        b.scene.object_poses,
        key=lambda p: (not b.ontology.get(p.object_type).movable_receptacle, p.position[1], p.object_name),
    )
    for pose in order:
        object_id = make_object_id(pose.object_type, pose.position)
        if object_id in b.floor_items:
            _start_state(b, world.objects[object_id])
            continue
        if (
            object_id in world.objects
        ):  # ALFRED lists some poses twice: one more instance, named where it lands
            object_id += _COPY
        size = _oriented(b.size_of(pose.object_type), pose.yaw)
        obj = WorldObject(
            object_id, pose.object_type, pose.position, size, facing=round(pose.yaw / 90) % 4 * 90
        )
        _start_state(b, obj)
        pickupable = b.ontology.get(pose.object_type).pickupable
        hosts = [
            r
            for r in world.objects.values()
            if pickupable
            and r.object_id not in decks
            and b.ontology.get(r.object_type).receptacle
            and b.ontology.accepts(r.object_type, pose.object_type)
        ]
        ranked = sorted(hosts, key=lambda r: (_holding_distance(catalog, r, pose.position), r.object_id))
        nearest = _holding_distance(catalog, ranked[0], pose.position) if ranked else math.inf
        floor_first = pose.position[1] < FLOOR_OBJECT_MAX_Y_M and nearest > SEARCH_STEP_M
        if floor_first and _on_the_floor(b, world, obj, cells, pose.position):
            continue
        if any(_put(world, obj, r, cells, pose.position) for r in ranked):
            continue
        if not _on_the_floor(b, world, obj, cells, pose.position):
            b.dropped.append(f"{object_id}: no place")
    for object_type, on in b.scene.toggles:
        for obj in world.of_type(object_type):
            obj.is_toggled = on


# ------------------------------------------------------------------------------------------------- the API


def _agent(scene: AlfredScene) -> AgentState:
    """ALFRED's start: ``init_action``'s (x, z), its rotation as a yaw, its horizon (within the camera's)."""
    x, z, rotation, horizon = scene.start
    yaw = int(round(rotation / 90.0)) * 90 % 360
    return AgentState(x=x, z=z, yaw=yaw, horizon=min(max(horizon, HORIZON_MIN_DEG), HORIZON_MAX_DEG))


def build_alfred_world(
    traj: Mapping[str, Any], data_dir: Path | None = None
) -> tuple[World, AlfredWorldReport]:
    """The world of one ALFRED trajectory and how it departs from the floor plan (module docstring)."""
    scene = scene_of(traj)
    plan = load_floor_plan(scene.floor_plan, data_dir)
    points = (
        np.array(sorted(_reachable_cells(plan, scene.start[:2])), dtype=np.float64) * GRID_STEP_M
    )  # [M, 2]
    b = _Build(plan, scene, load_catalog(), load_ontology(), points.reshape(-1, 2))
    b.plan = dataclasses.replace(plan, receptacles=plan.receptacles + tuple(_planned_spots(b)))
    _furnish(b, traj.get("pddl_params", {}))
    world = _enclose(b, str(traj.get("task_id") or scene.floor_plan), int(scene.random_seed) % 2**31)
    _place_objects(b, world)
    have = _cells_of(world.room, reachable_grid(world))
    listed = {_cell(x, z) for x, z in plan.reachable}
    report = AlfredWorldReport(
        layout_points=len(listed),
        missing_points=tuple(sorted((i * GRID_STEP_M, k * GRID_STEP_M) for i, k in listed - have)),
        extra_points=tuple(sorted((i * GRID_STEP_M, k * GRID_STEP_M) for i, k in have - listed)),
        dropped=tuple(b.dropped),
    )
    return world, report


def _furnish(b: _Build, task: Mapping[str, Any]) -> None:
    """Steps 1 and 2 of the module docstring: receptacles, then fixtures, as pieces."""
    pieces, tops = _surface_pieces(b)
    _vertical_structure(b, pieces, tops)
    b.pieces = _resolve(b, pieces)
    _settle(b)
    _counter_segments(b)
    _settle(b)
    _keep_walkway_clear(b)
    _settle(b)
    _advance(b)
    _split_decks(b)
    _place_fixtures(b, task)
    _settle(b)
    _over_standing_ground(b)


def _enclose(b: _Build, name: str, seed: int) -> World:
    """Step 3: the room around the pieces, wall units and fixtures on its walls, the pieces as objects."""
    world = World(name, _room(b), {}, _agent(b.scene), seed=seed)
    for hung in (False, True):  # again once wall units have moved: what they no longer cover must go too
        if hung:
            _hang_on_walls(b, world)
            _place_wall_fixtures(b, world)
        joined = _plug(world, b.reachable, [p.to_object() for p in b.pieces])
        b.reachable = np.concatenate([b.reachable, joined])
    _counters_for_pillars(b, world)
    for piece in sorted(b.pieces, key=_priority):
        obj = piece.to_object()
        obj.is_toggled = obj.object_type == "LightSwitch"  # AI2-THOR rooms start lit, everything else off
        world.add(obj)
    return world


def _counters_for_pillars(b: _Build, world: World) -> None:
    """Cells cut off inside the room (pillars) stand where AI2-THOR has furniture the data does not place;
    in kitchens that is counter, so they become counter-height CounterTop blocks instead of walls up to the
    ceiling that hide the microwave or fridge behind them."""
    if b.plan.kind != "kitchen":
        return
    room = world.room
    _, labels = cv2.connectedComponents((~room.floor).astype(np.uint8), connectivity=4)  # [NX, NZ]
    outside = set(np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]])).tolist())
    outside.add(0)  # cv2 labels the floor 0
    tops = [c.hi[1] for c in b.of_type("CounterTop")] or [b.catalog.counter.top_m]
    top = max(tops, key=tops.count)
    half_cell = GRID_STEP_M / 2 + EPS_M
    for label in outside:
        labels[labels == label] = 0
    for ix, iz in np.argwhere(labels > 0):
        x, z = room.cell_center(int(ix), int(iz))
        if any(
            p.mount == "wall"
            and p.lo[0] <= x + half_cell
            and p.hi[0] >= x - half_cell
            and p.lo[2] <= z + half_cell
            and p.hi[2] >= z - half_cell
            for p in b.pieces
        ):
            labels[labels == labels[ix, iz]] = 0  # something hangs on this pillar: it stays
    for ix, iz in np.argwhere(labels > 0):
        room.floor[ix, iz] = True
        x, z = room.cell_center(int(ix), int(iz))
        half = GRID_STEP_M - THIN_CLEARANCE_M  # the cells around stay as walkable as the pillar left them
        lo, hi = [x - half, 0.0, z - half], [x + half, top, z + half]
        centre = (x, top, z)
        b.pieces.append(
            _Piece(make_object_id("CounterTop", centre), "CounterTop", lo, hi, 0, "floor", centre)
        )


def _cells_of(room: Room, mask: np.ndarray) -> set[tuple[int, int]]:
    """The grid cells (indexed by centre / GRID_STEP_M) where a room-shaped mask is True."""
    return {_cell(*room.cell_center(int(i), int(k))) for i, k in np.argwhere(mask)}


def alfred_world(traj: Mapping[str, Any], data_dir: Path | None = None) -> World:
    """The harness world of an ALFRED ``traj_data`` (train or valid_seen), read from the shared data."""
    return build_alfred_world(traj, data_dir)[0]


def alfred_task_world_pairs(
    split: str, limit: int | None = None, data_dir: Path | None = None
) -> Iterator[tuple[dict[str, Any], World, AlfredTask]]:
    """(trajectory, its world, its ALFRED task) for the first ``limit`` trajectories of a split (or all)."""
    for n, traj in enumerate(load_alfred_trajectories(split, data_dir)):
        if limit is not None and n >= limit:
            return
        yield (
            traj,
            alfred_world(traj, data_dir),
            alfred_task_from_pddl(traj["pddl_params"], traj["task_type"]),
        )
