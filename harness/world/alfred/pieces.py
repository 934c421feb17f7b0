"""The furniture under construction: ``Piece`` boxes, the ``Build`` every stage shares, and the geometry
rules the stages agree on (clearance from the walkway, cuts, support, reach)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from harness.sim.navgrid import CLEARANCE_M
from harness.world.alfred.data import AlfredScene, FloorPlan
from harness.world.catalog import Catalog, load_catalog
from harness.world.invariants import EPS_M, on_wall, viewable_from
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology
from symbolic.thor import AGENT_RADIUS_M, GRID_STEP_M

Mount = Literal["floor", "wall"]
Vec3 = tuple[float, float, float]

FURNITURE_CLEARANCE_M = AGENT_RADIUS_M
"""Furniture keeps the agent's capsule radius from every reachable point, as AI2-THOR's reachability implies
(the navigation grid only needs CLEARANCE_M, so knobs and handles may stick out a little)."""

THIN_CLEARANCE_M = CLEARANCE_M + 0.005
"""Wall fixtures and objects on the floor keep just over the navigation grid's clearance."""

# ------------------------------------------------------------------------------------- pieces and cuts

MAX_RETREAT_M = 0.35
"""A piece whose front reaches into the walkway is first moved back by up to this, then shrunk."""

RELOCATE_M = 0.6
"""Farthest a piece that fits nowhere near its id's position is moved to a free spot."""

MIN_SIDE_M = 0.12
"""Narrowest a piece may be cut or shrunk to along x or z."""

MIN_HEIGHT_M = 0.03
"""Thinnest a piece may be cut to vertically."""

CUT_MARGIN_M = 1e-4
"""Cuts go this much past the limit so that rounding never leaves a point on the boundary."""

SLAB_M = 0.05
"""Thickness of a table or desk top that has drawers or cabinets under it."""

MAX_TOP_M = 2.35
"""Tops stay below the reach rule's 2.4 m view limit (invariants.VIEW_TOP_MAX_M)."""

# ------------------------------------------------------------------------------------------- surfaces

TOP_BAND_BELOW_M = 0.12
TOP_BAND_ABOVE_M = 0.4
"""Objects whose ALFRED height lies in [prior top - below, prior top + above] are taken as resting on a
surface: they set its height (the lowest one, less REST_GAP_M) and its extent (GROW_REACH_M steps)."""

REST_GAP_M = 0.005
"""A surface's top is this far below the lowest object ALFRED rests on it."""

SURFACE_MARGIN_M = 0.05
"""A counter segment reaches this far past the objects that rest on it."""

# ----------------------------------------------------------------------------------------- placement

FLOOR_OBJECT_MAX_Y_M = 0.25
"""Objects ALFRED leaves lower than this and on no receptacle stay on the floor (plungers, balls, boots)."""

SEARCH_STEP_M = 0.05
"""Spacing of positions tried when placing fixtures and floor objects."""

DIRECTIONS: dict[int, tuple[int, int]] = {0: (0, 1), 90: (1, 0), 180: (0, -1), 270: (-1, 0)}
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


@dataclass
class Piece:
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

    def overlaps(self, other: Piece) -> bool:
        return all(min(self.hi[k], other.hi[k]) - max(self.lo[k], other.lo[k]) > EPS_M for k in range(3))

    def overlaps_xz(self, other: Piece) -> bool:
        return all(min(self.hi[k], other.hi[k]) - max(self.lo[k], other.lo[k]) > EPS_M for k in (0, 2))

    def xz_overlap_area(self, other: Piece) -> float:
        dx = min(self.hi[0], other.hi[0]) - max(self.lo[0], other.lo[0])
        dz = min(self.hi[2], other.hi[2]) - max(self.lo[2], other.lo[2])
        return max(dx, 0.0) * max(dz, 0.0)

    def contains_xz(self, x: float, z: float, margin: float = 0.0) -> bool:
        return (
            self.lo[0] - margin <= x <= self.hi[0] + margin
            and self.lo[2] - margin <= z <= self.hi[2] + margin
        )

    def copy(self) -> Piece:
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


