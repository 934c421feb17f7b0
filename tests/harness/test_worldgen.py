"""The procedural room generator and the world checks it must pass (issue 3 §1, first bullet)."""

from __future__ import annotations

import functools
import statistics
import time
from collections.abc import Callable
from typing import get_args

import cv2
import numpy as np
import pytest

from harness.expert.navigation import SightOracle
from harness.render.camera import CameraSpec
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.sim.physics import encloses
from harness.world.catalog import load_catalog
from harness.world.invariants import check_world, component_count, seen_through_front
from harness.world.model import AgentState, Room, RoomKind, World, WorldObject, make_object_id
from harness.world.procedural.config import WorldGenConfig, WorldGenError
from harness.world.procedural.furniture import STRATEGIES
from harness.world.procedural.generate import (
    generate_bathroom,
    generate_bedroom,
    generate_kitchen,
    generate_living_room,
    generate_world,
)
from harness.world.walls import walls_of
from symbolic.ontology import UnknownObjectType, load_ontology
from symbolic.registry import UnknownName
from symbolic.thor import GRID_STEP_M, TEACH_HFOV_DEG

KINDS: tuple[RoomKind, ...] = get_args(RoomKind)
SEEDS = range(20)


@functools.cache
def world_for(kind: RoomKind, seed: int) -> World:
    """Generated once per test session; tests that mutate a world copy it first."""
    return generate_world(WorldGenConfig(kind, seed))


def in_closed_openable(world: World, obj: WorldObject) -> bool:
    onto = load_ontology()
    return any(
        onto.get(world.objects[p].object_type).openable and not world.objects[p].is_open
        for p in world.parent_chain(obj.object_id)
    )


# ------------------------------------------------------------------------------------------ generated worlds


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("seed", SEEDS)
def test_generated_world_has_no_problems(kind: RoomKind, seed: int) -> None:
    world = world_for(kind, seed)
    assert check_world(world) == []
    assert world.name == f"{kind}_s{seed}"
    assert world.room.kind == kind
    lo, hi = load_catalog().room(kind).area_m2
    assert lo <= world.room.floor.sum() * GRID_STEP_M**2 <= hi
    assert 2.5 <= world.room.wall_height <= 3.0
    assert world.agent.yaw in (0, 90, 180, 270) and world.agent.horizon == 0.0 and world.agent.held is None


@pytest.mark.parametrize("kind", KINDS)
def test_ids_follow_ai2thor_format_and_are_unique(kind: RoomKind) -> None:
    for seed in SEEDS:
        world = world_for(kind, seed)
        for oid, obj in world.objects.items():
            assert oid == obj.object_id == make_object_id(obj.object_type, obj.center)
        assert sorted(world.instance_ids.values()) == list(range(4, 4 + len(world.objects)))


@pytest.mark.parametrize("kind", KINDS)
def test_same_seed_same_world(kind: RoomKind) -> None:
    first = generate_world(WorldGenConfig(kind, 7)).to_dict()
    second = generate_world(WorldGenConfig(kind, 7)).to_dict()
    assert first == second


@pytest.mark.parametrize("kind", KINDS)
def test_different_seeds_differ(kind: RoomKind) -> None:
    dicts = [world_for(kind, seed).to_dict() for seed in range(5)]
    for i, a in enumerate(dicts):
        for b in dicts[i + 1 :]:
            assert a["room"] != b["room"] or a["objects"] != b["objects"]


@pytest.mark.parametrize("kind", KINDS)
def test_world_round_trips_through_dict(kind: RoomKind) -> None:
    world = world_for(kind, 3)
    again = World.from_dict(world.to_dict())
    assert again.to_dict() == world.to_dict()
    assert check_world(again) == []


def test_convenience_generators_name_their_kind() -> None:
    for make, kind in (
        (generate_kitchen, "kitchen"),
        (generate_living_room, "living_room"),
        (generate_bedroom, "bedroom"),
        (generate_bathroom, "bathroom"),
    ):
        world = make(5)
        assert world.room.kind == kind and world.name == f"{kind}_s5"
        assert world.to_dict() == world_for(kind, 5).to_dict()


