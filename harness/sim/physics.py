"""What objects do to each other: AI2-THOR's state-change rules as TEACh enforces them, and where things rest.

Two jobs that every state-changing action shares:

- ``apply_rules`` re-derives the contact states after each change, like TEACh's per-step checks in
  ``SimulatorTHOR.__check_per_step_custom_properties``: a running faucet cleans and fills what is in its
  basin, heat sources cook, a pot of water on heat boils, a coffee machine fills an empty mug, a closed
  fridge chills. Rules only ever set states (AI2-THOR never un-cooks or re-dirties), so applying them
  twice changes nothing.
- Effects with geometry: resting places for Place (a 2D packing of footprints), slices laid out where the
  whole object lay, switching a stove knob together with its burner.

Objects are axis-aligned boxes. How each receptacle holds things (on its top face, inside on its floor or
shelves, hanging below, one slot only) comes from ``harness.world.catalog``, the same table the world
generator and the world checks read; the renderer's ``OPEN_TOP_TYPES`` are the containers with no lid or
ceiling.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np

from harness.render.geometry import OPEN_TOP_TYPES
from harness.world.catalog import load_catalog
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology

Rule = Callable[[World, Ontology], None]
Vec3 = tuple[float, float, float]

PACKING_STEP_M = 0.025
"""Spacing of the candidate centres tried when packing footprints onto a surface."""

SINK_TYPES = frozenset({"SinkBasin", "Sink", "BathtubBasin", "Bathtub"})
"""Where a running faucet's water lands (TEACh treats a sink and its basin alike, and so a bathtub)."""

SLICE_COUNTS: dict[str, int] = {"Bread": 7, "Tomato": 6, "Lettuce": 6, "Apple": 4, "Potato": 5, "Egg": 1}
"""How many pieces Slice makes, close to AI2-THOR's sliced prefabs (an Egg cracks into one EggCracked)."""


def encloses(receptacle_type: str, ontology: Ontology) -> bool:
    """Receptacles whose contents sit behind a door or lid (Fridge, Cabinet, Drawer, Microwave, Safe, Box:
    ALFRED's OPENABLE_CLASS_LIST); a Toilet opens too, but things rest on it either way."""
    return ontology.get(receptacle_type).openable and load_catalog().placement(receptacle_type) == "inside"


def descendants(world: World, object_id: str) -> list[WorldObject]:
    """Everything resting in or on the object, directly or through other receptacles."""
    found: list[WorldObject] = []
    frontier = [object_id]
    while frontier:
        current = frontier.pop()
        for child in world.children(current):
            found.append(child)
            frontier.append(child.object_id)
    return found


def move_with_contents(world: World, obj: WorldObject, center: Vec3) -> None:
    """Put ``obj`` at ``center`` and carry what rests on it along (a plate keeps its slice)."""
    delta = tuple(new - old for new, old in zip(center, obj.center, strict=True))
    for moved in [obj, *descendants(world, obj.object_id)]:
        moved.center = tuple(c + d for c, d in zip(moved.center, delta, strict=True))  # type: ignore[assignment]


