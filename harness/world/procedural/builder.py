"""One attempt's world under construction, with the geometric queries the placement passes share (what a
new piece may touch, which doors must stay clear, where a wall has room)."""

from __future__ import annotations

import random
from collections.abc import Iterable

import numpy as np

from harness.sim import physics
from harness.sim.navgrid import BLOCKING_BELOW_M, reachable_grid
from harness.world.catalog import Catalog, RoomSpec, Span, load_catalog
from harness.world.invariants import EPS_M, component_count, is_interactable, reachable_centres, viewable_from
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.pieces import Piece
from harness.world.walls import AXES, Pose, Wall, walls_of
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import GRID_STEP_M

POSITION_STEP_M = 0.05
"""Furniture positions along a wall are multiples of this."""
SURFACE_MARGIN_M = 0.01
"""Gap between a small object and the edge of the surface it rests on."""
FRONT_CLEARANCE_M = 0.4
"""Free floor kept in front of every door (fridge, cabinet, drawer, microwave): the door swings or slides
into it and the agent stands in it to reach inside."""


def _front_strip(obj: WorldObject) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """The space a door needs in front of the object: FRONT_CLEARANCE_M deep, as wide and tall as it."""
    (_, _), (fx, fz) = AXES[obj.facing % 360]
    lo, hi = list(obj.min_corner), list(obj.max_corner)
    axis, sign = (0, fx) if fx else (2, fz)
    face = hi[axis] if sign > 0 else lo[axis]
    lo[axis], hi[axis] = sorted((face, face + sign * FRONT_CLEARANCE_M))
    return (lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])


def _overlap(lo: tuple[float, ...], hi: tuple[float, ...], obj: WorldObject) -> bool:
    """Whether the box lo/hi and the object's box share a volume thicker than EPS_M along every axis."""
    return all(min(hi[k], obj.max_corner[k]) - max(lo[k], obj.min_corner[k]) > EPS_M for k in range(3))


class Builder:
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
        down in front of a cabinet) cannot be opened in AI2-THOR, and what it holds cannot be seen.
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