@dataclass
class Build:
    """One trajectory's world under construction."""

    plan: FloorPlan
    scene: AlfredScene
    catalog: Catalog
    ontology: Ontology
    reachable: np.ndarray
    """float [M, 2]: the (x, z) cell centres the agent must be able to stand on."""
    pieces: list[Piece] = field(default_factory=list)
    dropped: list[str] = field(default_factory=list)
    floor_items: set[str] = field(default_factory=set)
    """Ids of the objects ALFRED leaves on the floor, placed with the furniture (they shape the floor)."""
    decks: dict[str, tuple[str, str, float]] = field(default_factory=dict)
    """Basin id -> (deck id, deck type, deck's share of the fixture's depth) of each sink and bathtub."""

    def size_of(self, object_type: str) -> Vec3:
        return self.catalog.scene_size(object_type)

    def of_type(self, *types: str) -> list[Piece]:
        return [p for p in self.pieces if p.object_type in types]


# ----------------------------------------------------------------------------------------------- grid cells


def grid_cell(x: float, z: float) -> tuple[int, int]:
    """The grid cell (indexed by centre / GRID_STEP_M) of a point."""
    return round(x / GRID_STEP_M), round(z / GRID_STEP_M)


def cell_span(lo: float, hi: float) -> range:
    """Indices of the grid cells (centred on multiples of GRID_STEP_M) that [lo, hi] reaches into."""
    half = GRID_STEP_M / 2
    return range(
        math.floor((lo + EPS_M + half) / GRID_STEP_M), math.floor((hi - EPS_M + half) / GRID_STEP_M) + 1
    )


# ----------------------------------------------------------------------------------------------- geometry


def violators(lo: list[float], hi: list[float], points: np.ndarray, clearance: float) -> np.ndarray:
    """[V, 2] reachable points closer than ``clearance`` to the footprint (navgrid's test)."""
    c = clearance
    near = (
        (points[:, 0] > lo[0] - c)
        & (points[:, 0] < hi[0] + c)
        & (points[:, 1] > lo[2] - c)
        & (points[:, 1] < hi[2] + c)
    )
    return points[near]