def resting_center(
    world: World,
    obj: WorldObject,
    receptacle: WorldObject,
    near: Vec3 | None = None,
    may_turn: bool = True,
) -> tuple[Vec3, Vec3] | None:
    """Where ``obj`` can rest in/on ``receptacle`` without overlapping anything, or None if there is no room.

    How the receptacle holds things (on its top, inside on its floor or shelves, hanging below it, one
    slot only) is the catalog's, so placed objects sit as generated ones do and pass the same world
    checks. Anything but the receptacle and what holds it is in the way (a burner set into the counter,
    a plant on the table). Returns the centre and the object's size: it may turn 90° about the vertical
    to fit, and stand upright in an open container (a fork in a mug), unless ``may_turn`` is False (a
    plate carrying a slice is not turned under it). Among free spots the one nearest ``near`` (the
    clicked point; TEACh places near the click) wins; without a click, or with one on the receptacle's
    outside rather than over its surface, the one nearest its centre.
    """
    catalog = load_catalog()
    kind = receptacle.object_type
    mode = catalog.placement(kind)
    if catalog.single_slot(kind) or mode == "hanging":  # a towel bar holds one towel
        occupied = any(c.object_id != obj.object_id for c in world.children(receptacle.object_id))
        return None if occupied else (_slot_center(obj, receptacle, mode), obj.size)
    target = near if near is not None else receptacle.center
    (x0, y0, z0), (x1, y1, z1) = receptacle.min_corner, receptacle.max_corner
    shelves: list[tuple[float, float]] = [(y1, math.inf)]  # (floor height, height of what bounds it above)
    if mode == "inside":
        wall = catalog.wall_thickness(kind)
        x0, z0, x1, z1 = x0 + wall, z0 + wall, x1 - wall, z1 - wall
        enclosed = kind not in OPEN_TOP_TYPES  # walls and a ceiling bound what fits
        spacing = catalog.shelf_spacing(kind)
        floors = [y0 + wall]
        while spacing is not None and floors[-1] + spacing < y1 - wall:
            floors.append(floors[-1] + spacing)
        ceilings = [*floors[1:], y1 - wall] if enclosed else [math.inf] * len(floors)
        shelves = sorted(zip(floors, ceilings, strict=True), key=lambda shelf: abs(shelf[0] - target[1]))
    if not (x0 <= target[0] <= x1 and z0 <= target[2] <= z1):
        target = receptacle.center  # clicked its outside (a basin's front wall): aim for the middle
    ignored = {obj.object_id, receptacle.object_id, *world.parent_chain(receptacle.object_id)}
    ignored.update(d.object_id for d in descendants(world, obj.object_id))
    others = [o for o in world.objects.values() if o.object_id not in ignored]
    for floor_y, ceiling_y in shelves:
        for size in _orientations(obj.size, may_turn, upright=mode == "inside" and kind in OPEN_TOP_TYPES):
            fx, fy, fz = size
            if floor_y + fy > ceiling_y + 1e-9 or (mode == "inside" and (fx > x1 - x0 or fz > z1 - z0)):
                continue
            in_the_way = [o for o in others if o.bottom < floor_y + fy - 1e-6 and o.top > floor_y + 1e-6]
            spot = _free_spot((x0, z0, x1, z1), (fx, fz), in_the_way, (target[0], target[2]))
            if spot is not None and _over_floor(world, spot, (fx, fz)):
                return (spot[0], floor_y + fy / 2, spot[1]), size
    return None


def _over_floor(world: World, spot: tuple[float, float], footprint: tuple[float, float]) -> bool:
    """Whether a footprint centred at ``spot`` stays over the room's floor: something longer than a narrow
    surface overhangs it (a knife across a sink's deck), and must not overhang into a wall."""
    (cx, cz), (fx, fz) = spot, footprint
    return all(
        world.room.contains(cx + sx * fx / 2, cz + sz * fz / 2)
        for sx in (-0.999, 0.999)
        for sz in (-0.999, 0.999)
    )


def _orientations(size: Vec3, may_turn: bool, upright: bool) -> list[Vec3]:
    """Box sizes to try, in order: as it is, turned 90° about the vertical, then (if ``upright``) standing
    on its smallest face, as a spoon stands in a cup."""
    sx, sy, sz = size
    if not may_turn:
        return [size]
    tries = [size, (sz, sy, sx)]
    if upright:
        small, middle, large = sorted(size)
        tries += [(middle, large, small), (small, large, middle)]
    return list(dict.fromkeys(tries))


def _slot_center(obj: WorldObject, slot: WorldObject, mode: str) -> Vec3:
    """The one place of a single-slot receptacle: a pan on a burner, a towel below its bar, a mug on the
    coffee machine's floor; a toaster's slice stands half out of its top, as in AI2-THOR."""
    cx, _, cz = slot.center
    h = obj.size[1]
    if slot.object_type == "Toaster":
        return (cx, slot.top, cz)
    if mode == "hanging":
        return (cx, slot.bottom - h / 2, cz)
    if mode == "inside":
        return (cx, slot.bottom + load_catalog().wall_thickness(slot.object_type) + h / 2, cz)
    return (cx, slot.top + h / 2, cz)


