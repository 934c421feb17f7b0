"""The API: a world (and how it departs from the floor plan) from one ALFRED trajectory, stage by stage."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from harness.sim.navgrid import reachable_grid
from harness.tasks.alfred import AlfredTask, alfred_task_from_pddl
from harness.world.alfred.data import load_alfred_trajectories, load_floor_plan, scene_of
from harness.world.alfred.fixtures import place_fixtures
from harness.world.alfred.grid import reachable_cells
from harness.world.alfred.objects import place_objects
from harness.world.alfred.pieces import Build, grid_cell
from harness.world.alfred.receptacles import planned_spots, split_decks, surface_pieces, vertical_structure
from harness.world.alfred.resolve import (
    advance,
    counter_segments,
    keep_walkway_clear,
    over_standing_ground,
    resolve,
    settle,
)
from harness.world.alfred.room import cells_of, enclose
from harness.world.catalog import load_catalog
from harness.world.model import World
from symbolic.ontology import load_ontology
from symbolic.thor import GRID_STEP_M


@dataclass(frozen=True)
class AlfredWorldReport:
    """How far a built world departs from ALFRED's floor plan (each count is small by design)."""

    layout_points: int
    missing_points: tuple[tuple[float, float], ...]
    """Listed reachable points that are not reachable here (dropped islands, points under a fixture)."""
    extra_points: tuple[tuple[float, float], ...]
    """Reachable cells the floor plan does not list (the start point, corridors joining islands)."""
    dropped: tuple[str, ...]
    """Receptacles, fixtures or object poses that found no place, each "id: reason" (rare: a few train
    trajectories lose an upper cabinet)."""


def build_alfred_world(
    traj: Mapping[str, Any], data_dir: Path | None = None
) -> tuple[World, AlfredWorldReport]:
    """The world of one ALFRED trajectory and how it departs from the floor plan (the package docstring)."""
    scene = scene_of(traj)
    plan = load_floor_plan(scene.floor_plan, data_dir)
    points = (
        np.array(sorted(reachable_cells(plan, scene.start[:2])), dtype=np.float64) * GRID_STEP_M
    )  # [M, 2]
    b = Build(plan, scene, load_catalog(), load_ontology(), points.reshape(-1, 2))
    b.plan = dataclasses.replace(plan, receptacles=plan.receptacles + tuple(planned_spots(b)))
    _furnish(b, traj.get("pddl_params", {}))
    world = enclose(b, str(traj.get("task_id") or scene.floor_plan), int(scene.random_seed) % 2**31)
    place_objects(b, world)
    have = cells_of(world.room, reachable_grid(world))
    listed = {grid_cell(x, z) for x, z in plan.reachable}
    report = AlfredWorldReport(
        layout_points=len(listed),
        missing_points=tuple(sorted((i * GRID_STEP_M, k * GRID_STEP_M) for i, k in listed - have)),
        extra_points=tuple(sorted((i * GRID_STEP_M, k * GRID_STEP_M) for i, k in have - listed)),
        dropped=tuple(b.dropped),
    )
    return world, report


def _furnish(b: Build, task: Mapping[str, Any]) -> None:
    """Stages 1 and 2 of the package docstring: receptacles, then fixtures, as pieces."""
    pieces, tops = surface_pieces(b)
    vertical_structure(b, pieces, tops)
    b.pieces = resolve(b, pieces)
    settle(b)
    counter_segments(b)
    settle(b)
    keep_walkway_clear(b)
    settle(b)
    advance(b)
    split_decks(b)
    place_fixtures(b, task)
    settle(b)
    over_standing_ground(b)


def alfred_world(traj: Mapping[str, Any], data_dir: Path | None = None) -> World:
    """The harness world of an ALFRED ``traj_data`` (train or valid_seen), read from the shared data."""
    return build_alfred_world(traj, data_dir)[0]


def alfred_task_world_pairs(
    split: str, limit: int | None = None, data_dir: Path | None = None
) -> Iterator[tuple[dict[str, Any], World, AlfredTask]]:
    """(trajectory, its world, its ALFRED task) for the first ``limit`` trajectories of a split (or all)."""
    for n, traj in enumerate(load_alfred_trajectories(split, data_dir)):
        if limit is not None and n >= limit:
            return
        yield (
            traj,
            alfred_world(traj, data_dir),
            alfred_task_from_pddl(traj["pddl_params"], traj["task_type"]),
        )
