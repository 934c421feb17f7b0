"""Checks that a world is physically and practically sound: the generator's acceptance test and tests' oracle.

A world passes when every object stands inside the room, rests on something (the floor, a wall it is
mounted on, the furniture under it, or its receptacle in the way that receptacle holds things), no two
objects interpenetrate, parent links agree with the ontology, the agent's reachable floor is one piece,
and every interactable object can be seen and reached from some reachable cell. The geometric reach rule
is the world generator's brief: a reachable cell whose centre is within VIEW_HORIZONTAL_M of the object's
box horizontally, and the box top between the floor and VIEW_TOP_MAX_M (the agent can tilt its camera to
it). The held object is not checked for placement: it travels with the agent.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from harness.sim.navgrid import reachable_grid
from harness.world.catalog import load_catalog
from harness.world.model import World, WorldObject
from symbolic.ontology import AFFORDANCES, Ontology, load_ontology
from symbolic.thor import (
    CAMERA_HEIGHT_M,
    GRID_STEP_M,
    HORIZON_MAX_DEG,
    HORIZON_MIN_DEG,
    INTERACTION_DISTANCE_M,
)

EPS_M = 2e-3
"""Contact tolerance: faces closer than this touch; boxes must overlap by more than this to interpenetrate."""

VIEW_HORIZONTAL_M = 1.3
"""An object is reachable from a cell whose centre is at most this far from its box, horizontally: inside
AI2-THOR's 1.5 m reach cylinder (``harness.sim.reach``) with room for clicks beyond the box's nearest edge."""

SIGHT_MARGIN_M = 0.1
"""Reach kept in hand when a box must show through a door: the click lands beyond its nearest point."""

VIEW_TOP_MAX_M = 2.4
"""Highest box top the agent's camera (1.576 m, looking up to 30 degrees) still brings into view."""

CONTROL_TARGETS: dict[str, tuple[str, ...]] = {
    "StoveKnob": ("StoveBurner",),
    "Faucet": ("SinkBasin", "BathtubBasin"),
}
"""What each controller type may switch (AI2-THOR: a knob drives one burner, a faucet runs into a basin)."""


def is_interactable(object_type: str, ontology: Ontology | None = None) -> bool:
    """Types some TEACh action can target (structure and pure decoration are not)."""
    info = (ontology or load_ontology()).get(object_type)
    return not info.structural and any(getattr(info, flag) for flag in AFFORDANCES)


def _box_arrays(objects: list[WorldObject]) -> tuple[np.ndarray, np.ndarray]:
    lo = np.array([o.min_corner for o in objects], dtype=np.float64).reshape(-1, 3)  # [N, 3]
    hi = np.array([o.max_corner for o in objects], dtype=np.float64).reshape(-1, 3)  # [N, 3]
    return lo, hi


def reachable_centres(world: World, grid: np.ndarray) -> np.ndarray:
    """[M, 2] world (x, z) of the reachable cells' centres."""
    ix, iz = np.nonzero(grid)
    xs = world.room.origin[0] + (ix + 0.5) * GRID_STEP_M
    zs = world.room.origin[1] + (iz + 0.5) * GRID_STEP_M
    return np.stack([xs, zs], axis=1)


