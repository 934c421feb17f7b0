"""Seeded procedural rooms of AI2-THOR's four kinds, with their furniture and the objects they hold.

A world is built in four passes, each driven by ``catalog.json`` and the shared ontology:
1. a floor plan: the union of 1-3 axis-aligned rectangles of 0.25 m cells (rect, L, T or U), turned and
   mirrored at random;
2. furniture, entry by entry, each by a named placement strategy (against a wall, in a corner, beside or in
   front of another piece, on top of one, in the middle of the room, or an assembly such as a kitchen
   counter run with cabinets, drawers, sink and stove); after every floor-standing piece the reachable
   floor must stay one piece and everything placed so far must stay reachable;
3. small objects, each into a receptacle the ontology allows (on a top surface, inside an openable or a
   basin, or hanging from a holder), some in closed openables, some dirty, some filled with water;
4. the agent on a random reachable cell, facing away from some task-relevant object.
The result must pass ``harness.invariants.check_world``; an attempt that fails any pass is redrawn with
the next sub-seed, so a seed always gives the same world.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from harness import physics
from harness.catalog import (
    PRODUCES,
    Catalog,
    CounterRunSpec,
    FurnitureSpec,
    ObjectSpec,
    RoomSpec,
    Span,
    load_catalog,
)
from harness.geometry import SLIDING_TYPES
from harness.invariants import (
    EPS_M,
    check_world,
    component_count,
    is_interactable,
    on_wall,
    reachable_centres,
    seen_through_front,
    viewable_from,
)
from harness.navgrid import BLOCKING_BELOW_M, reachable_grid
from harness.world import AgentState, Room, RoomKind, World, WorldObject, make_object_id
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import GRID_STEP_M, TEACH_HFOV_DEG

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

POSITION_STEP_M = 0.05
"""Furniture positions along a wall are multiples of this."""
CENTER_MARGIN_M = 0.9
"""Free space a free-standing piece (a dining table) keeps to walls and other furniture."""
SURFACE_MARGIN_M = 0.01
"""Gap between a small object and the edge of the surface it rests on."""
PLACEMENT_TRIES = 12
"""Random positions tried for one object on one receptacle."""
HANGING_RESERVE_M = 0.8
"""Wall space kept free below a holder for what hangs from it (a towel)."""
FRONT_CLEARANCE_M = 0.4
"""Free floor kept in front of every door (fridge, cabinet, drawer, microwave): the door swings or slides
into it and the agent stands in it to reach inside."""


class WorldGenError(RuntimeError):
    """No sound world could be built for a config (after every attempt); says what kept failing."""


class _Retry(Exception):
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


# ----------------------------------------------------------------------------------------------- floor plan


def _rect_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]]:
    aspect = rng.uniform(1.0, 1.7)
    nx = max(MIN_ARM_CELLS, round(math.sqrt(cells * aspect)))
    nz = max(MIN_ARM_CELLS, round(cells / nx))
    return [(0, 0, nx, nz)]


def _l_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]] | None:
    """A bar of depth b along x and an arm of width a up z from its left end."""
    a, b = rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 4), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 4)
    extra = cells - a * b
    share = rng.uniform(0.3, 0.7)
    n1, n2 = round(share * extra / b), round((1 - share) * extra / a)
    if min(n1, n2) < MIN_NOTCH_CELLS:
        return None
    return [(0, 0, a + n1, b), (0, b, a, b + n2)]


def _t_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]] | None:
    """A bar along x and a stem of width a up z from its middle, with notches s and t either side."""
    a, b = rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 3), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 3)
    s, t = rng.randint(MIN_NOTCH_CELLS - 1, 6), rng.randint(MIN_NOTCH_CELLS - 1, 6)
    width = a + s + t
    stem = round((cells - width * b) / a)
    if stem < MIN_NOTCH_CELLS:
        return None
    return [(0, 0, width, b), (s, b, s + a, b + stem)]


def _u_cells(cells: int, rng: random.Random) -> list[tuple[int, int, int, int]] | None:
    """A bar along x with two arms up z at its ends, a gap of at least MIN_NOTCH_CELLS between them."""
    a1, a2 = rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 2), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 2)
    gap, b = rng.randint(MIN_NOTCH_CELLS, 8), rng.randint(MIN_ARM_CELLS, MIN_ARM_CELLS + 2)
    width = a1 + gap + a2
    arm = round((cells - width * b) / (a1 + a2))
    if arm < MIN_NOTCH_CELLS:
        return None
    return [(0, 0, width, b), (0, b, a1, b + arm), (width - a2, b, width, b + arm)]


_SHAPE_BUILDERS: dict[str, Callable[[int, random.Random], list[tuple[int, int, int, int]] | None]] = {
    "rect": _rect_cells,
    "L": _l_cells,
    "T": _t_cells,
    "U": _u_cells,
}


def floor_plan(area_m2: Span, shape: ShapeName, rng: random.Random) -> tuple[np.ndarray, str]:
    """bool [NX, NZ] floor of 1-3 rectangles with area in ``area_m2``, and its outline ("rect", "L"...)."""
    lo, hi = (a * CELLS_PER_M**2 for a in area_m2)
    for _ in range(200):
        cells = round(rng.uniform(lo, hi))
        options = [s for s in SHAPE_WEIGHTS if SHAPE_MIN_CELLS[s] <= cells] if shape == "auto" else [shape]
        if not options:
            continue
        name = rng.choices(options, weights=[SHAPE_WEIGHTS[s] for s in options])[0]
        rects = _SHAPE_BUILDERS[name](cells, rng)
        if rects is None:
            continue
        floor = np.zeros((max(r[2] for r in rects), max(r[3] for r in rects)), dtype=bool)
        for x0, z0, x1, z1 in rects:
            floor[x0:x1, z0:z1] = True
        if not lo <= floor.sum() <= hi:
            continue
        floor = np.rot90(floor, k=rng.randrange(4))
        if rng.random() < 0.5:
            floor = floor[::-1]
        return np.ascontiguousarray(floor), name
    raise _Retry(f"no {shape} floor plan with area in {area_m2} m^2")


# ------------------------------------------------------------------------------------------ frames and walls

_AXES: dict[int, tuple[tuple[int, int], tuple[int, int]]] = {
    0: ((1, 0), (0, 1)),
    90: ((0, -1), (1, 0)),
    180: ((-1, 0), (0, -1)),
    270: ((0, 1), (-1, 0)),
}
"""facing -> (right R, forward F) unit vectors in (x, z): yaw 0 faces +z, 90 faces +x (AI2-THOR)."""


def _front_strip(obj: WorldObject) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The space a door needs in front of the object: FRONT_CLEARANCE_M deep, as wide and tall as it."""
    (_, _), (fx, fz) = _AXES[obj.facing % 360]
    lo, hi = list(obj.min_corner), list(obj.max_corner)
    axis, sign = (0, fx) if fx else (2, fz)
    face = hi[axis] if sign > 0 else lo[axis]
    lo[axis], hi[axis] = sorted((face, face + sign * FRONT_CLEARANCE_M))
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