def frontal_violators(lo: list[float], hi: list[float], axis: int, points: np.ndarray) -> np.ndarray:
    """[V, 2] reachable points a piece advancing along ``axis`` must keep clear of: FURNITURE_CLEARANCE_M in
    front of it, but only the navigation grid's CLEARANCE_M beside it, so a point diagonally off a fridge's
    corner does not hold the fridge back (the unlisted strip left in front of its door would become a wall
    that hides everything in it)."""
    side = 2 - axis
    ahead = (points[:, axis // 2] > lo[axis] - FURNITURE_CLEARANCE_M) & (
        points[:, axis // 2] < hi[axis] + FURNITURE_CLEARANCE_M
    )
    beside = (points[:, side // 2] > lo[side] - CLEARANCE_M) & (points[:, side // 2] < hi[side] + CLEARANCE_M)
    return points[ahead & beside]


def facing_walkway(x: float, z: float, points: np.ndarray, fallback: tuple[float, float]) -> int:
    """The axis yaw from a piece towards the nearest reachable point (furniture faces the floor it is used
    from); ties, and floor plans without points, go to the side ALFRED's planner stood on (``fallback``)."""
    rel = points - np.array([x, z])  # [N, 2]
    fx, fz = fallback
    options = []
    for yaw, (dx, dz) in DIRECTIONS.items():
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


def footprint(x: float, z: float, width: float, depth: float, facing: int) -> tuple[list[float], list[float]]:
    """(lo, hi) with y left 0: ``width`` along the piece's front, ``depth`` front to back."""
    sx, sz = (width, depth) if facing in (0, 180) else (depth, width)
    return [x - sx / 2, 0.0, z - sz / 2], [x + sx / 2, 0.0, z + sz / 2]


def retreat(piece: Piece, points: np.ndarray, clearance: float) -> None:
    """Move a piece back (away from its front) until its front keeps ``clearance``, MAX_RETREAT_M at most."""
    dx, dz = DIRECTIONS[piece.facing]
    axis, sign = (0, dx) if dx else (2, dz)
    bad = violators(piece.lo, piece.hi, points, clearance)
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


def clip(piece: Piece, points: np.ndarray, clearance: float) -> bool:
    """Cut the footprint until no reachable point is within ``clearance``; False if it gets too small.

    Greedy: each round applies the single cut (one side of one offending point) that keeps the piece's id
    position inside if possible and the most area otherwise."""
    for _ in range(256):
        bad = violators(piece.lo, piece.hi, points, clearance)
        if not len(bad):
            return True
        if not _take_best(piece, _clearing_cuts(piece, bad, clearance)):
            return False
    return False


def _clearing_cuts(
    piece: Piece, bad: np.ndarray, clearance: float
) -> Iterator[tuple[float, list[float], list[float]]]:
    """(area, lo, hi) of each footprint with one side moved to keep ``clearance`` from a point of ``bad``."""
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
                yield (hi[0] - lo[0]) * (hi[2] - lo[2]), lo, hi


def cut_away(piece: Piece, other: Piece) -> bool:
    """Remove ``other``'s box from ``piece`` by moving one face of ``piece``; False if too little is left."""
    volume = math.prod(b - a for a, b in zip(piece.lo, piece.hi, strict=True))

    def cuts() -> Iterator[tuple[float, list[float], list[float]]]:
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
                kept = math.prod(b - a for a, b in zip(lo, hi, strict=True)) / max(volume, 1e-12)
                if axis == 1:  # prefer keeping a piece's height: its top carries objects, its base the floor
                    kept *= 0.5
                yield kept, lo, hi

    return _take_best(piece, cuts())


def _take_best(piece: Piece, trials: Iterable[tuple[float, list[float], list[float]]]) -> bool:
    """Give the piece the trial box (score, lo, hi) that keeps its id position inside if one does, with the
    highest score (the first of equals); False if there is no trial."""
    px, _, pz = piece.pivot
    best: tuple[tuple[bool, float], list[float], list[float]] | None = None
    for score, lo, hi in trials:
        key = (lo[0] <= px <= hi[0] and lo[2] <= pz <= hi[2], score)
        if best is None or key > best[0]:
            best = (key, lo, hi)
    if best is None:
        return False
    piece.lo[:], piece.hi[:] = best[1], best[2]
    return True


# ---------------------------------------------------------------------------------- overlap order and support


def priority(piece: Piece) -> tuple[int, float, str]:
    """Who keeps its box when two overlap: fixed-shape fixtures, then units, then surfaces small to large."""
    return _KEEPS_ITS_BOX.get(piece.object_type, 4), piece.area, piece.object_id


def volume_of(piece: Piece) -> float:
    return math.prod(max(b - a, 0.0) for a, b in zip(piece.lo, piece.hi, strict=True))


def supported(piece: Piece, others: Iterable[Piece], world: World | None = None) -> bool:
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


def _flush_beside(a: Piece, b: Piece) -> bool:
    """Faces touching along x or z, with the boxes overlapping in height and along the touching face."""
    if min(a.hi[1], b.hi[1]) - max(a.lo[1], b.lo[1]) <= EPS_M:
        return False
    for axis, other in ((0, 2), (2, 0)):
        touching = abs(a.lo[axis] - b.hi[axis]) <= EPS_M or abs(a.hi[axis] - b.lo[axis]) <= EPS_M
        if touching and min(a.hi[other], b.hi[other]) - max(a.lo[other], b.lo[other]) > EPS_M:
            return True
    return False


def highest_top_below(piece: Piece, pieces: Iterable[Piece]) -> float:
    """The top of the highest piece under ``piece``'s footprint and not above its base, else the floor."""
    tops = [
        o.hi[1] for o in pieces if o is not piece and o.overlaps_xz(piece) and o.hi[1] <= piece.lo[1] + EPS_M
    ]
    return max(tops, default=0.0)


# ------------------------------------------------------------------------------------------------ reach


def in_reach(points: np.ndarray, lo: list[float], hi: list[float]) -> bool:
    """The world checks' reach rule (within AI2-THOR's reach cylinder), from the agent's cells."""
    return bool(viewable_from(points, np.array([lo]), np.array([hi]))[0])
