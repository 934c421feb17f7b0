"""Semantic map update speed and session state size (DESIGN.md §8: 300x300 oracle update median <= 10 ms).

A scripted walk through ``harness.world.procedural``'s kitchen (fixed seed): from the start cell the agent
looks around (four turns), then walks cell to cell over the reachable grid (a seeded walk that prefers
unvisited cells), facing where it goes and alternating TEACh's horizons 0 and 30, looking around again every
10 steps. Frames are rendered first (not timed); then each frame is perceived by the oracle and integrated
into one SemanticMap, timing perception (instance ids -> classes, eq. (5) mask) and the map update apart.
For scale, ``bench.map_update_published`` times FILM's and HLSM's own map updates on the same walk.

Run: ``.venv/bin/python -m bench.map_update``; writes ``bench/results/map_update.json``.
"""

from __future__ import annotations

import random
import sys
import time
from collections.abc import Sequence

import numpy as np

from agent.geometry import Camera, Pose
from agent.mapping import SemanticMap
from agent.perception import Observation, OraclePerception
from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.render.camera import CameraSpec
from harness.render.renderer import Frame, Renderer
from harness.sim.navgrid import reachable_grid
from harness.world.model import World
from harness.world.procedural.generate import generate_kitchen
from symbolic.thor import ALFRED_HFOV_DEG, ALFRED_IMAGE_SIDE, TEACH_HFOV_DEG, TEACH_IMAGE_SIDE

SEED = 0
RUNS: tuple[tuple[Camera, int], ...] = (
    (Camera(ALFRED_IMAGE_SIDE, ALFRED_IMAGE_SIDE, ALFRED_HFOV_DEG), 80),
    (Camera(TEACH_IMAGE_SIDE, TEACH_IMAGE_SIDE, TEACH_HFOV_DEG), 40),
)
TARGET_300_MEDIAN_MS = 10.0
STATE_LIMIT_BYTES = 2_000_000
_STEPS = {(1, 0): 90, (-1, 0): 270, (0, 1): 0, (0, -1): 180}  # grid step -> yaw facing it


def scripted_walk(world: World, n: int, rng: random.Random) -> list[Pose]:
    """n poses: look-arounds and a seeded walk over reachable cells that prefers cells not yet visited."""
    grid = reachable_grid(world)
    cell = world.room.cell_of(world.agent.x, world.agent.z)
    visited = {cell}
    poses: list[Pose] = []
    yaw, horizon = 0, 30
    while len(poses) < n:
        if len(poses) % 10 == 0:
            x, z = world.room.cell_center(*cell)
            poses.extend(Pose(x, z, float((yaw + turn) % 360), float(horizon)) for turn in (0, 90, 180, 270))
        moves = [
            (d, (cell[0] + d[0], cell[1] + d[1]))
            for d in _STEPS
            if 0 <= cell[0] + d[0] < grid.shape[0] and 0 <= cell[1] + d[1] < grid.shape[1]
        ]
        moves = [(d, c) for d, c in moves if grid[c]]
        fresh = [m for m in moves if m[1] not in visited]
        step, cell = rng.choice(fresh or moves)
        visited.add(cell)
        yaw, horizon = _STEPS[step], 30 - horizon
        x, z = world.room.cell_center(*cell)
        poses.append(Pose(x, z, float(yaw), float(horizon)))
    return poses[:n]


def render_frames(world: World, camera: Camera, poses: list[Pose]) -> list[Frame]:
    renderer = Renderer(CameraSpec(camera.width, camera.height, camera.hfov_deg, camera.height_m))
    frames = []
    for pose in poses:
        world.agent.x, world.agent.z = pose.x, pose.z
        world.agent.yaw, world.agent.horizon = int(pose.yaw), pose.horizon
        frames.append(renderer.render(world, want_rgb=False))
    return frames