def _horizontal_distances(cells: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """[N, M] distance in the floor plane from each cell centre to each box's footprint."""
    px, pz = cells[None, :, 0], cells[None, :, 1]  # [1, M]
    dx = np.maximum(np.maximum(lo[:, None, 0] - px, px - hi[:, None, 0]), 0.0)  # [N, M]
    dz = np.maximum(np.maximum(lo[:, None, 2] - pz, pz - hi[:, None, 2]), 0.0)  # [N, M]
    return np.hypot(dx, dz)


def viewable_from(cells: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """[N] bool: the brief's reach rule for boxes lo/hi [N, 3] from cell centres [M, 2]."""
    top_ok = (hi[:, 1] > 0.0) & (hi[:, 1] < VIEW_TOP_MAX_M)  # [N]
    if len(cells) == 0:
        return np.zeros(len(lo), dtype=bool)
    near = (_horizontal_distances(cells, lo, hi) <= VIEW_HORIZONTAL_M).any(axis=1)  # [N]
    return top_ok & near


def seen_through_front(
    cells: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    front: tuple[int, int, float],
    lateral: tuple[float, float],
    ceiling_y: float,
    camera_height: float = CAMERA_HEIGHT_M,
) -> bool:
    """Whether a box lo/hi [3] inside a receptacle with a door shows through its opening, within reach, from
    some cell centre [M, 2] in front of it.

    ``front`` is (axis 0 = x or 2 = z, sign, coordinate) of the front face, ``lateral`` the receptacle's
    extent along the other horizontal axis, ``ceiling_y`` the underside of its top. A box low in a cabinet
    below the eye shows only to a camera far enough back that the ray to the box's near top edge passes
    under the cabinet's top: ``ahead >= inset * (camera - ceiling) / (ceiling - box top)``; a shelf just
    under the top is seen from so far back that it is out of AI2-THOR's reach.
    """
    axis, sign, face = front
    across = 2 - axis
    inset = max(sign * (face - (hi[axis] if sign > 0 else lo[axis])), 0.0)
    rise = camera_height - ceiling_y
    if rise <= 0.0:
        needed = 0.0
    elif hi[1] >= ceiling_y:
        return False
    else:
        needed = inset * rise / (ceiling_y - hi[1])
    along, side = cells[:, axis // 2], cells[:, across // 2]  # [M] each
    ahead = sign * (along - face)  # [M] distance in front of the face
    beside = (side >= lateral[0]) & (side <= lateral[1])
    near = _horizontal_distances(cells, lo[None], hi[None])[0] <= INTERACTION_DISTANCE_M - SIGHT_MARGIN_M
    return bool((beside & near & (ahead >= needed)).any())


def component_count(grid: np.ndarray) -> int:
    """Number of 4-connected pieces of the reachable grid (the agent moves along the grid axes only)."""
    if not grid.any():
        return 0
    n_labels, _ = cv2.connectedComponents(grid.astype(np.uint8), connectivity=4)
    return int(n_labels) - 1


def on_wall(world: World, lo: tuple[float, float, float], hi: tuple[float, float, float]) -> bool:
    """Whether one vertical face of the box lies flush against the room's wall along its whole width."""
    room = world.room
    NX, NZ = room.shape
    ox, oz = room.origin

    def is_floor(ix: int, iz: int) -> bool:
        return 0 <= ix < NX and 0 <= iz < NZ and bool(room.floor[ix, iz])

    def cells(a: float, b: float, origin: float) -> range:
        return range(
            math.floor((a + EPS_M - origin) / GRID_STEP_M), math.floor((b - EPS_M - origin) / GRID_STEP_M) + 1
        )

    for axis, origin in ((0, ox), (2, oz)):
        for face, outward in ((lo[axis], -1), (hi[axis], 1)):
            k = round((face - origin) / GRID_STEP_M)
            if abs(origin + k * GRID_STEP_M - face) > EPS_M:
                continue
            inside, outside = (k - 1, k) if outward == 1 else (k, k - 1)
            other = 2 - axis
            span = cells(lo[other], hi[other], oz if other == 2 else ox)
            if axis == 0:
                pairs = [(is_floor(inside, j), is_floor(outside, j)) for j in span]
            else:
                pairs = [(is_floor(j, inside), is_floor(j, outside)) for j in span]
            if pairs and all(i and not o for i, o in pairs):
                return True
    return False


def _check_parents(world: World, ontology: Ontology) -> list[str]:
    problems: list[str] = []
    for o in world.objects.values():
        if o.object_type not in ontology:
            problems.append(f"{o.object_id}: unknown object type {o.object_type!r}")
            continue
        if o.controls is not None:
            target = world.objects.get(o.controls)
            allowed = CONTROL_TARGETS.get(o.object_type, ())
            if target is None or target.object_type not in allowed:
                problems.append(
                    f"{o.object_id}: controls {o.controls!r}, which is not one of its {allowed or 'none'}"
                )
        if o.parent_id is None:
            continue
        if o.object_id == world.agent.held:
            problems.append(f"{o.object_id}: held but still has parent {o.parent_id}")
        parent = world.objects.get(o.parent_id)
        if parent is None:
            problems.append(f"{o.object_id}: parent {o.parent_id} does not exist")
            continue
        if o.object_id in world.parent_chain(o.object_id):
            problems.append(f"{o.object_id}: parent chain loops")
            continue
        if parent.object_type in ontology and not ontology.accepts(parent.object_type, o.object_type):
            problems.append(
                f"{o.object_id}: incompatible parent {parent.object_type} (ontology does not accept it)"
            )
    if world.agent.held is not None and world.agent.held not in world.objects:
        problems.append(f"agent holds {world.agent.held}, which does not exist")
    return problems


def _check_bounds(world: World, objects: list[WorldObject]) -> list[str]:
    problems: list[str] = []
    room = world.room
    for o in objects:
        (x0, y0, z0), (x1, y1, z1) = o.min_corner, o.max_corner
        ix0, iz0 = room.cell_of(x0 + EPS_M, z0 + EPS_M)
        ix1, iz1 = room.cell_of(x1 - EPS_M, z1 - EPS_M)
        NX, NZ = room.shape
        inside = (
            ix0 >= 0
            and iz0 >= 0
            and ix1 < NX
            and iz1 < NZ
            and bool(room.floor[ix0 : ix1 + 1, iz0 : iz1 + 1].all())
        )
        if not inside:
            problems.append(f"{o.object_id}: footprint leaves the floor (inside a wall or outside the room)")
        if y0 < -EPS_M or y1 > room.wall_height + EPS_M:
            problems.append(
                f"{o.object_id}: spans y {y0:.3f}..{y1:.3f}, outside floor..ceiling {room.wall_height}"
            )
    return problems


def _within_footprint(x: float, z: float, box: WorldObject, margin: float = 0.0) -> bool:
    (x0, _, z0), (x1, _, z1) = box.min_corner, box.max_corner
    return x0 + margin - EPS_M <= x <= x1 - margin + EPS_M and z0 + margin - EPS_M <= z <= z1 - margin + EPS_M


def _check_child_placement(world: World, child: WorldObject, parent: WorldObject) -> list[str]:
    """A child rests on its parent's top, lies in its inner volume, or hangs below it (catalog.placement)."""
    catalog = load_catalog()
    mode = catalog.placement(parent.object_type)
    cx, _, cz = child.center
    if mode == "on":
        if abs(child.bottom - parent.top) > EPS_M or not _within_footprint(cx, cz, parent):
            return [f"{child.object_id}: floating, not resting on top of its parent {parent.object_id}"]
        return []
    if mode == "hanging":
        if abs(child.top - parent.bottom) > EPS_M or not _within_footprint(cx, cz, parent):
            return [f"{child.object_id}: not hanging from its parent {parent.object_id}"]
        return []
    wall = catalog.wall_thickness(parent.object_type)
    (x0, y0, z0), (x1, y1, z1) = child.min_corner, child.max_corner
    footprint_ok = _within_footprint(x0, z0, parent, wall) and _within_footprint(x1, z1, parent, wall)
    height_ok = parent.bottom + wall - EPS_M <= y0 < parent.top
    if load_ontology().get(parent.object_type).openable:
        if not (footprint_ok and height_ok and y1 <= parent.top - wall + EPS_M):
            state = "closed " if not parent.is_open else ""
            return [
                f"{child.object_id}: contents of {state}openable {parent.object_id} not inside its volume"
            ]
        return []
    if not (footprint_ok and height_ok):
        return [f"{child.object_id}: floating, not inside its parent {parent.object_id}"]
    return []


def _support_matrix(free: list[WorldObject]) -> np.ndarray:
    """[N, N] bool: object i is held up by object j (rests on its top, or is a fixture on its side)."""
    catalog = load_catalog()
    lo, hi = _box_arrays(free)
    overlap = np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None])  # [N, N, 3]
    rests = (
        (np.abs(lo[:, None, 1] - hi[None, :, 1]) <= EPS_M)
        & (overlap[..., 0] > EPS_M)
        & (overlap[..., 2] > EPS_M)
    )
    flush_x = (np.abs(lo[:, None, 0] - hi[None, :, 0]) <= EPS_M) | (
        np.abs(hi[:, None, 0] - lo[None, :, 0]) <= EPS_M
    )
    flush_z = (np.abs(lo[:, None, 2] - hi[None, :, 2]) <= EPS_M) | (
        np.abs(hi[:, None, 2] - lo[None, :, 2]) <= EPS_M
    )
    beside_x = flush_x & (overlap[..., 1] > EPS_M) & (overlap[..., 2] > EPS_M)
    beside_z = flush_z & (overlap[..., 1] > EPS_M) & (overlap[..., 0] > EPS_M)
    side_attached = np.array([catalog.side_attached(o.object_type) for o in free], dtype=bool)  # [N]
    holds = rests | (side_attached[:, None] & (beside_x | beside_z))
    np.fill_diagonal(holds, False)
    return holds


def _check_support(world: World, objects: list[WorldObject]) -> list[str]:
    """Parentless objects must stand on the floor, hang on a wall (wall-mountable types only: a lifted fridge
    is floating even with its back to the wall), or rest on (or, for side-attached fixtures, against) another
    supported parentless object; children follow their receptacle's placement."""
    problems: list[str] = []
    free = [o for o in objects if o.parent_id is None]
    if free:
        catalog = load_catalog()
        supported = np.array(
            [
                abs(o.bottom) <= EPS_M
                or (catalog.wall_mountable(o.object_type) and on_wall(world, o.min_corner, o.max_corner))
                for o in free
            ]
        )
        holds = _support_matrix(free)
        while True:
            grown = supported | (holds & supported[None, :]).any(axis=1)
            if (grown == supported).all():
                break
            supported = grown
        problems += [
            f"{o.object_id}: floating, resting on nothing"
            for o, ok in zip(free, supported, strict=True)
            if not ok
        ]
    for o in objects:
        if o.parent_id is not None and o.parent_id in world.objects:
            problems += _check_child_placement(world, o, world.objects[o.parent_id])
    return problems


def _check_overlaps(world: World, objects: list[WorldObject]) -> list[str]:
    """No two boxes interpenetrate, except an object and the receptacles it is in (AI2-THOR's containment)."""
    if len(objects) < 2:
        return []
    lo, hi = _box_arrays(objects)
    overlap = np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None])  # [N, N, 3]
    clash = (overlap > EPS_M).all(axis=2) & np.triu(np.ones((len(objects),) * 2, dtype=bool), k=1)  # [N, N]
    problems = []
    for i, j in zip(*np.nonzero(clash), strict=True):
        a, b = objects[i], objects[j]
        if a.object_id in world.parent_chain(b.object_id) or b.object_id in world.parent_chain(a.object_id):
            continue
        problems.append(f"{a.object_id} overlaps {b.object_id}")
    return problems