def _free_spot(
    region: tuple[float, float, float, float],
    footprint: tuple[float, float],
    others: list[WorldObject],
    target: tuple[float, float],
) -> tuple[float, float] | None:
    """The candidate centre nearest ``target`` whose footprint overlaps none of ``others``."""
    x0, z0, x1, z1 = region
    fx, fz = footprint
    xs = _centres(x0 + fx / 2, x1 - fx / 2)  # [NX]
    zs = _centres(z0 + fz / 2, z1 - fz / 2)  # [NZ]
    cx, cz = (a.ravel() for a in np.meshgrid(xs, zs, indexing="ij"))  # [C] each
    free = np.ones(cx.shape, dtype=bool)
    for other in others:
        ox, _, oz = other.center
        overlap_x = np.abs(cx - ox) < (fx + other.size[0]) / 2 - 1e-6
        overlap_z = np.abs(cz - oz) < (fz + other.size[2]) / 2 - 1e-6
        free &= ~(overlap_x & overlap_z)
    if not free.any():
        return None
    d2 = np.where(free, (cx - target[0]) ** 2 + (cz - target[1]) ** 2, np.inf)  # [C]
    best = int(np.argmin(d2))
    return float(cx[best]), float(cz[best])


def _centres(lo: float, hi: float) -> np.ndarray:
    """Centres from lo to hi every PACKING_STEP_M, centred; the midpoint when the object overhangs."""
    if hi < lo:
        return np.array([(lo + hi) / 2])
    n = int(math.floor((hi - lo) / PACKING_STEP_M + 1e-9)) + 1
    return lo + PACKING_STEP_M * np.arange(n) + ((hi - lo) - PACKING_STEP_M * (n - 1)) / 2


def slice_object(world: World, obj: WorldObject, ontology: Ontology) -> list[WorldObject]:
    """Replace a sliceable object by its pieces, laid side by side across its old footprint.

    AI2-THOR disables the whole object and spawns ``<id>|<Type>Sliced_<n>`` pieces; TEACh then checks the
    pieces' type (BreadSliced...). We drop the whole object from the world for the same reason, so a task
    counting "Bread" no longer finds it. Pieces inherit its states and its receptacle.
    """
    piece_type = ontology.get(obj.object_type).sliced_into
    if piece_type is None:
        raise ValueError(f"{obj.object_type} has no sliced form in the ontology")
    if obj.object_type not in SLICE_COUNTS:
        raise KeyError(f"no slice count for {obj.object_type}; known: {sorted(SLICE_COUNTS)}")
    count = SLICE_COUNTS[obj.object_type]
    sx, sy, sz = obj.size
    along_x = sx >= sz
    length = sx if along_x else sz
    start = obj.min_corner[0] if along_x else obj.min_corner[2]
    pieces = []
    for i in range(count):
        offset = start + (i + 0.5) * length / count
        if count == 1:  # a cracked egg: as wide as the egg, half as tall, resting where it rested
            size = (sx, sy / 2, sz)
            center = (obj.center[0], obj.bottom + sy / 4, obj.center[2])
        elif along_x:
            size, center = (sx / count, sy, sz), (offset, obj.center[1], obj.center[2])
        else:
            size, center = (sx, sy, sz / count), (obj.center[0], obj.center[1], offset)
        pieces.append(
            replace(
                obj,
                object_id=f"{obj.object_id}|{piece_type}_{i + 1}",
                object_type=piece_type,
                center=center,
                size=size,
                is_sliced=False,
            )
        )
    world.remove(obj.object_id)
    for piece in pieces:
        world.add(piece)
    return pieces


def set_toggled(world: World, obj: WorldObject, on: bool) -> None:
    """Switch an object; a StoveKnob and the StoveBurner it controls always switch together.

    AI2-THOR heats a burner through its knob (the knob's ``controlledObjects``); keeping both in step
    means either one can be used and a task checking either sees the same state.
    """
    obj.is_toggled = on
    if obj.object_type == "StoveKnob" and obj.controls in world.objects:
        world.objects[obj.controls].is_toggled = on
    if obj.object_type == "StoveBurner":
        for knob in world.of_type("StoveKnob"):
            if knob.controls == obj.object_id:
                knob.is_toggled = on