def time_walk(camera: Camera, poses: list[Pose], frames: list[Frame]) -> dict[str, object]:
    oracle = OraclePerception(camera)
    semantic_map = SemanticMap(camera, poses[0])
    perceive_ms, update_ms, points = [], [], []
    for pose, frame in zip(poses, frames, strict=True):
        obs = Observation(depth=frame.depth, instances=frame.instances, legend=frame.legend, pose=pose)
        start = time.perf_counter()
        percept = oracle.perceive(obs, target_type=None)
        middle = time.perf_counter()
        stats = semantic_map.update(percept, pose)
        end = time.perf_counter()
        perceive_ms.append((middle - start) * 1000.0)
        update_ms.append((end - middle) * 1000.0)
        points.append(stats.points)
    total = np.add(perceive_ms, update_ms)
    start = time.perf_counter()
    blob = semantic_map.to_bytes()
    middle = time.perf_counter()
    SemanticMap.from_bytes(blob)
    end = time.perf_counter()
    return {
        "frames": len(frames),
        "update_median_ms": round(float(np.median(update_ms)), 2),
        "update_p90_ms": round(float(np.percentile(update_ms, 90)), 2),
        "perceive_median_ms": round(float(np.median(perceive_ms)), 2),
        "perceive_plus_update_median_ms": round(float(np.median(total)), 2),
        "perceive_plus_update_p90_ms": round(float(np.percentile(total, 90)), 2),
        "points_per_frame_median": int(np.median(points)),
        "map_cells": list(semantic_map.shape),
        "state_bytes_in_memory": semantic_map.nbytes,
        "state_bytes_serialized": len(blob),
        "to_bytes_ms": round((middle - start) * 1000.0, 2),
        "from_bytes_ms": round((end - middle) * 1000.0, 2),
    }


def main(argv: Sequence[str] | None = None) -> int:
    # No options but --out; the parser answers --help and refuses stray arguments.
    args = bench_parser("map_update", __doc__).parse_args(argv)
    run = BenchRun.start("map_update", argv)
    world = generate_kitchen(SEED)
    results: dict[str, object] = {
        "seed": SEED,
        "scene": f"worldgen kitchen seed {SEED}: {len(world.objects)} objects, "
        f"{world.room.floor.sum() * 0.0625:.1f} m2 of floor",
    }
    for camera, n in RUNS:
        poses = scripted_walk(world.copy(), n, random.Random(SEED))
        frames = render_frames(world.copy(), camera, poses)
        results[f"{camera.width}x{camera.height}_hfov{camera.hfov_deg:g}"] = time_walk(camera, poses, frames)
    small = results[f"{ALFRED_IMAGE_SIDE}x{ALFRED_IMAGE_SIDE}_hfov{ALFRED_HFOV_DEG:g}"]
    large = results[f"{TEACH_IMAGE_SIDE}x{TEACH_IMAGE_SIDE}_hfov{TEACH_HFOV_DEG:g}"]
    assert isinstance(small, dict) and isinstance(large, dict)
    results["target_300_median_ms"] = TARGET_300_MEDIAN_MS
    results["ratio_300_update_median_to_target"] = round(small["update_median_ms"] / TARGET_300_MEDIAN_MS, 3)
    results["ratio_300_perceive_plus_update_median_to_target"] = round(
        small["perceive_plus_update_median_ms"] / TARGET_300_MEDIAN_MS, 3
    )
    results["state_limit_bytes"] = STATE_LIMIT_BYTES
    results["ratio_largest_state_to_limit"] = round(
        max(r["state_bytes_in_memory"] for r in (small, large)) / STATE_LIMIT_BYTES, 3
    )
    summary = (
        f"map_update: 300x300 update median {small['update_median_ms']} ms (p90 {small['update_p90_ms']}), "
        f"with perception {small['perceive_plus_update_median_ms']} ms; 900x900 update median "
        f"{large['update_median_ms']} ms; state {small['state_bytes_in_memory']} B in memory, "
        f"{small['state_bytes_serialized']} B serialized"
    )
    return run.finish(args.out, results, [summary])


if __name__ == "__main__":
    sys.exit(main())
