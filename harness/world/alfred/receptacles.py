"""Stage 1, receptacles: every receptacle of the floor plan (and of the trajectory's plan) as a piece,
sized from the catalog, facing the walkway, grown over what rests on it, and given its height."""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from harness.world.alfred.data import InteractionPose, ObjectPose, ReceptacleSpot
from harness.world.alfred.pieces import (
    DIRECTIONS,
    MAX_TOP_M,
    MIN_HEIGHT_M,
    REST_GAP_M,
    SLAB_M,
    TOP_BAND_ABOVE_M,
    TOP_BAND_BELOW_M,
    Build,
    Piece,
    cut_away,
    facing_walkway,
    footprint,
    violators,
)
from harness.world.invariants import EPS_M
from harness.world.model import make_object_id

COLUMN_OVERLAP = 0.35
"""Cabinets and drawers whose footprints share this much of the smaller one stack in one column."""

UNDER_OVERLAP = 0.3
"""A cabinet or drawer is in a surface's body when this much of its footprint is under the surface."""

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

UNDER_TOP_MARGIN_M = 0.12
"""A drawer or cabinet whose id is at most this above a surface's estimated top is in that surface's body
(the objects that set the top may rest on a shelf below it); the top is raised over the unit."""

REST_SNAP_M = 0.15
REST_SINK_M = 0.05
"""A piece whose base is within REST_SNAP_M above (or REST_SINK_M below) a surface's top rests on it (a
microwave on a counter, a safe on a dresser)."""

FRIDGE_HEADROOM_M = 0.15
"""A fridge is at least this much taller than the highest thing ALFRED puts in it."""

RIM_SLAB_M = 0.3
"""A piece lying lower than this above a basin's rim covers its opening; a wall cabinet higher up leaves
room to look in."""

GROW_REACH_M = 0.35
"""A surface grows to take in a resting object at most this far outside its current footprint ..."""
FIXTURE_REACH_M = 1.0
"""... or this far for a stove burner or appliance the plan uses (the counter under it runs up to it) ..."""
MAX_GROW_M = 2.5
"""... and never beyond this from its id's position (counters run along a wall, tables do not)."""

_STACKED = frozenset({"Cabinet", "Drawer"})
"""Units that stack into columns under counters, desks and dressers."""

_WALL_UNITS = frozenset({"Cabinet", "Shelf", "Microwave"})
"""Types AI2-THOR hangs above counters and furniture; high up, they face where ALFRED's planner looks from."""

_SLAB_TYPES = frozenset({"CounterTop", "Dresser", "Shelf"})
"""Surfaces the catalog sizes as a slab only (their body is the units under them)."""

COUNTER_FIXTURES = ("CoffeeMachine", "Toaster")
_ON_COUNTER = frozenset({*COUNTER_FIXTURES, "StoveBurner"})
"""Fixtures that stand on a counter: where the plan uses one, the counter reaches."""
_FIXTURE_RULES = frozenset(
    {"StoveBurner", "StoveKnob", "CoffeeMachine", "Toaster", "DeskLamp", "FloorLamp", "Television", "Faucet"}
    | {"Toilet", "GarbageCan", "LightSwitch", "HandTowelHolder", "TowelHolder", "ToiletPaperHanger"}
)
"""Types placed by a fixture rule (package docstring, 2) rather than as a receptacle from the plan."""


# ------------------------------------------------------------------------------------------ receptacles


def _prior_top(spot: ReceptacleSpot, b: Build) -> float:
    """Where a surface's top should be before looking at the objects on it."""
    y = spot.position[1]
    kind = spot.object_type
    if kind == "CounterTop":
        return y - COUNTER_PIVOT_ABOVE_TOP_M if y > PIVOT_AT_BASE_MAX_M else b.catalog.counter.top_m
    if kind == "Shelf":
        return y
    default = DRESSER_TOP_M if kind == "Dresser" else b.size_of(kind)[1]
    return max(default, y) if y > PIVOT_AT_BASE_MAX_M else default


def _resting_poses(b: Build, top: float, below: float = TOP_BAND_BELOW_M) -> list[ObjectPose]:
    return [
        p
        for p in b.scene.object_poses
        if top - below <= p.position[1] <= top + TOP_BAND_ABOVE_M and b.ontology.get(p.object_type).pickupable
    ]


def _claimed(
    pose: ObjectPose, owner: ReceptacleSpot, nominal: Mapping[str, tuple[Piece, float, float]]
) -> bool:
    """Whether another receptacle's nominal box holds the pose (so it must not pull ``owner``'s surface)."""
    x, y, z = pose.position
    for oid, (box, y0, y1) in nominal.items():
        if oid != owner.object_id and box.contains_xz(x, z) and y0 <= y <= y1:
            return True
    return False