def _overlap(lo: tuple[float, ...], hi: tuple[float, ...], obj: WorldObject) -> bool:
    """Whether the box lo/hi and the object's box share a volume thicker than EPS_M along every axis."""
    return all(min(hi[k], obj.max_corner[k]) - max(lo[k], obj.min_corner[k]) > EPS_M for k in range(3))


@dataclass(frozen=True)
class Pose:
    """Where a piece stands: its footprint centre, the yaw its front faces, and the height of its base."""

    cx: float
    cz: float
    facing: int
    y0: float = 0.0

    def box(
        self, width: float, depth: float, lo: tuple[float, float, float], hi: tuple[float, float, float]
    ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """World corners of a box given in the piece frame (u along the front, y up, v from back to front)."""
        (rx, rz), (fx, fz) = _AXES[self.facing]
        ox = self.cx - width / 2 * rx - depth / 2 * fx
        oz = self.cz - width / 2 * rz - depth / 2 * fz
        xa, xb = ox + lo[0] * rx + lo[2] * fx, ox + hi[0] * rx + hi[2] * fx
        za, zb = oz + lo[0] * rz + lo[2] * fz, oz + hi[0] * rz + hi[2] * fz
        return (min(xa, xb), lo[1] + self.y0, min(za, zb)), (max(xa, xb), hi[1] + self.y0, max(za, zb))

    def shifted(self, along: float, forward: float) -> Pose:
        (rx, rz), (fx, fz) = _AXES[self.facing]
        return Pose(
            self.cx + along * rx + forward * fx, self.cz + along * rz + forward * fz, self.facing, self.y0
        )


@dataclass(frozen=True)
class Wall:
    """A straight run of wall; furniture against it faces ``facing`` (the room side)."""

    facing: int
    line: float
    """The wall's fixed coordinate: z for facing 0/180, x for facing 90/270."""
    lo: float
    hi: float
    """Extent along the wall (x for facing 0/180, z for facing 90/270)."""

    def pose(self, start: float, width: float, depth: float, y0: float = 0.0) -> Pose:
        """A piece of this footprint with its back on the wall, covering [start, start + width] along it."""
        mid = start + width / 2
        normal = 1 if self.facing in (0, 90) else -1
        across = self.line + normal * depth / 2
        return (
            Pose(mid, across, self.facing, y0)
            if self.facing in (0, 180)
            else Pose(across, mid, self.facing, y0)
        )


def walls_of(room: Room) -> list[Wall]:
    """Maximal straight wall runs along the floor's boundary, in a fixed order."""
    floor = room.floor
    NX, NZ = floor.shape
    padded = np.pad(floor, 1)
    inside = padded[1:-1, 1:-1]
    ox, oz = room.origin
    out: list[Wall] = []
    # facing, boundary mask [NX, NZ], runs along x?, line offset in cells
    specs = (
        (0, inside & ~padded[1:-1, :-2], True, 0),
        (180, inside & ~padded[1:-1, 2:], True, 1),
        (90, inside & ~padded[:-2, 1:-1], False, 0),
        (270, inside & ~padded[2:, 1:-1], False, 1),
    )
    for facing, mask, along_x, offset in specs:
        lines = range(NZ) if along_x else range(NX)
        for k in lines:
            row = mask[:, k] if along_x else mask[k, :]
            i = 0
            while i < len(row):
                if not row[i]:
                    i += 1
                    continue
                j = i
                while j < len(row) and row[j]:
                    j += 1
                base, line_origin = (ox, oz) if along_x else (oz, ox)
                out.append(
                    Wall(
                        facing,
                        line_origin + (k + offset) * GRID_STEP_M,
                        base + i * GRID_STEP_M,
                        base + j * GRID_STEP_M,
                    )
                )
                i = j
    return out


# ------------------------------------------------------------------------------------------------- pieces


@dataclass(frozen=True)
class Part:
    """One box of a piece, in its frame: u along its front (0..width), y up, v from its back (0..depth)."""

    object_type: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    controls: int | None = None
    """Index of the part this one switches (a knob's burner, a faucet's basin)."""


@dataclass
class Piece:
    """Furniture placed as a unit: one box, or an assembly (a counter run, a dresser, a shelf stack)."""

    parts: list[Part]
    width: float = field(init=False)
    depth: float = field(init=False)

    def __post_init__(self) -> None:
        self.width = max(p.hi[0] for p in self.parts)
        self.depth = max(p.hi[2] for p in self.parts)

    @property
    def y_range(self) -> Span:
        return (min(p.lo[1] for p in self.parts), max(p.hi[1] for p in self.parts))


def single(object_type: str, size: tuple[float, float, float]) -> Piece:
    w, h, d = size
    return Piece([Part(object_type, (0.0, 0.0, 0.0), (w, h, d))])


# ----------------------------------------------------------------------------------------------- the builder


class _Builder:
    """One attempt's world under construction, with the geometric queries the strategies share."""

    def __init__(
        self, config: WorldGenConfig, room: Room, rng: random.Random, required: dict[str, int]
    ) -> None:
        self.config = config
        self.rng = rng
        self.required = required
        self.catalog: Catalog = load_catalog()
        self.ontology: Ontology = load_ontology()
        self.spec: RoomSpec = self.catalog.room(config.kind)
        ix, iz = (int(v[0]) for v in np.nonzero(room.floor))
        x, z = room.cell_center(ix, iz)
        self.world = World(f"{config.kind}_s{config.seed}", room, {}, AgentState(x, z), seed=config.seed)
        self.walls = walls_of(room)

    # -------- queries

    def boxes(self, exclude: Iterable[str] = ()) -> tuple[np.ndarray, np.ndarray]:
        skip = set(exclude)
        objs = [o for o in self.world.objects.values() if o.object_id not in skip]
        lo = np.array([o.min_corner for o in objs], dtype=np.float64).reshape(-1, 3)
        hi = np.array([o.max_corner for o in objs], dtype=np.float64).reshape(-1, 3)
        return lo, hi

    def collides(self, lo: tuple[float, ...], hi: tuple[float, ...], exclude: Iterable[str] = ()) -> bool:
        blo, bhi = self.boxes(exclude)
        if len(blo) == 0:
            return False
        overlap = np.minimum(bhi, np.asarray(hi)) - np.maximum(blo, np.asarray(lo))  # [N, 3]
        return bool((overlap > EPS_M).all(axis=1).any())

    def on_floor(self, lo: tuple[float, ...], hi: tuple[float, ...]) -> bool:
        room = self.world.room
        ix0, iz0 = room.cell_of(lo[0] + EPS_M, lo[2] + EPS_M)
        ix1, iz1 = room.cell_of(hi[0] - EPS_M, hi[2] - EPS_M)
        NX, NZ = room.shape
        if ix0 < 0 or iz0 < 0 or ix1 >= NX or iz1 >= NZ:
            return False
        return bool(room.floor[ix0 : ix1 + 1, iz0 : iz1 + 1].all()) and hi[1] <= room.wall_height

    def reach_ok(self) -> bool:
        """The reachable floor is one piece and every interactable placed so far can be seen from it."""
        grid = reachable_grid(self.world)
        if component_count(grid) != 1:
            return False
        targets = [o for o in self.world.objects.values() if is_interactable(o.object_type, self.ontology)]
        if not targets:
            return True
        lo = np.array([o.min_corner for o in targets])
        hi = np.array([o.max_corner for o in targets])
        return bool(viewable_from(reachable_centres(self.world, grid), lo, hi).all())

    def of_types(self, types: Iterable[str]) -> list[WorldObject]:
        wanted = set(types)
        return [o for o in self.world.objects.values() if o.object_type in wanted]

    # -------- placing furniture

    def try_piece(self, piece: Piece, pose: Pose) -> list[WorldObject] | None:
        """Add the piece's parts at ``pose`` if they fit the floor, hit nothing and keep the room usable."""
        boxes = [pose.box(piece.width, piece.depth, p.lo, p.hi) for p in piece.parts]
        for lo, hi in boxes:
            if not self.on_floor(lo, hi) or self.collides(lo, hi):
                return None
        for i, (lo, hi) in enumerate(boxes):
            for lo2, hi2 in boxes[i + 1 :]:
                if all(min(hi[k], hi2[k]) - max(lo[k], lo2[k]) > EPS_M for k in range(3)):
                    raise AssertionError(f"assembly parts overlap: {piece.parts}")
        made: list[WorldObject] = []
        for part, (lo, hi) in zip(piece.parts, boxes, strict=True):
            center = tuple(round((a + b) / 2, 4) for a, b in zip(lo, hi, strict=True))
            size = tuple(round(b - a, 4) for a, b in zip(lo, hi, strict=True))
            oid = make_object_id(part.object_type, center)  # type: ignore[arg-type]
            if oid in self.world.objects or any(m.object_id == oid for m in made):
                return None
            made.append(WorldObject(oid, part.object_type, center, size, facing=pose.facing))  # type: ignore[arg-type]
        for part, obj in zip(piece.parts, made, strict=True):
            if part.controls is not None:
                obj.controls = made[part.controls].object_id
        if not self.doors_clear(made):
            return None
        for obj in made:
            self.world.add(obj)
        blocking = any(o.bottom < BLOCKING_BELOW_M for o in made)
        if blocking and not self.reach_ok():
            self.discard(made)
            return None
        return made

    def has_door(self, obj: WorldObject) -> bool:
        """Furniture whose contents are reached through its front: a fridge, cabinet, drawer, microwave."""
        info = self.ontology.get(obj.object_type)
        return physics.encloses(obj.object_type, self.ontology) and not info.pickupable

    def doors_clear(self, made: list[WorldObject]) -> bool:
        """New parts keep every door's front clear, and their own doors open onto free floor.

        A fridge pushed against a wall with its door touching the end of a counter run (or a garbage can set
        down in front of a cabinet) could never be opened in AI2-THOR, and what it holds could not be seen.
        """
        placed = [o for o in self.world.objects.values() if o.parent_id is None]
        for obj in made:
            others = [o for o in [*placed, *made] if o is not obj]
            if self.has_door(obj):
                lo, hi = _front_strip(obj)
                if not self.on_floor(lo, hi) or any(_overlap(lo, hi, o) for o in others):
                    return False
            if any(self.has_door(o) and _overlap(*_front_strip(o), obj) for o in others):
                return False
        return True

    def discard(self, made: list[WorldObject]) -> None:
        """Take back the objects just added (their segmentation ids too, so ids stay dense)."""
        for obj in made:
            self.world.remove(obj.object_id)
            del self.world.instance_ids[obj.object_id]

    def place_first(self, piece: Piece, poses: Iterable[Pose]) -> list[WorldObject] | None:
        for pose in poses:
            made = self.try_piece(piece, pose)
            if made is not None:
                return made
        return None

    def free_intervals(self, wall: Wall, depth: float, y_range: Span) -> list[Span]:
        """Stretches along ``wall`` where a piece ``depth`` deep spanning ``y_range`` meets nothing."""
        along_x = wall.facing in (0, 180)
        normal = 1 if wall.facing in (0, 90) else -1
        band = sorted((wall.line, wall.line + normal * depth))
        cut: list[Span] = []
        for o in self.world.objects.values():
            (x0, y0, z0), (x1, y1, z1) = o.min_corner, o.max_corner
            a0, a1, n0, n1 = (x0, x1, z0, z1) if along_x else (z0, z1, x0, x1)
            if (
                min(n1, band[1]) - max(n0, band[0]) > EPS_M
                and min(y1, y_range[1]) - max(y0, y_range[0]) > EPS_M
            ):
                cut.append((a0, a1))
        free: list[Span] = []
        cursor = wall.lo
        for a0, a1 in sorted(cut):
            if a0 > cursor + EPS_M:
                free.append((cursor, min(a0, wall.hi)))
            cursor = max(cursor, a1)
        if wall.hi > cursor + EPS_M:
            free.append((cursor, wall.hi))
        return [(a, b) for a, b in free if b > a]

    def is_corner(self, wall: Wall, at: float, outward: int) -> bool:
        """Whether the wall turns into the room at ``at`` (a convex corner), not into open floor."""
        normal = 1 if wall.facing in (0, 90) else -1
        along = at + outward * GRID_STEP_M / 2
        across = wall.line + normal * GRID_STEP_M / 2
        x, z = (along, across) if wall.facing in (0, 180) else (across, along)
        return not self.world.room.contains(x, z)

    def wall_poses(
        self, piece: Piece, y0: float = 0.0, *, corner: bool = False, reserve_below: float = 0.0
    ) -> list[Pose]:
        """Poses with the piece's back on a wall; with ``corner`` only those at convex corners of the room."""
        y_lo, y_hi = piece.y_range
        y_range = (max(0.0, y0 + y_lo - reserve_below), y0 + y_hi)
        walls = list(self.walls)
        self.rng.shuffle(walls)
        corners: list[Pose] = []
        others: list[Pose] = []
        for wall in walls:
            for a, b in self.free_intervals(wall, piece.depth, y_range):
                room = b - a - piece.width
                if room < -EPS_M:
                    continue
                room = max(room, 0.0)
                for start, outward, at in ((a, -1, a), (b - piece.width, 1, b)):
                    target = corners if self.is_corner(wall, at, outward) else others
                    target.append(wall.pose(start, piece.width, piece.depth, y0))
                for _ in range(2):
                    steps = int(room / POSITION_STEP_M)
                    others.append(
                        wall.pose(
                            a + POSITION_STEP_M * self.rng.randint(0, steps), piece.width, piece.depth, y0
                        )
                    )
        self.rng.shuffle(others)
        return corners + ([] if corner else others)

    def host_frame(self, host: WorldObject) -> tuple[Pose, float, float]:
        """A placed object's own frame: (pose of its footprint centre, width along its front, depth)."""
        sx, _, sz = host.size
        width, depth = (sx, sz) if host.facing in (0, 180) else (sz, sx)
        return Pose(host.center[0], host.center[2], host.facing, host.bottom), width, depth

    # -------- placing small objects

    def reachable_cells(self) -> np.ndarray:
        return reachable_centres(self.world, reachable_grid(self.world))


# ------------------------------------------------------------------------------------------------ assemblies


def counter_run(
    catalog: Catalog, rng: random.Random, length: float, specials: list[str], run: CounterRunSpec
) -> Piece:
    """A kitchen-style run: base units (Cabinet, or Drawer over Cabinet) under CounterTop slabs, a sink unit
    (Cabinet, SinkBasin, Sink deck and Faucet) that splits the slabs, a stove unit whose burners sit on the
    slab with a StoveKnob each on its front edge, and wall Cabinets above some units (AI2-THOR kitchens)."""
    c = catalog.counter
    _, slab, depth = catalog.nominal_size("CounterTop")
    widths = {"sink": c.sink_width_m, "stove": c.stove_width_m}
    units: list[tuple[str, float]] = [(s, widths[s]) for s in specials]
    rest = length - sum(w for _, w in units)
    while rest >= min(c.unit_widths_m) - EPS_M:
        w = rng.choice([u for u in c.unit_widths_m if u <= rest + EPS_M])
        units.insert(rng.randint(0, len(units)), ("base", w))
        rest -= w
    parts: list[Part] = []
    base_top = c.top_m - slab
    slab_start: float | None = None
    u = 0.0

    def close_slab(end: float) -> None:
        if slab_start is not None and end > slab_start + EPS_M:
            parts.append(Part("CounterTop", (slab_start, base_top, 0.0), (end, c.top_m, depth)))

    for kind, w in units:
        if kind == "sink":
            close_slab(u)
            slab_start = None
            deck = catalog.nominal_size("Sink")[2]
            low = c.sink_cabinet_height_m
            parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, low, depth)))
            basin = len(parts)
            parts.append(Part("SinkBasin", (u, low, deck), (u + w, c.top_m, depth)))
            parts.append(Part("Sink", (u, low, 0.0), (u + w, c.top_m, deck)))
            fw, fh, fd = catalog.nominal_size("Faucet")
            mid, v0 = u + w / 2, (deck - fd) / 2
            parts.append(
                Part("Faucet", (mid - fw / 2, c.top_m, v0), (mid + fw / 2, c.top_m + fh, v0 + fd), basin)
            )
        else:
            if slab_start is None:
                slab_start = u
            if kind == "stove":
                parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, base_top, depth)))
                parts += _burners_and_knobs(catalog, rng, u, w, run, depth, first=len(parts))
            elif rng.random() < run.drawer_p:
                split = base_top - c.drawer_height_m
                parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, split, depth)))
                parts.append(Part("Drawer", (u, split, 0.0), (u + w, base_top, depth)))
            else:
                parts.append(Part("Cabinet", (u, 0.0, 0.0), (u + w, base_top, depth)))
            if kind != "stove" and rng.random() < run.upper_cabinet_p:
                y0 = c.upper_cabinet_bottom_m
                parts.append(
                    Part(
                        "Cabinet",
                        (u, y0, 0.0),
                        (u + w, y0 + c.upper_cabinet_height_m, c.upper_cabinet_depth_m),
                    )
                )
        u += w
    close_slab(u)
    return Piece(parts)


