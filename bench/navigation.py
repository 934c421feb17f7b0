"""Navigation speed and path quality: JARVIS's FMM navigator against HLSM's VIN (issue 4 §3).

Part 1, 12 m house-like rooms (240x240 cells of 5 cm; three partitions with 0.9 m doorways, ten pieces of
furniture; fixed seeds), fully observed. From start/goal pairs at least 16 moves apart, each navigator
drives a pose by its own actions; a move is blocked as the harness blocks it (the agent's centre must keep
``harness.sim.navgrid.CLEARANCE_M`` from every obstacle along the move). Reports the median and p90 time per
``next_action`` (aim: 3 ms, navigation's share of DESIGN.md §8's 15 ms step), success, moves against the
fewest possible for a 0.2 m body (breadth-first search over 0.25 m moves) and all actions taken. For the
record, also one scikit-fmm distance field on the whole 5 cm map, the alternative the FMM navigator's
lattice raster replaces.

Part 2, the harness's own rooms (``harness.world.procedural``, four kinds, fixed seeds): the ground-truth 5 cm
map of each room (outside the floor and under blocking furniture) and a walk from the agent's start to every
piece of furniture, with moves checked by the harness's reachable grid. Shows how the body radius the
navigator dilates obstacles by fits a simulator that lets the agent stand 0.125 m from walls.

Run: ``.venv/bin/python -m bench.navigation``; writes ``bench/results/navigation.json``.
"""

from __future__ import annotations

import sys
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import skfmm

from agent.geometry import Pose
from agent.mapping import GridFrame
from agent.navigation.base import STEPS, NavGoal, NavGrids, Navigator, body_fits
from agent.navigation.fmm import FmmConfig, FmmNavigator
from agent.navigation.goals import interaction_goal_cells
from agent.navigation.vin import VinNavigator
from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.sim.navgrid import CLEARANCE_M, blocks_movement, reachable_grid
from harness.world.model import World
from harness.world.procedural.generate import (
    generate_bathroom,
    generate_bedroom,
    generate_kitchen,
    generate_living_room,
)
from symbolic.thor import AGENT_RADIUS_M, GRID_STEP_M

SEED = 0
CELL_M = 0.05
STRIDE = round(GRID_STEP_M / CELL_M)  # cells per move
SIDE = 240  # cells: 12 m
LAYOUTS = 6
PAIRS_PER_LAYOUT = 5
MIN_MOVES = 16
MAX_ACTIONS = 400
TARGET_MEDIAN_MS = 3.0
HARNESS_SEEDS = range(3)
HARNESS_ROOMS: dict[str, Callable[[int], World]] = {
    "kitchen": generate_kitchen,
    "living_room": generate_living_room,
    "bedroom": generate_bedroom,
    "bathroom": generate_bathroom,
}
NAVIGATORS: dict[str, tuple[Callable[[], Navigator], float]] = {
    "fmm": (FmmNavigator, AGENT_RADIUS_M),
    "fmm_radius_0.10": (lambda: FmmNavigator(FmmConfig(robot_radius_m=0.1)), 0.1),
    "vin": (VinNavigator, AGENT_RADIUS_M),
}
"""The registry's two navigators, plus FMM dilating by 0.1 m (the harness's walls stand 0.125 m from the
centres of the cells next to them, which a 0.2 m dilation closes); each with the body radius its goal
cells keep from obstacles."""

Cell = tuple[int, int]
MoveCheck = Callable[[Cell, Cell], bool]


@dataclass
class Drive:
    arrived: bool
    moves: int
    actions: int
    blocked: int
    call_ms: list[float]


