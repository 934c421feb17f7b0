"""Stage 3, the room around the pieces: its floor and walls, wall units and wall fixtures on the walls, the
pieces as objects; and stage 5, the agent at ALFRED's start."""

from __future__ import annotations

import collections
import dataclasses
import math
from collections.abc import Iterable

import cv2
import numpy as np

from harness.sim.navgrid import BLOCKING_BELOW_M, reachable_grid
from harness.world.alfred.data import AlfredScene
from harness.world.alfred.fixtures import add_fixture, by_hint, fixture_hint, is_free
from harness.world.alfred.pieces import (
    DIRECTIONS,
    FURNITURE_CLEARANCE_M,
    MIN_SIDE_M,
    SEARCH_STEP_M,
    THIN_CLEARANCE_M,
    Build,
    Piece,
    Vec3,
    cell_span,
    clip,
    footprint,
    grid_cell,
    highest_top_below,
    in_reach,
    priority,
    supported,
)
from harness.world.invariants import EPS_M, on_wall
from harness.world.model import AgentState, Room, World, WorldObject, make_object_id
from harness.world.walls import walls_of
from symbolic.thor import GRID_STEP_M, HORIZON_MAX_DEG, HORIZON_MIN_DEG

WALL_SNAP_MAX_M = 0.75
"""Farthest a wall unit is pushed back to meet the wall."""

SUPPORT_ROUNDS = 4
"""Passes of the final support fix (each can only lower pieces, so a few settle every floor plan)."""

WALL_HEIGHT_MIN_M = 2.6
CEILING_GAP_M = 0.1
"""Rooms are WALL_HEIGHT_MIN_M high, or this much above their tallest piece."""
_HANGERS: dict[str, str] = {
    "HandTowelHolder": "HandTowel",
    "TowelHolder": "Towel",
    "ToiletPaperHanger": "ToiletPaper",
}
"""Wall holders and what hangs from them (their ALFRED poses show where the holder is)."""


def _room(b: Build) -> Room:
    """Floor = the agent's cells and every cell under a piece, with enclosed holes closed."""
    cells = {grid_cell(x, z) for x, z in b.reachable}
    for p in b.pieces:
        cells.update((i, k) for i in cell_span(p.lo[0], p.hi[0]) for k in cell_span(p.lo[2], p.hi[2]))
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


def on_floor(room: Room, lo: list[float], hi: list[float]) -> bool:
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


def _snap_to_wall(b: Build, world: World, piece: Piece) -> bool:
    """Stretch a wall unit's back onto the wall behind it (AI2-THOR's upper cabinets and shelves hang so)."""
    fx, fz = DIRECTIONS[piece.facing]
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
        if hi[axis] - lo[axis] < min(depth, MIN_SIDE_M) or not on_floor(world.room, lo, hi):
            continue
        probe = Piece(piece.object_id, piece.object_type, lo, hi, piece.facing, "wall", piece.pivot)
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


def _hang_on_walls(b: Build, world: World) -> None:
    """Wall units flush with a wall; any that cannot reach one stands on what is under it instead. Repeated
    until every piece is held up, since a unit lowered or trimmed may leave what stood on it hanging."""
    for piece in sorted(b.pieces, key=lambda p: p.object_id):
        if piece.mount == "wall" and not supported(piece, b.pieces, world):
            _snap_to_wall(b, world, piece)
    for _ in range(SUPPORT_ROUNDS):
        hanging = [p for p in b.pieces if not supported(p, b.pieces, world)]
        for piece in sorted(hanging, key=lambda p: (p.lo[1], p.object_id)):
            piece.mount = "floor"
            piece.lo[1] = highest_top_below(piece, b.pieces)
            if piece.lo[1] < BLOCKING_BELOW_M and not clip(piece, b.reachable, FURNITURE_CLEARANCE_M):
                b.pieces.remove(piece)
                b.dropped.append(f"{piece.object_id}: no wall and no room below")
        if not hanging:
            return


