"""Passes 3 and 4: small objects into receptacles the ontology allows (some in closed openables, dirty or
filled), then the agent on a reachable cell facing away from some task-relevant object."""

from __future__ import annotations

import math

import numpy as np

from harness.render.geometry import SLIDING_TYPES
from harness.sim.navgrid import reachable_grid
from harness.world.catalog import ObjectSpec
from harness.world.invariants import EPS_M, seen_through_front, viewable_from
from harness.world.model import AgentState, World, WorldObject, make_object_id
from harness.world.procedural.builder import SURFACE_MARGIN_M, Builder
from harness.world.procedural.config import Retry
from harness.world.walls import AXES
from symbolic.ontology import load_ontology
from symbolic.thor import GRID_STEP_M, TEACH_HFOV_DEG

PLACEMENT_TRIES = 12
"""Random positions tried for one object on one receptacle."""


# --------------------------------------------------------------------------------------------- small objects


def _inner_levels(b: Builder, host: WorldObject) -> list[tuple[float, float | None]]:
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
    b: Builder, host: WorldObject, lo: tuple[float, ...], hi: tuple[float, ...], cells: np.ndarray
) -> bool:
    """Inside a fridge, cabinet or microwave, the object must show through the open door from a reachable
    cell within reach (``invariants.seen_through_front``): a plate at the back of a low cabinet's top shelf
    is seen only from too far away. Drawers slide out and show everything from above."""
    if not b.has_door(host) or host.object_type in SLIDING_TYPES:
        return True
    (_, _), (fx, fz) = AXES[host.facing % 360]
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
    b: Builder, object_type: str, size: tuple[float, float, float], host: WorldObject, cells: np.ndarray
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


def _start_states(b: Builder, obj: WorldObject) -> None:
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
    b: Builder, object_type: str, where: tuple[tuple[str, float], ...], cells: np.ndarray
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


def _object_plan(b: Builder, furniture_types: frozenset[str]) -> list[tuple[ObjectSpec, int, int]]:
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


def place_objects(b: Builder) -> None:
    cells = b.reachable_cells()
    for spec, count, least in _object_plan(b, b.spec.furniture_types):
        for i in range(count):
            if not _place_object(b, spec.object_type, spec.where, cells):
                if i < least:
                    raise Retry(f"no room for {spec.object_type} #{i + 1}")
                break


# ------------------------------------------------------------------------------------------------ the agent


def _in_closed_openable(world: World, obj: WorldObject) -> bool:
    ontology = load_ontology()
    return any(
        ontology.get(world.objects[p].object_type).openable and not world.objects[p].is_open
        for p in world.parent_chain(obj.object_id)
    )


def _in_view(x: float, z: float, yaw: int, obj: WorldObject) -> bool:
    """Inside the horizontal field of view of TEACh's camera (90 degrees) from (x, z) facing ``yaw``."""
    fx, fz = AXES[yaw][1]
    dx, dz = obj.center[0] - x, obj.center[2] - z
    norm = math.hypot(dx, dz)
    return norm < 1e-9 or (dx * fx + dz * fz) / norm >= math.cos(math.radians(TEACH_HFOV_DEG / 2))


def place_agent(b: Builder, task_types: set[str]) -> None:
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
            fx, fz = AXES[yaw][1]
            ahead = world.room.cell_of(x + fx * GRID_STEP_M, z + fz * GRID_STEP_M)
            free_ahead = 0 <= ahead[0] < grid.shape[0] and 0 <= ahead[1] < grid.shape[1] and bool(grid[ahead])
            hidden = any(not _in_view(x, z, yaw, o) for o in targets)
            score = 2 * hidden + free_ahead
            if best is None or score > best[0]:
                best = (score, x, z, yaw)
        if best is not None and best[0] == 3:
            break
    if best is None:
        raise Retry("no reachable cell for the agent")
    _, x, z, yaw = best
    world.agent = AgentState(x=x, z=z, yaw=yaw, horizon=0.0)