def _check_reach(world: World, grid: np.ndarray, ontology: Ontology) -> list[str]:
    problems: list[str] = []
    components = component_count(grid)
    if components == 0:
        return ["no reachable floor cell"]
    if components > 1:
        problems.append(f"reachable area is disconnected ({components} pieces)")
    targets = [
        o
        for o in world.objects.values()
        if o.object_id != world.agent.held
        and o.object_type in ontology
        and is_interactable(o.object_type, ontology)
    ]
    if targets:
        lo, hi = _box_arrays(targets)
        ok = viewable_from(reachable_centres(world, grid), lo, hi)
        problems += [
            f"{o.object_id}: unreachable, no cell to see it from"
            for o, k in zip(targets, ok, strict=True)
            if not k
        ]
    return problems


def _check_agent(world: World, grid: np.ndarray) -> list[str]:
    agent = world.agent
    problems = []
    ix, iz = world.room.cell_of(agent.x, agent.z)
    NX, NZ = grid.shape
    cx, cz = world.room.cell_center(ix, iz)
    if not (0 <= ix < NX and 0 <= iz < NZ and grid[ix, iz]) or abs(cx - agent.x) + abs(cz - agent.z) > EPS_M:
        problems.append(f"agent at ({agent.x}, {agent.z}) is not on a reachable cell centre")
    if agent.yaw % 90 != 0 or not 0 <= agent.yaw < 360:
        problems.append(f"agent yaw {agent.yaw} is not one of 0, 90, 180, 270")
    if not HORIZON_MIN_DEG <= agent.horizon <= HORIZON_MAX_DEG:
        problems.append(f"agent horizon {agent.horizon} outside [{HORIZON_MIN_DEG}, {HORIZON_MAX_DEG}]")
    return problems


def check_world(world: World) -> list[str]:
    """Every problem found, one human-readable line each; an empty list means the world is sound."""
    ontology = load_ontology()
    placed = [o for o in world.objects.values() if o.object_id != world.agent.held]
    grid = reachable_grid(world)
    return (
        _check_parents(world, ontology)
        + _check_bounds(world, placed)
        + _check_support(world, placed)
        + _check_overlaps(world, placed)
        + _check_reach(world, grid, ontology)
        + _check_agent(world, grid)
    )