def _mount_on_wall(
    b: Build, world: World, object_type: str, hint: tuple[float, float] | None, below: float = 0.0
) -> Piece | None:
    """A wall fixture flush with a wall at its mounting height (or at BLOCKING_BELOW_M where the wall is by
    the walkway), with ``below`` metres kept free under it for what hangs from it."""
    w, h, d = b.size_of(object_type)
    default = b.catalog.alfred_mount_bottom(object_type)
    options = []
    for wall in walls_of(world.room):
        n = int((wall.hi - wall.lo - w) / SEARCH_STEP_M) + 1
        for i in range(max(n, 0)):
            pose = wall.pose(wall.lo + i * SEARCH_STEP_M, w, d)
            options.append((pose.cx, pose.cz, (pose.cx, pose.cz, wall.facing)))
    for cx, cz, facing in by_hint(options, hint):
        for bottom in (default, max(default, BLOCKING_BELOW_M)):
            lo, hi = footprint(cx, cz, w, d, facing)
            lo[1], hi[1] = bottom, bottom + h
            space = [lo[0], bottom - below, lo[2]], [hi[0], bottom, hi[2]]
            if not on_wall(world, tuple(lo), tuple(hi)) or not on_floor(world.room, lo, hi):  # type: ignore[arg-type]
                continue
            if not is_free(b, lo, hi, THIN_CLEARANCE_M) or (below > 0 and not is_free(b, *space, None)):
                continue
            if in_reach(b.reachable, lo, hi):
                return add_fixture(b, object_type, lo, hi, facing, "wall")
    return None


def _place_wall_fixtures(b: Build, world: World) -> None:
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
                fixture_hint(b, holder, None, (hung,))
            ]  # rolls also stand on toilets: one hanger, as AI2-THOR's
        for hint in (hints or [None])[have:]:
            _mount_on_wall(b, world, holder, hint, below=b.size_of(hung)[1])
    if "LightSwitch" in listed:
        _mount_on_wall(b, world, "LightSwitch", None)
    if "Television" in listed and not b.of_type("Television"):
        _mount_on_wall(b, world, "Television", fixture_hint(b, "Television"))


# ------------------------------------------------------------------------------------ the room and the agent


def start_pose(scene: AlfredScene) -> AgentState:
    """ALFRED's start: ``init_action``'s (x, z), its rotation as a yaw, its horizon (within the camera's)."""
    x, z, rotation, horizon = scene.start
    yaw = int(round(rotation / 90.0)) * 90 % 360
    return AgentState(x=x, z=z, yaw=yaw, horizon=min(max(horizon, HORIZON_MIN_DEG), HORIZON_MAX_DEG))


def enclose(b: Build, name: str, seed: int) -> World:
    """Step 3: the room around the pieces, wall units and fixtures on its walls, the pieces as objects."""
    world = World(name, _room(b), {}, start_pose(b.scene), seed=seed)
    for hung in (False, True):  # again once wall units have moved: what they no longer cover must go too
        if hung:
            _hang_on_walls(b, world)
            _place_wall_fixtures(b, world)
        joined = _plug(world, b.reachable, [p.to_object() for p in b.pieces])
        b.reachable = np.concatenate([b.reachable, joined])
    _counters_for_pillars(b, world)
    for piece in sorted(b.pieces, key=priority):
        obj = piece.to_object()
        obj.is_toggled = obj.object_type == "LightSwitch"  # AI2-THOR rooms start lit, everything else off
        world.add(obj)
    return world


def _counters_for_pillars(b: Build, world: World) -> None:
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
        b.pieces.append(Piece(make_object_id("CounterTop", centre), "CounterTop", lo, hi, 0, "floor", centre))


def cells_of(room: Room, mask: np.ndarray) -> set[tuple[int, int]]:
    """The grid cells (indexed by centre / GRID_STEP_M) where a room-shaped mask is True."""
    return {grid_cell(*room.cell_center(int(i), int(k))) for i, k in np.argwhere(mask)}