def _burners_and_knobs(
    catalog: Catalog, rng: random.Random, u: float, w: float, run: CounterRunSpec, depth: float, first: int
) -> list[Part]:
    """2-4 burners on the stove unit's slab and, on the slab's front edge, one knob per burner in the same
    left-to-right order (AI2-THOR: each StoveKnob toggles one StoveBurner). ``first`` is the index the first
    burner will have in the piece's part list, so each knob can name its burner."""
    c = catalog.counter
    n = rng.randint(*run.burners)
    sites = sorted(rng.sample(c.burner_offsets_m, n))
    bw, bh, bd = catalog.nominal_size("StoveBurner")
    kw, kh, kd = catalog.nominal_size("StoveKnob")
    _, slab, _ = catalog.nominal_size("CounterTop")
    mid = u + w / 2
    burners = [
        Part(
            "StoveBurner",
            (mid + du - bw / 2, c.top_m, dv - bd / 2),
            (mid + du + bw / 2, c.top_m + bh, dv + bd / 2),
        )
        for du, dv in sites
    ]
    knob_y = c.top_m - slab / 2
    knobs = []
    for i in range(n):
        ku = u + w * (i + 1) / (n + 1)
        lo, hi = (ku - kw / 2, knob_y - kh / 2, depth), (ku + kw / 2, knob_y + kh / 2, depth + kd)
        knobs.append(Part("StoveKnob", lo, hi, controls=first + i))
    return [*burners, *knobs]


