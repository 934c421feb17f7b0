"""Stage 4, objects: every ALFRED object pose into or onto the accepting receptacle nearest it, else onto
the floor, with ALFRED's start states."""

from __future__ import annotations

import math

import numpy as np

from harness.sim.navgrid import reachable_grid
from harness.sim.physics import resting_center
from harness.world.alfred.pieces import (
    FLOOR_OBJECT_MAX_Y_M,
    RELOCATE_M,
    SEARCH_STEP_M,
    THIN_CLEARANCE_M,
    TOP_BAND_ABOVE_M,
    Build,
    Vec3,
    in_reach,
)
from harness.world.alfred.room import on_floor
from harness.world.catalog import Catalog, load_catalog
from harness.world.invariants import EPS_M, reachable_centres
from harness.world.model import Room, World, WorldObject, make_object_id
from symbolic.thor import GRID_STEP_M

_COPY = "|copy"
"""Marks the second instance of a pose ALFRED lists twice until it is placed and named."""


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
    if not (on_floor(world.room, lo, hi) and hi[1] <= world.room.wall_height and in_reach(cells, lo, hi)):
        return False
    holders = set(world.parent_chain(parent)) | {parent} if parent is not None else set()
    others = [o for o in world.objects.values() if o.object_id not in holders]
    if not others:
        return True
    o_lo = np.array([o.min_corner for o in others])  # [N, 3]
    o_hi = np.array([o.max_corner for o in others])  # [N, 3]
    overlap = np.minimum(o_hi, np.array(hi)) - np.maximum(o_lo, np.array(lo))  # [N, 3]
    return not bool((overlap > EPS_M).all(axis=1).any())


def _on_the_floor(b: Build, world: World, obj: WorldObject, cells: np.ndarray, near: Vec3) -> bool:
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


def _start_state(b: Build, obj: WorldObject) -> None:
    """ALFRED's dirty_and_empty: every dish dirty and every container empty; otherwise clean (and empty, as
    AI2-THOR's scenes start)."""
    info = b.ontology.get(obj.object_type)
    obj.is_dirty = b.scene.dirty_and_empty and info.dirtyable
    obj.liquid = None


def place_objects(b: Build, world: World) -> None:
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