# ---------------------------------------------------------------------------------------------- room shapes


def outline(floor: np.ndarray) -> str:
    """Classify a floor plan: rect, or L / T / U by the notches cut out of its bounding box."""
    empty = ~floor
    if not empty.any():
        return "rect"
    n, labels = cv2.connectedComponents(empty.astype(np.uint8), connectivity=4)
    notches = n - 1
    if notches == 2:
        return "T"
    sides = sum(
        bool(edge.any())
        for edge in (labels[0, :] > 0, labels[-1, :] > 0, labels[:, 0] > 0, labels[:, -1] > 0)
    )
    return "L" if sides == 2 else "U"


def test_shapes_vary_across_seeds() -> None:
    shapes = {outline(world_for(kind, seed).room.floor) for kind in KINDS for seed in SEEDS}
    assert {"rect", "L"} <= shapes
    assert len(shapes) >= 3


@pytest.mark.parametrize("shape", ["rect", "L", "T", "U"])
def test_requested_shape_is_built(shape: str) -> None:
    for seed in range(3):
        world = generate_world(WorldGenConfig("living_room", seed, shape=shape))  # type: ignore[arg-type]
        assert outline(world.room.floor) == shape
        assert check_world(world) == []


def test_shape_too_big_for_area_is_refused() -> None:
    with pytest.raises(ValueError, match="U room needs at least 14"):
        WorldGenConfig("bathroom", 0, shape="U", max_area_m2=12)


def test_walls_of_l_shaped_room() -> None:
    floor = np.zeros((8, 8), dtype=bool)
    floor[:, :4] = True
    floor[:4, 4:] = True
    walls = walls_of(Room("kitchen", floor, (0.0, 0.0)))
    assert sorted((w.facing, w.line, w.lo, w.hi) for w in walls) == [
        (0, 0.0, 0.0, 2.0),
        (90, 0.0, 0.0, 2.0),
        (180, 1.0, 1.0, 2.0),
        (180, 2.0, 0.0, 1.0),
        (270, 1.0, 1.0, 2.0),
        (270, 2.0, 0.0, 1.0),
    ]


# ----------------------------------------------------------------------------------------------- furniture


def test_kitchens_have_their_fixtures() -> None:
    for seed in SEEDS:
        world = world_for("kitchen", seed)
        for t in (
            "CounterTop",
            "Cabinet",
            "Fridge",
            "Sink",
            "SinkBasin",
            "Faucet",
            "GarbageCan",
            "LightSwitch",
        ):
            assert world.of_type(t), f"kitchen {seed} lacks {t}"
        burners = world.of_type("StoveBurner")
        knobs = world.of_type("StoveKnob")
        assert 2 <= len(burners) <= 4
        assert sorted(k.controls for k in knobs) == sorted(b.object_id for b in burners)  # type: ignore[type-var]
        for faucet in world.of_type("Faucet"):
            basin = world.objects[faucet.controls]  # type: ignore[index]
            assert basin.object_type == "SinkBasin"
            assert abs(faucet.bottom - basin.top) < 1e-3  # on the sink deck behind the basin
        for cabinet in world.of_type("Cabinet"):
            assert not cabinet.is_open
            assert (
                cabinet.bottom < 1e-3 or cabinet.bottom >= 1.5
            )  # base units or wall units above walking height
        assert all(o.is_toggled for o in world.of_type("LightSwitch"))
        assert not any(o.is_toggled for o in world.objects.values() if o.object_type != "LightSwitch")


@pytest.mark.parametrize(
    ("kind", "always"),
    [
        ("living_room", ("Sofa", "TVStand", "Television", "LightSwitch")),
        ("bedroom", ("Bed", "LightSwitch")),
        ("bathroom", ("Toilet", "Sink", "SinkBasin", "Faucet", "CounterTop", "Mirror", "HandTowelHolder")),
    ],
)
def test_rooms_have_their_furniture(kind: RoomKind, always: tuple[str, ...]) -> None:
    for seed in SEEDS:
        world = world_for(kind, seed)
        for t in always:
            assert world.of_type(t), f"{kind} {seed} lacks {t}"