def running_sinks(world: World) -> set[str]:
    """Sinks and basins whose faucet is on: the faucet that ``controls`` them, else the nearest faucet
    (TEACh's ``__update_sink_interaction_outcomes`` pairs each sink with the faucet nearest to it)."""
    faucets = world.of_type("Faucet")
    running = set()
    for sink in world.objects.values():
        if sink.object_type not in SINK_TYPES or not faucets:
            continue
        controlling = [f for f in faucets if f.controls == sink.object_id]
        faucet = controlling[0] if controlling else min(faucets, key=lambda f: _distance(f, sink))
        if faucet.is_toggled:
            running.add(sink.object_id)
    return running


def _distance(a: WorldObject, b: WorldObject) -> float:
    return math.dist(a.center, b.center)


def _contained(world: World, ids: set[str]) -> Iterator[tuple[WorldObject, list[str]]]:
    """Objects somewhere inside one of ``ids``, with their receptacle chain (innermost first)."""
    if not ids:
        return
    for obj in list(world.objects.values()):
        chain = world.parent_chain(obj.object_id)
        if ids.intersection(chain):
            yield obj, chain


def rule_sink(world: World, ontology: Ontology) -> None:
    """A running faucet cleans everything in its basin and fills every container there with water."""
    for obj, _ in _contained(world, running_sinks(world)):
        info = ontology.get(obj.object_type)
        obj.is_dirty = False
        if info.dirtyable or info.cleanable:
            obj.is_cleaned = True
        if info.fillable:
            obj.liquid = "water"


def heat_sources(world: World) -> set[str]:
    """Microwaves on and shut, burners on, toasters on."""
    hot = set()
    for obj in world.objects.values():
        if not obj.is_toggled:
            continue
        if obj.object_type in ("StoveBurner", "Toaster") or (
            obj.object_type == "Microwave" and not obj.is_open
        ):
            hot.add(obj.object_id)
    return hot


def rule_heat(world: World, ontology: Ontology) -> None:
    """Cookable things anywhere inside a heat source cook (a potato in a pot on a lit burner, bread in a
    toaster); cooked in a container of liquid is boiled, as TEACh's ``simbotIsBoiled`` rule has it."""
    for obj, chain in _contained(world, heat_sources(world)):
        info = ontology.get(obj.object_type)
        if info.heatable:
            obj.is_heated = True
            obj.is_cooled = False
        if not info.cookable:
            continue
        obj.is_cooked = True
        obj.is_cooled = False
        if any(world.objects[r].is_filled for r in chain):
            obj.is_boiled = True


def rule_coffee(world: World, ontology: Ontology) -> None:
    """A coffee machine that is on fills an empty container in it with coffee.

    TEACh only flags ``simbotIsFilledWithCoffee`` when the mug was empty before (a mug already holding water
    keeps its water), and AI2-THOR does not care whether the mug is dirty.
    """
    machines = {m.object_id for m in world.of_type("CoffeeMachine") if m.is_toggled}
    for obj, _ in _contained(world, machines):
        if ontology.get(obj.object_type).fillable and obj.liquid is None:
            obj.liquid = "coffee"


def rule_fridge(world: World, ontology: Ontology) -> None:
    """Everything inside a closed fridge is chilled (ALFRED's cooled-objects set)."""
    fridges = {f.object_id for f in world.of_type("Fridge") if not f.is_open}
    for obj, _ in _contained(world, fridges):
        obj.is_cooled = True


RULES: tuple[Rule, ...] = (rule_sink, rule_coffee, rule_heat, rule_fridge)
"""Applied in this order: water first, so a pot filled this step boils this step."""


def apply_rules(world: World, ontology: Ontology) -> None:
    """Bring contact states up to date after any change (idempotent)."""
    for rule in RULES:
        rule(world, ontology)