def drive(
    navigator: Navigator, grids: NavGrids, frame: GridFrame, pose: Pose, goal: NavGoal, can_move: MoveCheck
) -> Drive:
    """Execute the navigator's actions; ``can_move(from_cell, to_cell)`` is the simulator's move rule. A
    blocked move marks the spot it tried to reach in this drive's own collision layer, as the map does."""
    collisions = np.zeros(grids.shape, dtype=bool)
    grids = NavGrids(grids.obstacles, grids.explored, collisions)
    moves = actions = blocked = 0
    call_ms: list[float] = []
    while actions < MAX_ACTIONS:
        start = time.perf_counter()
        decision = navigator.next_action(grids, frame, pose, goal)
        call_ms.append((time.perf_counter() - start) * 1000.0)
        if decision.action is None:
            return Drive(decision.reason == "arrived", moves, actions, blocked, call_ms)
        actions += 1
        after = pose.apply_motion(decision.action, True)
        if (after.x, after.z) != (pose.x, pose.z):
            here, there = frame.world_to_cell(pose.x, pose.z), frame.world_to_cell(after.x, after.z)
            if not can_move(here, there):
                blocked += 1
                if frame.contains(*there):
                    collisions[there] = True
                continue
            moves += 1
        pose = after
    return Drive(False, moves, actions, blocked, call_ms)


def fewest_moves(fits: np.ndarray, start: Cell, goal: np.ndarray) -> int:
    """Breadth-first search over 0.25 m moves whose swept cells all lie in ``fits``; -1 when none."""
    X, Z = fits.shape
    dist = {start: 0}
    queue = deque([start])
    while queue:
        i, j = queue.popleft()
        if goal[i, j]:
            return dist[(i, j)]
        for di, dj in STEPS:
            swept = [(i + di * k, j + dj * k) for k in range(1, STRIDE + 1)]
            nxt = swept[-1]
            if nxt not in dist and all(0 <= p < X and 0 <= q < Z and fits[p, q] for p, q in swept):
                dist[nxt] = dist[(i, j)] + 1
                queue.append(nxt)
    return -1


def house(rng: np.random.Generator) -> tuple[np.ndarray, list[np.ndarray]]:
    """bool [SIDE, SIDE] obstacles of a 12 m room with three partitions and ten pieces of furniture."""
    obstacles = np.zeros((SIDE, SIDE), dtype=bool)
    obstacles[0, :] = obstacles[-1, :] = obstacles[:, 0] = obstacles[:, -1] = True
    for axis in (0, 1, 0):
        at, door = int(rng.integers(50, SIDE - 50)), int(rng.integers(10, SIDE - 30))
        add_partition(obstacles, at, door, across_columns=axis == 1)
    furniture = []
    for _ in range(10):
        (w, d), (i, j) = rng.integers(8, 30, size=2), rng.integers(5, SIDE - 35, size=2)
        furniture.append(add_box(obstacles, i, j, w, d))
    return obstacles, furniture


def add_partition(obstacles: np.ndarray, at: int, door: int, *, across_columns: bool = False) -> None:
    """Wall off rows ``at``..``at + 2`` of the square grid ``obstacles`` (columns with ``across_columns``),
    in place, but for a 0.9 m doorway at cells ``door``..``door + 17``: a room's partition."""
    wall = np.zeros_like(obstacles)
    wall[at : at + 3, :] = True
    wall[at : at + 3, door : door + 18] = False  # 0.9 m doorway
    obstacles |= wall.T if across_columns else wall


def add_box(obstacles: np.ndarray, i: int, j: int, w: int, d: int) -> np.ndarray:
    """Mark a ``w`` x ``d`` piece of furniture with corner (``i``, ``j``) in ``obstacles``; its own mask."""
    piece = np.zeros_like(obstacles)
    piece[i : i + w, j : j + d] = True
    obstacles |= piece
    return piece