def test_furniture_faces_into_the_room() -> None:
    """A piece against a wall faces away from it: one step from its front centre is still floor."""
    for seed in range(5):
        world = world_for("kitchen", seed)
        for obj in world.of_type("Fridge") + world.of_type("CounterTop"):
            fx, fz = {0: (0, 1), 90: (1, 0), 180: (0, -1), 270: (-1, 0)}[obj.facing]
            reach = max(obj.size) / 2 + 0.3
            assert world.room.contains(obj.center[0] + fx * reach, obj.center[2] + fz * reach)


@pytest.mark.parametrize("kind", KINDS)
def test_every_door_opens_onto_free_floor(kind: RoomKind) -> None:
    """Fridges, cabinets, drawers and microwaves keep the floor in front of them clear (salad seed 1 had a
    fridge whose door touched the end of the counter run: its lettuce could be neither reached nor seen)."""
    onto = load_ontology()
    for seed in SEEDS:
        world = world_for(kind, seed)
        doors = [
            o
            for o in world.objects.values()
            if o.parent_id is None
            and encloses(o.object_type, onto)
            and not onto.get(o.object_type).pickupable
        ]
        for door in doors:
            fx, fz = {0: (0, 1), 90: (1, 0), 180: (0, -1), 270: (-1, 0)}[door.facing]
            axis, sign = (0, fx) if fx else (2, fz)
            lo, hi = list(door.min_corner), list(door.max_corner)
            face = hi[axis] if sign > 0 else lo[axis]
            lo[axis], hi[axis] = sorted((face + sign * 0.01, face + sign * 0.3))
            blocking = [
                o.object_id
                for o in world.objects.values()
                if o.parent_id is None
                and all(min(hi[k], o.max_corner[k]) - max(lo[k], o.min_corner[k]) > 0.01 for k in range(3))
            ]
            assert not blocking, f"{kind} {seed}: {door.object_id} opens into {blocking}"
            ahead = [door.center[0], door.center[2]]
            ahead[axis // 2] = face + sign * 0.3
            assert world.room.contains(*ahead), f"{kind} {seed}: {door.object_id} opens into a wall"


@pytest.mark.parametrize(
    ("inset", "top", "seen"),
    [
        (0.05, 0.70, True),  # a plate at the front of a low cabinet's top shelf
        (0.25, 0.70, False),  # at its back: the ray passes under the top only from 1.75 m away
        (0.25, 0.10, True),  # on its floor: seen from 0.4 m back
        (0.25, 0.86, False),  # taller than the inside
    ],
)
def test_seen_through_front_follows_the_sight_line_under_the_top(
    inset: float, top: float, seen: bool
) -> None:
    """A cabinet 0.85 m high, front face at z = 1 facing -z, top's underside 0.83 m; cells every 0.25 m."""
    cells = np.array([[0.125, z] for z in np.arange(-1.875, 1.0, 0.25)])  # [M, 2] in front, at x = 0.125
    lo = np.array([0.0, top - 0.02, 1.0 + inset])
    hi = np.array([0.24, top, 1.24 + inset])
    assert seen_through_front(cells, lo, hi, (2, -1, 1.0), (-0.3, 0.5), 0.83) is seen


@pytest.mark.parametrize("seed", range(4))
def test_everything_behind_a_door_shows_when_it_is_open(seed: int) -> None:
    """What the generator puts in a fridge, cabinet or microwave can be seen and reached from some reachable
    pose once the door is open (a plate at the back of a cabinet's top shelf could not, in Clean All X seed
    15, and no expert could find it)."""
    world = world_for("kitchen", seed)
    onto = load_ontology()
    camera = CameraSpec(120, 120, TEACH_HFOV_DEG)
    sight = SightOracle(Renderer(camera), camera, 30, 0.01, 16)
    hidden = [
        o.object_id
        for o in world.objects.values()
        if o.parent_id is not None
        and encloses(world.objects[o.parent_id].object_type, onto)
        and world.objects[o.parent_id].object_type != "Drawer"
        and not sight.can_act_on(world, o.object_id, thorough=True)
    ]
    assert not hidden, hidden


# ------------------------------------------------------------------------------------------- small objects


@pytest.mark.parametrize("kind", KINDS)
def test_objects_rest_in_compatible_receptacles(kind: RoomKind) -> None:
    onto, catalog = load_ontology(), load_catalog()
    for seed in SEEDS:
        world = world_for(kind, seed)
        for obj in world.objects.values():
            if not onto.get(obj.object_type).pickupable:
                continue
            parent = world.objects[obj.parent_id]  # type: ignore[index]
            assert onto.accepts(parent.object_type, obj.object_type)
            if catalog.placement(parent.object_type) == "on":
                assert obj.center[1] == pytest.approx(parent.top + obj.size[1] / 2, abs=1e-3)


@pytest.mark.parametrize("kind", KINDS)
def test_task_relevant_objects_always_exist(kind: RoomKind) -> None:
    needed = [s for s in load_catalog().room(kind).objects if s.min_count]
    assert needed
    for seed in SEEDS:
        world = world_for(kind, seed)
        for spec in needed:
            assert len(world.of_type(spec.object_type)) >= spec.min_count, (seed, spec.object_type)


def test_some_objects_start_hidden_dirty_or_filled() -> None:
    worlds = [world_for(kind, seed) for kind in KINDS for seed in SEEDS]
    hidden = sum(in_closed_openable(w, o) for w in worlds for o in w.objects.values())
    dirty = sum(o.is_dirty for w in worlds for o in w.objects.values())
    filled = [o.liquid for w in worlds for o in w.objects.values() if o.liquid]
    assert hidden >= 40 and dirty >= 20 and len(filled) >= 5
    assert set(filled) <= {"water", "coffee", "wine"}
    kitchens = [world_for("kitchen", seed) for seed in SEEDS]
    assert all(any(in_closed_openable(w, o) for o in w.objects.values()) for w in kitchens)
    pans = [(w, o) for w in kitchens for o in w.of_type("Pot") + w.of_type("Pan")]
    assert any(w.objects[o.parent_id].object_type == "StoveBurner" for w, o in pans if o.parent_id)
    onto = load_ontology()
    for w in worlds:
        for o in w.objects.values():
            assert not o.is_dirty or onto.get(o.object_type).dirtyable
            assert o.liquid is None or (onto.get(o.object_type).fillable and not o.is_dirty)


def test_agent_starts_with_task_objects_out_of_view() -> None:
    half_fov = np.radians(TEACH_HFOV_DEG / 2)
    for kind in KINDS:
        task_types = {s.object_type for s in load_catalog().room(kind).objects if s.min_count}
        for seed in SEEDS:
            world = world_for(kind, seed)
            a = world.agent
            forward = np.array([np.sin(np.radians(a.yaw)), np.cos(np.radians(a.yaw))])

            def seen(o: WorldObject, a: AgentState = a, forward: np.ndarray = forward) -> bool:
                to = np.array([o.center[0] - a.x, o.center[2] - a.z])
                return bool(to @ forward >= np.linalg.norm(to) * np.cos(half_fov))

            targets = [o for o in world.objects.values() if o.object_type in task_types]
            assert any(in_closed_openable(world, o) or not seen(o) for o in targets), (kind, seed)


# ------------------------------------------------------------------------------------------------- require


def test_require_is_honoured() -> None:
    need = (("Potato", 3), ("Pot", 2), ("StoveBurner", 4), ("Toaster", 1), ("Chair", 2))
    for seed in range(3):
        world = generate_world(WorldGenConfig("kitchen", seed, require=need))
        for t, n in need:
            assert len(world.of_type(t)) >= n, (seed, t)
        assert check_world(world) == []


def test_require_brings_objects_a_room_does_not_usually_hold() -> None:
    world = generate_world(WorldGenConfig("bedroom", 1, require=(("Apple", 2), ("Safe", 1))))
    apples = world.of_type("Apple")
    assert len(apples) >= 2 and len(world.of_type("Safe")) == 1
    assert all(load_ontology().accepts(world.objects[a.parent_id].object_type, "Apple") for a in apples)  # type: ignore[index]


def test_impossible_require_fails_loudly() -> None:
    with pytest.raises(ValueError, match="kitchen cannot hold 'Toilet'.*Apple"):
        generate_world(WorldGenConfig("kitchen", 0, require=(("Toilet", 1),)))
    with pytest.raises(UnknownObjectType):
        generate_world(WorldGenConfig("kitchen", 0, require=(("Bananna", 1),)))
    with pytest.raises(ValueError, match="at most 4 StoveBurners"):
        generate_world(WorldGenConfig("kitchen", 0, require=(("StoveBurner", 5),)))
    with pytest.raises(ValueError, match="must be >= 1"):
        WorldGenConfig("kitchen", 0, require=(("Apple", 0),))
    with pytest.raises(WorldGenError, match="no room for Apple"):
        generate_world(WorldGenConfig("bathroom", 0, require=(("Apple", 500),), max_attempts=2))


def test_config_is_validated() -> None:
    with pytest.raises(KeyError, match="unknown room kind 'garage'.*kitchen"):
        WorldGenConfig("garage", 0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="dirty_prob"):
        WorldGenConfig("kitchen", 0, dirty_prob=1.5)
    with pytest.raises(ValueError, match="shape must be one of"):
        WorldGenConfig("kitchen", 0, shape="O")  # type: ignore[arg-type]


def test_probabilities_steer_states() -> None:
    clean = generate_world(WorldGenConfig("kitchen", 2, dirty_prob=0.0, filled_prob=0.0))
    assert not any(o.is_dirty or o.liquid for o in clean.objects.values())
    open_air = generate_world(WorldGenConfig("kitchen", 2, inside_closed_prob=0.0))
    packed = generate_world(WorldGenConfig("kitchen", 2, inside_closed_prob=1.0))

    def hidden(w: World) -> int:
        return sum(in_closed_openable(w, o) for o in w.objects.values())

    assert hidden(packed) > hidden(open_air)


def test_area_bounds_are_honoured() -> None:
    for seed in range(5):
        world = generate_world(WorldGenConfig("living_room", seed, min_area_m2=20, max_area_m2=22))
        assert 20 <= world.room.floor.sum() * GRID_STEP_M**2 <= 22


def test_generating_a_kitchen_is_fast() -> None:
    times = []
    for seed in range(100, 105):
        start = time.perf_counter()
        generate_kitchen(seed)
        times.append(time.perf_counter() - start)
    assert statistics.median(times) < 1.0


# ------------------------------------------------------------------------------------------------- catalog


def test_catalog_names_known_types_strategies_and_receptacles() -> None:
    onto, catalog = load_ontology(), load_catalog()
    assert set(catalog.kinds) == set(KINDS)
    for t in catalog.sized_types:
        onto.get(t)
    for kind in KINDS:
        room = catalog.room(kind)
        for entry in room.furniture:
            assert entry.place in STRATEGIES
            for host in entry.of:
                onto.get(host)
        for spec in room.objects:
            for receptacle, _ in spec.where:
                if onto.get(spec.object_type).pickupable:
                    assert onto.accepts(receptacle, spec.object_type), (receptacle, spec.object_type)
                else:
                    assert catalog.placement(receptacle) == "on"


def test_unknown_strategy_lists_known_ones() -> None:
    with pytest.raises(UnknownName, match="unknown placement strategy 'floating'.*counter_run"):
        STRATEGIES.get("floating")


# ------------------------------------------------------------------------------------- the world checks


def small_world() -> World:
    """A 3 m x 3 m room with a fridge against the -z wall, an egg inside it and an apple on a counter slab
    resting on a cabinet against the -x wall; the agent in the middle."""
    floor = np.ones((12, 12), dtype=bool)
    room = Room("kitchen", floor, (0.0, 0.0), wall_height=2.6)
    objs = [
        WorldObject("Fridge|a", "Fridge", (1.5, 0.9, 0.375), (0.8, 1.8, 0.75)),
        WorldObject("Egg|a", "Egg", (1.5, 0.08, 0.3), (0.05, 0.06, 0.05), parent_id="Fridge|a"),
        WorldObject("Cabinet|a", "Cabinet", (0.3, 0.425, 1.5), (0.6, 0.85, 0.6), facing=90),
        WorldObject("CounterTop|a", "CounterTop", (0.3, 0.875, 1.5), (0.6, 0.05, 0.6), facing=90),
        WorldObject("Apple|a", "Apple", (0.3, 0.945, 1.5), (0.08, 0.09, 0.08), parent_id="CounterTop|a"),
        WorldObject("StoveBurner|a", "StoveBurner", (0.3, 0.915, 1.75), (0.2, 0.03, 0.2), facing=90),
        WorldObject(
            "StoveKnob|a", "StoveKnob", (0.615, 0.875, 1.75), (0.03, 0.04, 0.05), controls="StoveBurner|a"
        ),
    ]
    return World("test", room, {o.object_id: o for o in objs}, AgentState(1.625, 1.625))


def test_hand_built_world_is_sound() -> None:
    assert check_world(small_world()) == []


def problems_after(change: Callable[[World], object]) -> list[str]:
    world = small_world()
    change(world)
    return check_world(world)


def moved(world: World, oid: str, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> None:
    x, y, z = world.objects[oid].center
    world.objects[oid].center = (x + dx, y + dy, z + dz)


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda w: moved(w, "Fridge|a", dz=-0.2), "Fridge|a: footprint leaves the floor"),
        (lambda w: moved(w, "Fridge|a", dy=0.3), "Fridge|a: floating, resting on nothing"),
        (lambda w: moved(w, "Apple|a", dy=0.2), "Apple|a: floating, not resting on top of its parent"),
        (lambda w: moved(w, "Apple|a", dz=0.25), "Apple|a overlaps StoveBurner|a"),
        (
            lambda w: moved(w, "Egg|a", dy=1.8),
            "Egg|a: contents of closed openable Fridge|a not inside its volume",
        ),
        (
            lambda w: setattr(w.objects["Apple|a"], "parent_id", "Fridge|a"),
            "Apple|a: contents of closed openable",
        ),
        (
            lambda w: setattr(w.objects["Egg|a"], "parent_id", "Cabinet|a"),
            "Egg|a: incompatible parent Cabinet",
        ),
        (lambda w: setattr(w.objects["Egg|a"], "parent_id", "Bowl|x"), "Egg|a: parent Bowl|x does not exist"),
        (
            lambda w: setattr(w.objects["StoveKnob|a"], "controls", "Apple|a"),
            "StoveKnob|a: controls 'Apple|a'",
        ),
        (lambda w: moved(w, "StoveKnob|a", dx=0.1), "StoveKnob|a: floating"),
        (lambda w: setattr(w.agent, "x", 0.3), "agent at (0.3, 1.625) is not on a reachable cell centre"),
        (lambda w: setattr(w.agent, "yaw", 45), "agent yaw 45"),
    ],
)
def test_check_world_names_each_problem(change: Callable[[World], object], expected: str) -> None:
    problems = problems_after(change)
    assert any(p.startswith(expected) for p in problems), problems


def test_check_world_finds_split_floor_and_unreachable_objects() -> None:
    world = small_world()
    wall = WorldObject("Dresser|a", "Dresser", (2.25, 0.4, 1.5), (0.2, 0.8, 3.0))
    world.add(wall)  # a partition from wall to wall: the floor falls in two
    assert any(p.startswith("reachable area is disconnected (2 pieces)") for p in check_world(world))
    assert component_count(reachable_grid(world)) == 2

    world = small_world()
    world.objects["CounterTop|a"].center = (0.3, 2.575, 1.5)  # out of the camera's reach, above 2.4 m
    problems = check_world(world)
    assert any(p.startswith("CounterTop|a: unreachable") for p in problems), problems