def shelf_stack(catalog: Catalog, rng: random.Random, levels: int, spacing: float) -> Piece:
    """Wall shelves one above the other (AI2-THOR's Shelf receptacles of a shelving unit)."""
    w, t, d = catalog.draw_size("Shelf", rng)
    return Piece([Part("Shelf", (0.0, k * spacing, 0.0), (w, k * spacing + t, d)) for k in range(levels)])


def dresser(catalog: Catalog, rng: random.Random, drawers: int, drawer_height: float) -> Piece:
    """Drawers stacked from the floor with the Dresser's top surface on them."""
    w, t, d = catalog.draw_size("Dresser", rng)
    parts = [
        Part("Drawer", (0.0, k * drawer_height, 0.0), (w, (k + 1) * drawer_height, d)) for k in range(drawers)
    ]
    top = drawers * drawer_height
    return Piece([*parts, Part("Dresser", (0.0, top, 0.0), (w, top + t, d))])


def bathtub(catalog: Catalog, rng: random.Random) -> Piece:
    """The tub's rim deck along the wall and, in front of it, the open BathtubBasin that holds things."""
    length, h, deck = catalog.draw_size("Bathtub", rng)
    _, _, basin = catalog.nominal_size("BathtubBasin")
    return Piece(
        [
            Part("Bathtub", (0.0, 0.0, 0.0), (length, h, deck)),
            Part("BathtubBasin", (0.0, 0.0, deck), (length, h, deck + basin)),
        ]
    )


