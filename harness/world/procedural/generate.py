"""The API: a sound world for a config, redrawn with the next sub-seed until every pass and the world
checks succeed, so a seed always gives the same world."""

from __future__ import annotations

import random

from harness.world.catalog import load_catalog
from harness.world.invariants import check_world
from harness.world.model import Room, World
from harness.world.procedural.builder import Builder
from harness.world.procedural.config import Retry, WorldGenConfig, WorldGenError
from harness.world.procedural.floor import floor_plan
from harness.world.procedural.furniture import draw_in, place_furniture
from harness.world.procedural.objects import place_agent, place_objects
from symbolic.ontology import load_ontology
from symbolic.thor import GRID_STEP_M


def _check_require(config: WorldGenConfig) -> dict[str, int]:
    """The required counts by type, or ValueError naming what this room kind can hold instead."""
    catalog, ontology = load_catalog(), load_ontology()
    spec = catalog.room(config.kind)
    required: dict[str, int] = {}
    for object_type, count in config.require:
        ontology.get(object_type)
        if object_type in required:
            raise ValueError(f"require names {object_type!r} twice")
        required[object_type] = count
    furniture = spec.furniture_types
    listed = furniture | {s.object_type for s in spec.objects}
    receptacles = {t for t in listed if ontology.get(t).receptacle}
    holdable = {
        t
        for t in catalog.sized_types
        if ontology.get(t).pickupable and any(ontology.accepts(r, t) for r in receptacles)
    }
    possible = listed | holdable
    for object_type in required:
        if object_type not in possible:
            raise ValueError(
                f"a {config.kind} cannot hold {object_type!r}; it can hold: {', '.join(sorted(possible))}"
            )
    runs = [e.run for e in spec.furniture if e.run is not None]
    most_burners = sum(r.stoves * r.burners[1] for r in runs)
    if required.get("StoveBurner", 0) > most_burners:
        raise ValueError(
            f"a {config.kind} has at most {most_burners} StoveBurners, {required['StoveBurner']} required"
        )
    return required


def _attempt(config: WorldGenConfig, rng: random.Random, required: dict[str, int]) -> World:
    catalog = load_catalog()
    spec = catalog.room(config.kind)
    floor, _ = floor_plan(config.area_range_m2(), config.shape, rng)
    NX, NZ = floor.shape
    room = Room(
        kind=config.kind,
        floor=floor,
        origin=(-(NX // 2) * GRID_STEP_M, -(NZ // 2) * GRID_STEP_M),
        wall_height=draw_in(spec.wall_height_m, rng, 0.05),
    )
    b = Builder(config, room, rng, required)
    place_furniture(b)
    place_objects(b)
    place_agent(b, {s.object_type for s in spec.objects if s.min_count} | set(required))
    world = b.world
    missing = {t: n for t, n in required.items() if len(world.of_type(t)) < n}
    if missing:
        raise Retry(f"required objects missing: {missing}")
    problems = check_world(world)
    if problems:
        raise Retry("; ".join(problems[:3]))
    return world


def generate_world(config: WorldGenConfig) -> World:
    """A sound world for ``config``: same config, same world (ids, positions and states).

    Raises ValueError when ``require`` asks for what the room kind cannot hold, and WorldGenError when no
    attempt succeeded (the message carries the last attempts' reasons).
    """
    required = _check_require(config)
    reasons: list[str] = []
    for attempt in range(config.max_attempts):
        rng = random.Random(f"{config.kind}/{config.seed}/{attempt}")
        try:
            return _attempt(config, rng, required)
        except Retry as failure:
            reasons.append(f"attempt {attempt}: {failure}")
    raise WorldGenError(
        f"no sound {config.kind} for seed {config.seed} in {config.max_attempts} attempts; "
        f"last: {reasons[-3:]}"
    )


def generate_kitchen(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("kitchen", seed, require=require))


def generate_living_room(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("living_room", seed, require=require))


def generate_bedroom(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("bedroom", seed, require=require))


def generate_bathroom(seed: int, require: tuple[tuple[str, int], ...] = ()) -> World:
    return generate_world(WorldGenConfig("bathroom", seed, require=require))