def _grow_surface(
    piece: Piece, spot: ReceptacleSpot, b: Build, nominal: Mapping[str, tuple[Piece, float, float]]
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
            crossing = len(violators(lo, hi, b.reachable, 0.0)) > len(
                violators(piece.lo, piece.hi, b.reachable, 0.0)
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


def _nominal_pieces(b: Build) -> dict[str, tuple[Piece, float, float]]:
    """id -> (footprint at the id's position, y range it holds objects in): for telling who owns an object."""
    out = {}
    for spot in b.plan.receptacles:
        x, y, z = spot.position
        w, h, d = b.size_of(spot.object_type)
        over_furniture = y >= UPPER_UNIT_MIN_Y_M and spot.object_type in _WALL_UNITS
        if over_furniture or spot.object_type == "Fridge":  # its door faces where ALFRED's planner opens it
            facing = (round(spot.pose.rotation / 90) * 90 + 180) % 360
        else:
            facing = facing_walkway(x, z, b.reachable, (spot.pose.x - x, spot.pose.z - z))
        lo, hi = footprint(x, z, w, d, facing)
        box = Piece(spot.object_id, spot.object_type, lo, hi, facing, "floor", (x, y, z))
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


def _make_piece(spot: ReceptacleSpot, b: Build, facing: int, width: float, depth: float) -> Piece:
    x, y, z = spot.position
    lo, hi = footprint(x, z, width, depth, facing)
    seen_from = (spot.pose.x, spot.pose.z, round(spot.pose.rotation / 90) % 4 * 90)
    return Piece(spot.object_id, spot.object_type, lo, hi, facing, "floor", (x, y, z), seen_from=seen_from)


def _basin_piece(spot: ReceptacleSpot, b: Build, facing: int) -> Piece:
    """A sink or bathtub as one rigid piece: the basin (the id ALFRED lists) in front, the fixture's deck
    behind it (AI2-THOR's Sink or Bathtub object); ``split_decks`` cuts the deck off once it stands."""
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


def split_decks(b: Build) -> None:
    """Each sink or bathtub piece becomes its basin (front) and its deck (back, the catalog's share of the
    depth). A sink that had to be stretched down to stand on something (the floor, or a low cabinet under
    it) becomes a basin of the catalog's depth on its Sink pedestal instead, the deck strip behind the basin
    left for the faucet: a basin stretched half a metre deep would hide what lies in it from every pose."""
    for piece in list(b.pieces):
        if piece.object_id not in b.decks:
            continue
        deck_id, deck_type, share = b.decks[piece.object_id]
        fx, fz = DIRECTIONS[piece.facing]
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


def _uncover(b: Build, basin: Piece) -> None:
    """Cut back what lies on a basin's rim over its opening (up to RIM_SLAB_M above it): AI2-THOR's counter
    top has the sink cut out of it, but a box cannot, and a counter slab over the basin hides all in it."""
    above = dataclasses.replace(basin.copy(), lo=[basin.lo[0], basin.hi[1], basin.lo[2]])
    above.hi[1] = basin.hi[1] + RIM_SLAB_M
    for piece in list(b.pieces):
        if piece is not basin and piece.overlaps(above) and not cut_away(piece, above):
            b.dropped.append(f"{piece.object_id}: covers the basin {basin.object_id}")
            b.pieces.remove(piece)


def planned_spots(b: Build) -> list[ReceptacleSpot]:
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
        yaw = facing_walkway(
            float(nearest[0]), float(nearest[1]), np.array([[x, z]]), (x - nearest[0], z - nearest[1])
        )
        pose = InteractionPose(float(nearest[0]), float(nearest[1]), yaw, 30.0)
        spots.append(ReceptacleSpot(object_id, kind, fixture, (x, y, z), pose))
        listed.append((kind, (x, y, z)))
    return spots


def surface_pieces(b: Build) -> tuple[list[Piece], dict[str, float]]:
    """Every receptacle of the floor plan as a piece with a footprint; surfaces' tops by id."""
    nominal = _nominal_pieces(b)
    pieces: list[Piece] = []
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


def _content_heights(b: Build, piece: Piece) -> list[float]:
    """ALFRED heights of the object poses over a piece's footprint."""
    return [p.position[1] for p in b.scene.object_poses if piece.contains_xz(p.position[0], p.position[2])]


def _stack_columns(units: list[Piece]) -> list[list[Piece]]:
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
    groups: dict[int, list[Piece]] = collections.defaultdict(list)
    for i, unit in enumerate(units):
        groups[find(i)].append(unit)
    return [sorted(g, key=lambda p: (p.pivot[1], p.object_id)) for _, g in sorted(groups.items())]


def vertical_structure(b: Build, pieces: list[Piece], tops: dict[str, float]) -> None:
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
        s.lo[1] = top - slab_thickness(b, s.object_type) if slab else 0.0
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
                top = tops[low] - slab_thickness(b, kinds[low])
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
    b: Build, units: list[Piece], surfaces: list[Piece], tops: dict[str, float]
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
            need = unit.pivot[1] + b.size_of(unit.object_type)[1] / 2 + slab_thickness(b, s.object_type)
            tops[s.object_id] = max(tops[s.object_id], need)
        if over:
            caps[unit.object_id] = sorted(s.object_id for s in over)
    return caps


def _own_height(b: Build, piece: Piece) -> None:
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


def slab_thickness(b: Build, object_type: str) -> float:
    return b.size_of(object_type)[1] if object_type in _SLAB_TYPES else SLAB_M


def _rest_on_surface(piece: Piece, surfaces: list[Piece]) -> None:
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