# ------------------------------------------------------------------------------------ placement strategies


def _draw(span: Span | None, rng: random.Random, step: float = 0.01) -> float:
    if span is None:
        return 0.0
    lo, hi = span
    return round(lo + step * rng.randint(0, int(round((hi - lo) / step))), 4)


def _place_wall(b: _Builder, spec: FurnitureSpec, n: int, *, corner: bool = False) -> int:
    """Against a wall, on the floor or mounted at ``bottom_m``; corners first when ``corner``."""
    reserve = HANGING_RESERVE_M if b.catalog.placement(spec.object_type) == "hanging" else 0.0
    for placed in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        y0 = _draw(spec.bottom_m, b.rng)
        poses = b.wall_poses(piece, y0, reserve_below=reserve)
        if corner:
            poses = b.wall_poses(piece, y0, corner=True) + poses
        if b.place_first(piece, poses) is None:
            return placed
    return n


def _place_corner(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    return _place_wall(b, spec, n, corner=True)


def _mounted_ok(b: _Builder, made: list[WorldObject]) -> bool:
    """Pieces placed relative to a host off the floor must still hang on a wall (the host's wall may end)."""
    return all(o.bottom <= EPS_M or on_wall(b.world, o.min_corner, o.max_corner) for o in made)


def _place_beside(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """Next to a host along the same wall, backs aligned (side tables by a sofa, a fridge by the counter);
    against any wall if no host has room."""
    placed = 0
    for _ in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        y0 = _draw(spec.bottom_m, b.rng)
        poses = []
        hosts = b.of_types(spec.of)
        b.rng.shuffle(hosts)
        for host in hosts:
            frame, hw, hd = b.host_frame(host)
            sides = [-1, 1]
            b.rng.shuffle(sides)
            for side in sides:
                gap = _draw((0.02, 0.1), b.rng)
                pose = frame.shifted(side * (hw / 2 + gap + piece.width / 2), (piece.depth - hd) / 2)
                poses.append(Pose(pose.cx, pose.cz, pose.facing, y0))
        made = None
        for pose in poses:
            made = b.try_piece(piece, pose)
            if made is not None and y0 > 0 and not _mounted_ok(b, made):
                b.discard(made)
                made = None
            if made is not None:
                break
        if made is None and b.place_first(piece, b.wall_poses(piece, y0)) is None:
            return placed
        placed += 1
    return placed


def _place_front_of(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """Facing a host from ``gap_m`` in front of it (a coffee table before the sofa, a chair at the desk)."""
    placed = 0
    hosts = b.of_types(spec.of)
    b.rng.shuffle(hosts)
    for host in hosts:
        if placed == n:
            break
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        frame, hw, hd = b.host_frame(host)
        gap = _draw(spec.gap_m, b.rng)
        poses = []
        for jitter in (0.0, -0.1, 0.1, -0.2, 0.2):
            p = frame.shifted(jitter, hd / 2 + gap + piece.depth / 2)
            poses.append(Pose(p.cx, p.cz, (host.facing + 180) % 360))
        if b.place_first(piece, poses) is not None:
            placed += 1
    return placed


def _place_around(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """Chairs around a table, each facing it, one or two per side as the side's length allows."""
    placed = 0
    for host in b.of_types(spec.of):
        frame, hw, hd = b.host_frame(host)
        w, h, d = b.catalog.draw_size(spec.object_type, b.rng)
        gap = 0.05
        sites: list[Pose] = []
        for side_len, off_dir, reach, facing in (
            (hw, (0, 1), hd / 2, 180),
            (hw, (0, -1), hd / 2, 0),
            (hd, (1, 0), hw / 2, 270),
            (hd, (-1, 0), hw / 2, 90),
        ):
            slots = (-side_len / 4, side_len / 4) if side_len >= 2 * w + 0.2 else (0.0,)
            for s in slots:
                along = off_dir[0] * (reach + gap + d / 2) + (s if off_dir[0] == 0 else 0.0)
                forward = off_dir[1] * (reach + gap + d / 2) + (s if off_dir[1] == 0 else 0.0)
                p = frame.shifted(along, forward)
                sites.append(Pose(p.cx, p.cz, (host.facing + facing) % 360))
        b.rng.shuffle(sites)
        for pose in sites:
            if placed == n:
                return placed
            if b.try_piece(single(spec.object_type, (w, h, d)), pose) is not None:
                placed += 1
    return placed


def _place_on(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """Standing on a host's top, back near the host's back (appliances on a counter, a TV on its stand)."""
    placed = 0
    for _ in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        hosts = b.of_types(spec.of)
        b.rng.shuffle(hosts)
        poses = []
        for host in hosts:
            frame, hw, hd = b.host_frame(host)
            slack = hw - piece.width - 2 * SURFACE_MARGIN_M
            if slack < 0 or piece.depth > hd - 0.02:
                continue
            offsets = [0.0] + [b.rng.uniform(-slack / 2, slack / 2) for _ in range(6)]
            for along in offsets:
                p = frame.shifted(round(along, 2), -hd / 2 + 0.02 + piece.depth / 2)
                poses.append(Pose(p.cx, p.cz, host.facing, host.top))
        if b.place_first(piece, poses) is None:
            return placed
        placed += 1
    return placed


def _place_above(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """On the wall above a host, centred on it (a mirror over the bathroom sink)."""
    placed = 0
    for host in b.of_types(spec.of)[:n]:
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        frame, hw, hd = b.host_frame(host)
        p = frame.shifted(0.0, -hd / 2 + piece.depth / 2)
        made = b.try_piece(piece, Pose(p.cx, p.cz, host.facing, _draw(spec.bottom_m, b.rng)))
        if made is not None and not _mounted_ok(b, made):
            b.discard(made)
            made = None
        placed += made is not None
    return placed


def _place_center(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """Free-standing in the open floor, CENTER_MARGIN_M clear of walls and other furniture."""
    placed = 0
    x0, z0, x1, z1 = b.world.room.bounds()
    for _ in range(n):
        piece = single(spec.object_type, b.catalog.draw_size(spec.object_type, b.rng))
        for _ in range(30):
            facing = b.rng.choice((0, 90, 180, 270))
            pose = Pose(
                round(b.rng.uniform(x0, x1) / POSITION_STEP_M) * POSITION_STEP_M,
                round(b.rng.uniform(z0, z1) / POSITION_STEP_M) * POSITION_STEP_M,
                facing,
            )
            m = CENTER_MARGIN_M
            lo, hi = pose.box(
                piece.width, piece.depth, (-m, 0.0, -m), (piece.width + m, BLOCKING_BELOW_M, piece.depth + m)
            )
            if not b.on_floor(lo, hi) or b.collides(lo, hi):
                continue
            if b.try_piece(piece, pose) is not None:
                placed += 1
                break
    return placed


def _place_shelf_stack(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    assert spec.levels is not None and spec.spacing_m is not None, (
        f"{spec.object_type}: shelf_stack needs levels"
    )
    for placed in range(n):
        piece = shelf_stack(b.catalog, b.rng, b.rng.randint(*spec.levels), spec.spacing_m)
        if b.place_first(piece, b.wall_poses(piece, _draw(spec.bottom_m, b.rng))) is None:
            return placed
    return n


def _place_dresser(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    assert spec.drawers is not None and spec.drawer_height_m is not None, "dresser needs drawers"
    for placed in range(n):
        piece = dresser(b.catalog, b.rng, b.rng.randint(*spec.drawers), spec.drawer_height_m)
        if b.place_first(piece, b.wall_poses(piece)) is None:
            return placed
    return n


def _place_bathtub(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    for placed in range(n):
        piece = bathtub(b.catalog, b.rng)
        if b.place_first(piece, b.wall_poses(piece, corner=True) + b.wall_poses(piece)) is None:
            return placed
    return n


def _place_counter_runs(b: _Builder, spec: FurnitureSpec, n: int) -> int:
    """``n`` counter runs on the walls; the first takes the sink and stove units, or only the sink when no
    wall has room for both, leaving the stove to another run (added if ``n`` runs are not enough)."""
    assert spec.run is not None, f"{spec.object_type}: counter_run needs a run spec"
    run = spec.run
    burners_needed = b.required.get("StoveBurner", 0)
    if burners_needed > run.burners[0]:
        run = CounterRunSpec(
            run.length_m,
            run.sinks,
            run.stoves,
            (burners_needed, run.burners[1]),
            run.drawer_p,
            run.upper_cabinet_p,
        )
    c = b.catalog.counter
    widths = {"sink": c.sink_width_m, "stove": c.stove_width_m}
    specials = ["sink"] * run.sinks + ["stove"] * run.stoves
    placed = 0
    while placed < n or specials:
        length = _draw(run.length_m, b.rng, POSITION_STEP_M)
        takes = range(len(specials), 0, -1) if specials else (0,)
        for take in takes:
            chosen = specials[:take]
            need = sum(widths[s] for s in chosen) + min(c.unit_widths_m)
            piece = counter_run(b.catalog, b.rng, max(length, need), chosen, run)
            if b.place_first(piece, b.wall_poses(piece)) is not None:
                specials = specials[take:]
                placed += 1
                break
        else:
            if specials:
                raise _Retry(f"no wall has room for a counter run with {specials}")
            return placed
    return placed


Strategy = Callable[[_Builder, FurnitureSpec, int], int]

STRATEGIES: dict[str, Strategy] = {
    "wall": _place_wall,
    "wall_mounted": _place_wall,
    "corner": _place_corner,
    "beside": _place_beside,
    "front_of": _place_front_of,
    "around": _place_around,
    "on": _place_on,
    "above": _place_above,
    "center": _place_center,
    "counter_run": _place_counter_runs,
    "shelf_stack": _place_shelf_stack,
    "dresser": _place_dresser,
    "bathtub": _place_bathtub,
}
"""Placement strategies by the name ``catalog.json`` uses in each furniture entry's ``place``."""


def strategy(name: str) -> Strategy:
    """The placement strategy called ``name``; unknown names fail with the list of known ones."""
    found = STRATEGIES.get(name)
    if found is None:
        raise KeyError(f"unknown placement strategy {name!r}; known: {', '.join(sorted(STRATEGIES))}")
    return found


def _forced_entries(spec: RoomSpec, required: dict[str, int]) -> set[int]:
    """Furniture entries that must be placed because they (or pieces that stand on them) are required."""
    wanted = set(required)
    forced: set[int] = set()
    changed = True
    while changed:
        changed = False
        for i, entry in enumerate(spec.furniture):
            makes = {entry.object_type, *PRODUCES.get(entry.place, ())}
            if i not in forced and makes & wanted:
                forced.add(i)
                wanted |= set(entry.of)
                changed = True
    return forced


def _place_furniture(b: _Builder) -> None:
    forced = _forced_entries(b.spec, b.required)
    for i, entry in enumerate(b.spec.furniture):
        need = b.required.get(entry.object_type, 0)
        if i in forced:
            n, mandatory = max(b.rng.randint(*entry.count), need, 1), max(need, 1)
        elif b.rng.random() < entry.p:
            n, mandatory = b.rng.randint(*entry.count), int(entry.p >= 1.0)
        else:
            continue
        if entry.of and not b.of_types(entry.of):
            if i in forced:
                raise _Retry(f"{entry.object_type} needs one of {entry.of}, which this room lacks")
            continue
        placed = strategy(entry.place)(b, entry, n)
        if placed < mandatory:
            raise _Retry(f"could place only {placed} of {mandatory} {entry.object_type}")
    for switch in b.world.of_type("LightSwitch"):
        switch.is_toggled = True  # AI2-THOR rooms start lit; lamps, appliances and faucets start off


# --------------------------------------------------------------------------------------------- small objects


def _inner_levels(b: _Builder, host: WorldObject) -> list[tuple[float, float | None]]:
    """(floor, ceiling) of each place inside a receptacle: its inner floor and, for fridges and cabinets,
    shelves every ``shelf_spacing`` (boards 2 cm thick); open-topped ones (basins, pots) have no ceiling."""
    t = b.catalog.wall_thickness(host.object_type)
    floor = host.bottom + t
    if not b.ontology.get(host.object_type).openable:
        return [(floor, None)]
    top = host.top - t
    spacing = b.catalog.shelf_spacing(host.object_type)
    if spacing is None:
        return [(floor, top)]
    levels = [
        floor + k * spacing
        for k in range(int((top - floor) / spacing) + 1)
        if floor + k * spacing < top - 0.1
    ]
    return [(y, levels[k + 1] - 0.02 if k + 1 < len(levels) else top) for k, y in enumerate(levels)]


def _shows_through_door(
    b: _Builder, host: WorldObject, lo: tuple[float, ...], hi: tuple[float, ...], cells: np.ndarray
) -> bool:
    """Inside a fridge, cabinet or microwave, the object must show through the open door from a reachable
    cell within reach (``invariants.seen_through_front``): a plate at the back of a low cabinet's top shelf
    is seen only from too far away. Drawers slide out and show everything from above."""
    if not b.has_door(host) or host.object_type in SLIDING_TYPES:
        return True
    (_, _), (fx, fz) = _AXES[host.facing % 360]
    axis, sign = (0, fx) if fx else (2, fz)
    face = host.max_corner[axis] if sign > 0 else host.min_corner[axis]
    across = 2 - axis
    return seen_through_front(
        cells,
        np.array(lo),
        np.array(hi),
        (axis, sign, face),
        (host.min_corner[across], host.max_corner[across]),
        host.top - b.catalog.wall_thickness(host.object_type),
    )


def _fit_object(
    b: _Builder, object_type: str, size: tuple[float, float, float], host: WorldObject, cells: np.ndarray
) -> WorldObject | None:
    """A free, reachable spot for the object in or on ``host`` (AI2-THOR-style: centre y = surface + h/2)."""
    catalog = b.catalog
    mode = catalog.placement(host.object_type)
    pickupable = b.ontology.get(object_type).pickupable
    if (catalog.single_slot(host.object_type) and b.world.children(host.object_id)) or (
        not pickupable and mode != "on"
    ):
        return None
    w, h, d = size
    exclude = [host.object_id, *b.world.parent_chain(host.object_id)]
    (hx0, _, hz0), (hx1, _, hz1) = host.min_corner, host.max_corner
    for _ in range(PLACEMENT_TRIES):
        facing = host.facing if mode == "hanging" else b.rng.choice((0, 90, 180, 270))
        sx, sz = (w, d) if facing in (0, 180) else (d, w)
        if mode == "hanging":
            frame, _, hd = b.host_frame(host)
            spot = frame.shifted(0.0, -hd / 2 + d / 2)
            cx, cz, y = spot.cx, spot.cz, host.bottom - h
        else:
            inset = (
                SURFACE_MARGIN_M
                if mode == "on"
                else catalog.wall_thickness(host.object_type) + SURFACE_MARGIN_M
            )
            if catalog.single_slot(host.object_type):
                cx, cz = host.center[0], host.center[2]
            else:
                xa, xb = hx0 + inset + sx / 2, hx1 - inset - sx / 2
                za, zb = hz0 + inset + sz / 2, hz1 - inset - sz / 2
                if xa > xb or za > zb:
                    continue
                cx, cz = b.rng.uniform(xa, xb), b.rng.uniform(za, zb)
            if mode == "on":
                y = host.top
            else:
                y, ceiling = b.rng.choice(_inner_levels(b, host))
                if ceiling is not None and y + h > ceiling + EPS_M:
                    continue
        center = (round(cx, 4), round(y + h / 2, 4), round(cz, 4))
        lo = (center[0] - sx / 2, center[1] - h / 2, center[2] - sz / 2)
        hi = (center[0] + sx / 2, center[1] + h / 2, center[2] + sz / 2)
        if not b.on_floor(lo, hi) or b.collides(lo, hi, exclude):
            continue
        if not viewable_from(cells, np.array([lo]), np.array([hi]))[0] or not _shows_through_door(
            b, host, lo, hi, cells
        ):
            continue
        oid = make_object_id(object_type, center)
        if oid in b.world.objects:
            continue
        parent = host.object_id if pickupable else None
        return WorldObject(oid, object_type, center, (sx, h, sz), facing=facing, parent_id=parent)
    return None


def _start_states(b: _Builder, obj: WorldObject) -> None:
    """Some dishes dirty, some clean containers filled (AI2-THOR's isDirty / isFilledWithLiquid)."""
    info = b.ontology.get(obj.object_type)
    cfg = b.config
    if info.dirtyable and b.rng.random() < cfg.dirty_prob:
        obj.is_dirty = True
    if info.fillable and info.pickupable and not obj.is_dirty and b.rng.random() < cfg.filled_prob:
        if obj.object_type == "Mug" and b.rng.random() < cfg.coffee_prob:
            obj.liquid = "coffee"
        else:
            obj.liquid = "wine" if obj.object_type == "WineBottle" else "water"


def _place_object(
    b: _Builder, object_type: str, where: tuple[tuple[str, float], ...], cells: np.ndarray
) -> bool:
    """Put one object in a receptacle: the usual ones first (closed openables first with inside_closed_prob),
    then any receptacle in the room the ontology allows."""
    info = b.ontology.get(object_type)
    size = b.catalog.draw_size(object_type, b.rng)
    present = {o.object_type for o in b.world.objects.values()}

    def usable(r: str) -> bool:
        if r not in present:
            return False
        return b.ontology.accepts(r, object_type) if info.pickupable else b.catalog.placement(r) == "on"

    preferred = [(r, w) for r, w in where if usable(r)]
    named = {r for r, _ in preferred}
    fallback = [(r, 1.0) for r in b.ontology.receptacles_for(object_type) if usable(r) and r not in named]
    closed = [(r, w) for r, w in preferred if b.ontology.get(r).openable]
    opened = [(r, w) for r, w in preferred if not b.ontology.get(r).openable]
    groups = [closed, opened] if b.rng.random() < b.config.inside_closed_prob else [opened, closed]
    for group in [*groups, fallback]:
        remaining = list(group)
        while remaining:
            pick = b.rng.choices(range(len(remaining)), weights=[w for _, w in remaining])[0]
            receptacle, _ = remaining.pop(pick)
            hosts = b.world.of_type(receptacle)
            b.rng.shuffle(hosts)
            for host in hosts:
                obj = _fit_object(b, object_type, size, host, cells)
                if obj is not None:
                    _start_states(b, obj)
                    b.world.add(obj)
                    return True
    return False


def _object_plan(b: _Builder, furniture_types: set[str]) -> list[tuple[ObjectSpec, int, int]]:
    """(spec, how many, how many at least) per object type. Movable receptacles go first so others can go in
    them, then the objects that must exist, so the optional ones never take their place."""
    specs = list(b.spec.objects)
    listed = {s.object_type for s in specs}
    for object_type, n in b.required.items():
        if object_type not in listed and object_type not in furniture_types:
            specs.append(ObjectSpec(object_type, (n, n), n, ()))
    plan = []
    for s in specs:
        least = max(s.min_count, b.required.get(s.object_type, 0))
        plan.append((s, max(b.rng.randint(*s.count), least), least))
    plan.sort(key=lambda p: (not b.ontology.get(p[0].object_type).movable_receptacle, p[2] == 0))
    return plan


def _place_objects(b: _Builder) -> None:
    cells = b.reachable_cells()
    for spec, count, least in _object_plan(b, _furniture_types(b.spec)):
        for i in range(count):
            if not _place_object(b, spec.object_type, spec.where, cells):
                if i < least:
                    raise _Retry(f"no room for {spec.object_type} #{i + 1}")
                break


def _furniture_types(spec: RoomSpec) -> set[str]:
    return {t for e in spec.furniture for t in (e.object_type, *PRODUCES.get(e.place, ()))}


# ------------------------------------------------------------------------------------------------ the agent


def _in_closed_openable(world: World, obj: WorldObject) -> bool:
    ontology = load_ontology()
    return any(
        ontology.get(world.objects[p].object_type).openable and not world.objects[p].is_open
        for p in world.parent_chain(obj.object_id)
    )


def _in_view(x: float, z: float, yaw: int, obj: WorldObject) -> bool:
    """Inside the horizontal field of view of TEACh's camera (90 degrees) from (x, z) facing ``yaw``."""
    fx, fz = _AXES[yaw][1]
    dx, dz = obj.center[0] - x, obj.center[2] - z
    norm = math.hypot(dx, dz)
    return norm < 1e-9 or (dx * fx + dz * fz) / norm >= math.cos(math.radians(TEACH_HFOV_DEG / 2))


def _place_agent(b: _Builder, task_types: set[str]) -> None:
    """A random reachable cell and yaw (horizon 0) from which some task-relevant object in the open is out
    of view (so the agent must search), preferring a pose with a free cell ahead."""
    world = b.world
    grid = reachable_grid(world)
    cells = [(int(i), int(j)) for i, j in zip(*np.nonzero(grid), strict=True)]
    b.rng.shuffle(cells)
    targets = [
        o for o in world.objects.values() if o.object_type in task_types and not _in_closed_openable(world, o)
    ]
    best: tuple[int, float, float, int] | None = None
    for ix, iz in cells:
        x, z = world.room.cell_center(ix, iz)
        yaws = [0, 90, 180, 270]
        b.rng.shuffle(yaws)
        for yaw in yaws:
            fx, fz = _AXES[yaw][1]
            ahead = world.room.cell_of(x + fx * GRID_STEP_M, z + fz * GRID_STEP_M)
            free_ahead = 0 <= ahead[0] < grid.shape[0] and 0 <= ahead[1] < grid.shape[1] and bool(grid[ahead])
            hidden = any(not _in_view(x, z, yaw, o) for o in targets)
            score = 2 * hidden + free_ahead
            if best is None or score > best[0]:
                best = (score, x, z, yaw)
        if best is not None and best[0] == 3:
            break
    if best is None:
        raise _Retry("no reachable cell for the agent")
    _, x, z, yaw = best
    world.agent = AgentState(x=x, z=z, yaw=yaw, horizon=0.0)


# ------------------------------------------------------------------------------------------------ the API


def _check_require(config: WorldGenConfig) -> dict[str, int]:
    """The required counts by type, or ValueError naming what this room kind can hold instead."""
    catalog, ontology = load_catalog(), load_ontology()
    spec = catalog.room(config.kind)
    required: dict[str, int] = {}
    for object_type, count in config.require:
        ontology.get(object_type)
        if object_type in required:
            raise ValueError(f"require names {object_type!r} twice")
        required[object_type] = count
    furniture = _furniture_types(spec)
    listed = furniture | {s.object_type for s in spec.objects}
    receptacles = {t for t in listed if ontology.get(t).receptacle}
    holdable = {
        t
        for t in catalog.sized_types
        if ontology.get(t).pickupable and any(ontology.accepts(r, t) for r in receptacles)
    }
    possible = listed | holdable
    for object_type in required:
        if object_type not in possible:
            raise ValueError(
                f"a {config.kind} cannot hold {object_type!r}; it can hold: {', '.join(sorted(possible))}"
            )
    runs = [e.run for e in spec.furniture if e.run is not None]
    most_burners = sum(r.stoves * r.burners[1] for r in runs)
    if required.get("StoveBurner", 0) > most_burners:
        raise ValueError(
            f"a {config.kind} has at most {most_burners} StoveBurners, {required['StoveBurner']} required"
        )
    return required


def _attempt(config: WorldGenConfig, rng: random.Random, required: dict[str, int]) -> World:
    catalog = load_catalog()
    spec = catalog.room(config.kind)
    floor, _ = floor_plan(config.area_range_m2(), config.shape, rng)
    NX, NZ = floor.shape
    room = Room(
        kind=config.kind,
        floor=floor,
        origin=(-(NX // 2) * GRID_STEP_M, -(NZ // 2) * GRID_STEP_M),
        wall_height=_draw(spec.wall_height_m, rng, 0.05),
    )
    b = _Builder(config, room, rng, required)
    _place_furniture(b)
    _place_objects(b)
    _place_agent(b, {s.object_type for s in spec.objects if s.min_count} | set(required))
    world = b.world
    missing = {t: n for t, n in required.items() if len(world.of_type(t)) < n}
    if missing:
        raise _Retry(f"required objects missing: {missing}")
    problems = check_world(world)
    if problems:
        raise _Retry("; ".join(problems[:3]))
    return world


def generate_world(config: WorldGenConfig) -> World:
    """A sound world for ``config``: same config, same world (ids, positions and states).

    Raises ValueError when ``require`` asks for what the room kind cannot hold, and WorldGenError when no
    attempt succeeded (the message carries the last attempts' reasons).
    """
    required = _check_require(config)
    reasons: list[str] = []
    for attempt in range(config.max_attempts):
        rng = random.Random(f"{config.kind}/{config.seed}/{attempt}")
        try:
            return _attempt(config, rng, required)
        except _Retry as failure:
            reasons.append(f"attempt {attempt}: {failure}")
    raise WorldGenError(
        f"no sound {config.kind} for seed {config.seed} in {config.max_attempts} attempts; "
        f"last: {reasons[-3:]}"
    )


def generate_kitchen(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("kitchen", seed, require=require))


def generate_living_room(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("living_room", seed, require=require))


def generate_bedroom(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("bedroom", seed, require=require))


def generate_bathroom(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("bathroom", seed, require=require))
