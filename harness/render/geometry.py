"""From a world to what the renderer draws: axis-aligned boxes with an instance id and a look.

Every object is its box, except where AI2-THOR would show more: an open fridge or cabinet is a hollow
shell with its door swung out beside the front face (so what is inside shows), an open drawer slides out
with its contents, basins, bowls, pots, pans and cups are open-topped (so what is in them shows, liquid
included), a coffee machine's nook is open at the front (so the mug in it shows), and the held object
floats in front of the camera as AI2-THOR draws the agent's hand-held object. Panels are as thick as the
catalog's walls, so what rests on a receptacle's inner floor lies on the drawn floor. Walls stand on the
boundary of the room's floor cells.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from harness.render.appearance import Surface, surface_of
from harness.render.camera import CameraPose, camera_to_world
from harness.world.catalog import load_catalog
from harness.world.model import STRUCTURE_IDS, Room, World, WorldObject
from symbolic.thor import GRID_STEP_M

Vec3 = tuple[float, float, float]

WALL_THICKNESS_M = 0.05  # walls extend this far outwards from the floor boundary
WALL_END_OVERLAP_M = 0.001  # wall segments overlap at their ends so no ray slips through a corner
WALL_OVERHANG_M = 0.05  # walls reach this far below the floor and above the ceiling, closing those edges too
SHELL_THICKNESS_M = 0.025  # panels of open receptacles and open-topped containers
MIN_PANEL_FRACTION = 0.2  # a panel is never thicker than this share of the box along its axis
DRAWER_SLIDE_FRACTION = 0.7  # an open drawer slides out by this share of its depth
LIQUID_LEVEL = 0.7  # liquid fills this share of an open-topped container's inner height
HAND_OFFSET_M: Vec3 = (0.13, 0.13, 0.45)  # held object centre in the camera frame: right, down, forward
HAND_MAX_EXTENT_M = 0.2  # a held object is scaled down so its largest side fits this

OPEN_TOP_TYPES = frozenset(
    {
        "Sink",
        "SinkBasin",
        "Bathtub",
        "BathtubBasin",
        "Bowl",
        "Pot",
        "Pan",
        "Cup",
        "Mug",
        "GarbageCan",
        "LaundryHamper",
    }
)
"""Containers whose contents are seen from above: drawn as a bottom and four walls."""

SLIDING_TYPES = frozenset({"Drawer"})
"""Openables that slide out rather than swing a door (AI2-THOR's drawers)."""

NOOK_TYPES = frozenset({"CoffeeMachine"})
"""Appliances whose slot is open at the front, as AI2-THOR's coffee machines are (the mug stands in a nook
under the spout, in plain view): drawn as a shell with no front panel, so what stands in them shows."""


@dataclass(frozen=True)
class Box:
    """One drawable axis-aligned box (world metres)."""

    instance_id: int
    lo: Vec3
    hi: Vec3
    surface: Surface
    in_hand: bool = False  # drawn over the scene, like AI2-THOR's held object that never hides behind walls


@dataclass(frozen=True)
class DrawTransform:
    """Where an object is drawn if not where it is: p -> target + (p - pivot) * scale."""

    pivot: Vec3
    target: Vec3
    scale: float
    in_hand: bool

    def apply(self, point: Vec3) -> Vec3:
        return tuple(t + (p - c) * self.scale for p, c, t in zip(point, self.pivot, self.target, strict=True))  # type: ignore[return-value]


def primitives(world: World) -> list[Box]:
    """Walls, then every object's boxes, in the world's object order (earlier wins exact depth ties)."""
    boxes = wall_boxes(world.room, world.name)
    camera = CameraPose.of_agent(world.agent)
    hand = _hand_placement(world, camera)
    for obj in world.objects.values():
        placement = _placement_of(world, obj, hand)
        if placement is None and _hidden_in_closed_receptacle(world, obj, camera.position):
            continue
        assert obj.object_id in world.instance_ids, f"{obj.object_id} has no instance id (use World.add)"
        boxes.extend(_object_boxes(obj, world.instance_ids[obj.object_id], placement))
    return boxes


def wall_boxes(room: Room, world_name: str) -> list[Box]:
    """Thin boxes outside every boundary between floor and non-floor cells, merged into long segments.

    ``world_name`` keys the walls' tint, so paint varies between worlds as it does between AI2-THOR scenes.
    """
    wall = STRUCTURE_IDS["Wall"]
    surface = Surface(object_type="Wall", instance_key=world_name)
    bottom, top = -WALL_OVERHANG_M, room.wall_height + WALL_OVERHANG_M
    ox, oz = room.origin
    g = GRID_STEP_M
    t = WALL_THICKNESS_M
    e = WALL_END_OVERLAP_M
    padded = np.pad(room.floor, 1, constant_values=False)  # [NX+2, NZ+2]
    inner = padded[1:-1, 1:-1]
    boxes: list[Box] = []
    # Faces normal to x: the neighbour at ix+side is not floor.
    for side in (-1, 1):
        open_side = inner & ~padded[1 + side : padded.shape[0] - 1 + side, 1:-1]  # [NX, NZ]
        for ix, (z0, z1) in _runs(open_side):
            x = ox + (ix + (side > 0)) * g
            x_lo, x_hi = (x, x + t) if side > 0 else (x - t, x)
            boxes.append(Box(wall, (x_lo, bottom, oz + z0 * g - e), (x_hi, top, oz + z1 * g + e), surface))
    # Faces normal to z: the neighbour at iz+side is not floor.
    for side in (-1, 1):
        open_side = inner & ~padded[1:-1, 1 + side : padded.shape[1] - 1 + side]
        for iz, (x0, x1) in _runs(open_side.T):
            z = oz + (iz + (side > 0)) * g
            z_lo, z_hi = (z, z + t) if side > 0 else (z - t, z)
            boxes.append(Box(wall, (ox + x0 * g - e, bottom, z_lo), (ox + x1 * g + e, top, z_hi), surface))
    return boxes


def _runs(mask: np.ndarray) -> list[tuple[int, tuple[int, int]]]:
    """(row, (start, stop)) of every maximal run of True along each row of a 2D bool array."""
    runs: list[tuple[int, tuple[int, int]]] = []
    for row, line in enumerate(mask):
        edges = np.flatnonzero(np.diff(np.concatenate(([0], line.astype(np.int8), [0]))))
        runs.extend((row, (int(a), int(b))) for a, b in zip(edges[::2], edges[1::2], strict=True))
    return runs


def _hand_placement(world: World, camera: CameraPose) -> DrawTransform | None:
    """Held object in front of the eye, slightly right and below, shrunk to fit the view."""
    held = world.held_object()
    if held is None:
        return None
    offset = camera_to_world(camera) @ np.array(HAND_OFFSET_M)
    target = camera.position + offset
    scale = min(1.0, HAND_MAX_EXTENT_M / max(held.size))
    return DrawTransform(pivot=held.center, target=tuple(float(v) for v in target), scale=scale, in_hand=True)  # type: ignore[arg-type]


def _slide_placement(drawer: WorldObject) -> DrawTransform:
    """An open drawer and its contents, moved out along the drawer's facing by part of its depth."""
    axis, sign = _facing_axis(drawer.facing)
    shift = [0.0, 0.0, 0.0]
    shift[axis] = sign * DRAWER_SLIDE_FRACTION * drawer.size[axis]
    return DrawTransform(
        pivot=(0.0, 0.0, 0.0), target=(shift[0], shift[1], shift[2]), scale=1.0, in_hand=False
    )


def _placement_of(world: World, obj: WorldObject, hand: DrawTransform | None) -> DrawTransform | None:
    """The innermost moved thing (held object, open drawer) among the object and its receptacles decides."""
    for object_id in [obj.object_id, *world.parent_chain(obj.object_id)]:
        if object_id == world.agent.held:
            return hand
        owner = world.objects.get(object_id)
        if owner is not None and owner.is_open and owner.object_type in SLIDING_TYPES:
            return _slide_placement(owner)
    return None


def _is_drawn_solid(obj: WorldObject) -> bool:
    return not obj.is_open and obj.object_type not in OPEN_TOP_TYPES | NOOK_TYPES


def _hidden_in_closed_receptacle(world: World, obj: WorldObject, camera: np.ndarray) -> bool:
    """Inside a solid box the camera is outside of: a z-buffer would never show it, so skip drawing it."""
    lo, hi = np.array(obj.min_corner), np.array(obj.max_corner)
    for receptacle_id in world.parent_chain(obj.object_id):
        receptacle = world.objects.get(receptacle_id)
        if receptacle is None or not _is_drawn_solid(receptacle):
            continue
        r_lo, r_hi = np.array(receptacle.min_corner), np.array(receptacle.max_corner)
        encloses = bool(np.all(lo >= r_lo - 1e-6) and np.all(hi <= r_hi + 1e-6))
        camera_outside = bool(np.any(camera < r_lo) or np.any(camera > r_hi))
        if encloses and camera_outside:
            return True
    return False


def _facing_axis(facing: int) -> tuple[int, int]:
    """(world axis, sign) of the direction a yaw faces: 0 -> +z, 90 -> +x, 180 -> -z, 270 -> -x."""
    yaw = facing % 360
    assert yaw in (0, 90, 180, 270), f"facing must be a multiple of 90, got {facing}"
    return {0: (2, 1), 90: (0, 1), 180: (2, -1), 270: (0, -1)}[yaw]


def _wall_of(object_type: str) -> float:
    """How thick an open receptacle's or container's panels are drawn: the catalog's wall thickness for
    receptacles that hold things inside (so a thin knife at the bottom of a garbage can lies on the drawn
    floor, not buried in it), SHELL_THICKNESS_M for the rest."""
    catalog = load_catalog()
    return (
        catalog.wall_thickness(object_type)
        if catalog.placement(object_type) == "inside"
        else SHELL_THICKNESS_M
    )


def _panel(lo: Vec3, hi: Vec3, axis: int, side: int, wall: float) -> tuple[Vec3, Vec3]:
    """The slab of a box along one face: ``wall`` thick (thinner for small boxes)."""
    thickness = min(wall, MIN_PANEL_FRACTION * (hi[axis] - lo[axis]))
    p_lo, p_hi = list(lo), list(hi)
    if side > 0:
        p_lo[axis] = hi[axis] - thickness
    else:
        p_hi[axis] = lo[axis] + thickness
    return (p_lo[0], p_lo[1], p_lo[2]), (p_hi[0], p_hi[1], p_hi[2])


def _open_top_panels(lo: Vec3, hi: Vec3, wall: float) -> list[tuple[Vec3, Vec3]]:
    """Bottom and four walls."""
    return [_panel(lo, hi, 1, -1, wall)] + [
        _panel(lo, hi, axis, side, wall) for axis in (0, 2) for side in (-1, 1)
    ]


def _shell_panels(lo: Vec3, hi: Vec3, facing: int, wall: float) -> list[tuple[Vec3, Vec3]]:
    """Back, sides, top and bottom of a receptacle whose front (the face its facing yaw points to) is open."""
    front_axis, front_sign = _facing_axis(facing)
    side_axis = 2 - front_axis  # the other horizontal axis
    panels = [_panel(lo, hi, front_axis, -front_sign, wall), _panel(lo, hi, 1, -1, wall)]
    return panels + [_panel(lo, hi, 1, 1, wall)] + [_panel(lo, hi, side_axis, s, wall) for s in (-1, 1)]


def _door_panel(lo: Vec3, hi: Vec3, facing: int) -> tuple[Vec3, Vec3]:
    """An open receptacle's door, swung 90° out of the front face.

    The hinge is on the receptacle's own right (the right of its facing yaw θ is (cos θ, 0, -sin θ)).
    """
    front_axis, front_sign = _facing_axis(facing)
    side_axis = 2 - front_axis
    right_sign = {0: 1, 90: -1, 180: -1, 270: 1}[facing % 360]
    width = hi[side_axis] - lo[side_axis]
    thickness = min(SHELL_THICKNESS_M, MIN_PANEL_FRACTION * width)
    front = hi[front_axis] if front_sign > 0 else lo[front_axis]
    hinge = hi[side_axis] if right_sign > 0 else lo[side_axis]
    door_lo, door_hi = list(lo), list(hi)
    door_lo[front_axis], door_hi[front_axis] = sorted((front, front + front_sign * width))
    door_lo[side_axis], door_hi[side_axis] = sorted((hinge, hinge + right_sign * thickness))
    return (door_lo[0], door_lo[1], door_lo[2]), (door_hi[0], door_hi[1], door_hi[2])


def _liquid_layer(lo: Vec3, hi: Vec3, wall: float) -> tuple[Vec3, Vec3]:
    """The liquid inside an open-topped container: between its walls, up to LIQUID_LEVEL of the inside."""
    floor_y = _panel(lo, hi, 1, -1, wall)[1][1]  # top of the bottom panel
    layer_lo, layer_hi = list(lo), list(hi)
    for axis in (0, 2):
        side = min(wall, MIN_PANEL_FRACTION * (hi[axis] - lo[axis]))
        layer_lo[axis], layer_hi[axis] = lo[axis] + side, hi[axis] - side
    layer_lo[1] = floor_y
    layer_hi[1] = floor_y + LIQUID_LEVEL * (hi[1] - floor_y)
    return (layer_lo[0], layer_lo[1], layer_lo[2]), (layer_hi[0], layer_hi[1], layer_hi[2])


def _object_boxes(obj: WorldObject, instance_id: int, placement: DrawTransform | None) -> list[Box]:
    surface = surface_of(obj)
    lo, hi = obj.min_corner, obj.max_corner
    wall = _wall_of(obj.object_type)
    parts: list[tuple[Vec3, Vec3, Surface]]
    if obj.is_open and obj.object_type in SLIDING_TYPES:
        parts = [(p_lo, p_hi, surface) for p_lo, p_hi in _open_top_panels(lo, hi, wall)]
    elif obj.is_open:
        panels = [*_shell_panels(lo, hi, obj.facing, wall), _door_panel(lo, hi, obj.facing)]
        parts = [(p_lo, p_hi, surface) for p_lo, p_hi in panels]
    elif obj.object_type in NOOK_TYPES:
        parts = [(p_lo, p_hi, surface) for p_lo, p_hi in _shell_panels(lo, hi, obj.facing, wall)]
    elif obj.object_type in OPEN_TOP_TYPES:
        body = replace(surface, liquid=None)
        parts = [(p_lo, p_hi, body) for p_lo, p_hi in _open_top_panels(lo, hi, wall)]
        if obj.liquid is not None:
            liquid = Surface(object_type=obj.object_type, instance_key=obj.object_id, liquid=obj.liquid)
            parts.append((*_liquid_layer(lo, hi, wall), replace(liquid, liquid_layer=True)))
    else:
        parts = [(lo, hi, surface)]
    if placement is None:
        return [Box(instance_id, p_lo, p_hi, s) for p_lo, p_hi, s in parts]
    return [
        Box(instance_id, placement.apply(p_lo), placement.apply(p_hi), s, in_hand=placement.in_hand)
        for p_lo, p_hi, s in parts
    ]