def sweep_rule(passable: np.ndarray) -> MoveCheck:
    """A move is possible when every cell the centre sweeps is ``passable``."""

    def can_move(a: Cell, b: Cell) -> bool:
        steps = max(abs(b[0] - a[0]), abs(b[1] - a[1]))
        return all(
            passable[a[0] + (b[0] - a[0]) * k // steps, a[1] + (b[1] - a[1]) * k // steps]
            for k in range(steps + 1)
        )

    return can_move


def synthetic_rooms() -> dict[str, object]:
    rng = np.random.default_rng(SEED)
    frame = GridFrame(0.0, 0.0, CELL_M, (SIDE, SIDE))
    per_nav: dict[str, list[tuple[Drive, int]]] = {name: [] for name in NAVIGATORS}
    field_ms = []
    for _ in range(LAYOUTS):
        obstacles, furniture = house(rng)
        fits = body_fits(obstacles, CELL_M, AGENT_RADIUS_M)
        can_move = sweep_rule(body_fits(obstacles, CELL_M, CLEARANCE_M))
        grids = NavGrids(obstacles=obstacles, explored=np.ones_like(obstacles))
        starts = np.argwhere(fits)
        phi = np.ma.MaskedArray(np.ones(obstacles.shape), obstacles)
        phi[tuple(starts[len(starts) // 2])] = -1.0
        start = time.perf_counter()
        skfmm.distance(phi, dx=CELL_M)
        field_ms.append((time.perf_counter() - start) * 1000.0)
        pairs = 0
        while pairs < PAIRS_PER_LAYOUT:
            i, j = starts[rng.integers(len(starts))]
            target = furniture[int(rng.integers(len(furniture)))]
            goal = NavGoal(interaction_goal_cells(target, fits, frame), face=target)
            optimal = fewest_moves(fits, (int(i), int(j)), goal.cells)
            if optimal < MIN_MOVES:
                continue
            pairs += 1
            pose = Pose((i + 0.5) * CELL_M, (j + 0.5) * CELL_M, float(90 * rng.integers(4)))
            for name, (make, _) in NAVIGATORS.items():
                per_nav[name].append((drive(make(), grids, frame, pose, goal, can_move), optimal))
    summary: dict[str, object] = {
        "layouts": LAYOUTS,
        "pairs": LAYOUTS * PAIRS_PER_LAYOUT,
        "grid_cells": [SIDE, SIDE],
        "skfmm_distance_full_5cm_grid_median_ms": round(float(np.median(field_ms)), 2),
    }
    for name, runs in per_nav.items():
        calls = np.concatenate([run.call_ms for run, _ in runs])
        ratios = [run.moves / optimal for run, optimal in runs if run.arrived]
        summary[name] = {
            "next_action_median_ms": round(float(np.median(calls)), 2),
            "next_action_p90_ms": round(float(np.percentile(calls, 90)), 2),
            "ratio_median_to_target": round(float(np.median(calls)) / TARGET_MEDIAN_MS, 3),
            "success_rate": round(len(ratios) / len(runs), 3),
            "moves_over_fewest_mean": round(float(np.mean(ratios)), 3) if ratios else None,
            "moves_over_fewest_max": round(float(np.max(ratios)), 3) if ratios else None,
            "actions_per_run_mean": round(float(np.mean([r.actions for r, _ in runs])), 1),
            "blocked_moves_total": int(sum(r.blocked for r, _ in runs)),
        }
    summary["target_median_ms"] = TARGET_MEDIAN_MS
    return summary


def ground_truth_map(world: World) -> tuple[np.ndarray, GridFrame]:
    """bool [X, Z] 5 cm obstacles of a harness room (off the floor or under blocking furniture)."""
    room = world.room
    floor = np.repeat(np.repeat(room.floor, STRIDE, axis=0), STRIDE, axis=1)  # [NX·5, NZ·5]
    X, Z = floor.shape
    frame = GridFrame(room.origin[0], room.origin[1], CELL_M, (X, Z))
    xs = room.origin[0] + (np.arange(X) + 0.5) * CELL_M  # [X] cell centres
    zs = room.origin[1] + (np.arange(Z) + 0.5) * CELL_M  # [Z]
    obstacles = ~floor
    for obj in world.objects.values():
        if blocks_movement(obj, world.agent.held):
            (x0, _, z0), (x1, _, z1) = obj.min_corner, obj.max_corner
            obstacles |= ((xs > x0) & (xs < x1))[:, None] & ((zs > z0) & (zs < z1))[None, :]
    return obstacles, frame


def footprint(world: World, object_id: str, frame: GridFrame) -> np.ndarray:
    X, Z = frame.shape
    xs = frame.origin_x + (np.arange(X) + 0.5) * CELL_M
    zs = frame.origin_z + (np.arange(Z) + 0.5) * CELL_M
    (x0, _, z0), (x1, _, z1) = world.objects[object_id].min_corner, world.objects[object_id].max_corner
    return ((xs >= x0) & (xs <= x1))[:, None] & ((zs >= z0) & (zs <= z1))[None, :]


def harness_rooms() -> dict[str, object]:
    per_nav = {name: {"runs": 0, "arrived": 0, "blocked": 0} for name in NAVIGATORS}
    for generate in HARNESS_ROOMS.values():
        for seed in HARNESS_SEEDS:
            world = generate(seed)
            obstacles, frame = ground_truth_map(world)
            grids = NavGrids(obstacles=obstacles, explored=np.ones_like(obstacles))
            agent = world.agent
            pose = Pose(agent.x, agent.z, float(agent.yaw))
            reachable = reachable_grid(world)
            start_cell = world.room.cell_of(agent.x, agent.z)
            _, labels = cv2.connectedComponents(reachable.view(np.uint8), connectivity=4)
            connected = labels == labels[start_cell]  # [NX, NZ] room cells the agent can walk to
            can_move = harness_rule(world, connected, frame)
            truth_standable = np.repeat(np.repeat(connected, STRIDE, axis=0), STRIDE, axis=1)  # at 5 cm
            for obj in world.objects.values():
                if obj.parent_id is not None:
                    continue  # furniture only: what rests on it is reached from the same cells
                target = footprint(world, obj.object_id, frame)
                if not interaction_goal_cells(target, truth_standable, frame).any():
                    continue  # the harness itself offers no cell within reach
                for name, (make, radius_m) in NAVIGATORS.items():
                    standable = body_fits(obstacles, CELL_M, radius_m)
                    cells = interaction_goal_cells(target, standable, frame)
                    run = drive(make(), grids, frame, pose, NavGoal(cells, face=target), can_move)
                    stats = per_nav[name]
                    stats["runs"] += 1
                    stats["arrived"] += int(run.arrived)
                    stats["blocked"] += run.blocked
    return {
        "rooms": f"{', '.join(HARNESS_ROOMS)} x seeds {list(HARNESS_SEEDS)}",
        "walks": per_nav["fmm"]["runs"],
        **{
            name: {
                "success_rate": round(stats["arrived"] / max(stats["runs"], 1), 3),
                "blocked_moves_total": stats["blocked"],
            }
            for name, stats in per_nav.items()
        },
    }


def harness_rule(world: World, connected: np.ndarray, frame: GridFrame) -> MoveCheck:
    """The harness's move rule: the destination room cell must be reachable (simulator ``_move``)."""
    NX, NZ = connected.shape

    def can_move(a: Cell, b: Cell) -> bool:
        ix, iz = world.room.cell_of(*frame.cell_to_world(*b))
        return 0 <= ix < NX and 0 <= iz < NZ and bool(connected[ix, iz])

    return can_move


def main(argv: Sequence[str] | None = None) -> int:
    # No options but --out; the parser answers --help and refuses stray arguments.
    args = bench_parser("navigation", __doc__).parse_args(argv)
    run = BenchRun.start("navigation", argv)
    results: dict[str, object] = {
        "seed": SEED,
        "synthetic_rooms": synthetic_rooms(),
        "harness_rooms": harness_rooms(),
    }
    synthetic = results["synthetic_rooms"]
    assert isinstance(synthetic, dict)
    line = ", ".join(
        f"{name} {stats['next_action_median_ms']} ms median, success {stats['success_rate']}"
        for name, stats in ((name, synthetic[name]) for name in NAVIGATORS)
    )
    return run.finish(args.out, results, [f"navigation: {line}"])


if __name__ == "__main__":
    sys.exit(main())
