"""Renderer speed: median and p90 milliseconds per frame at 300x300 (ALFRED-like) and 900x900 (TEACh).

The issue's target is a 300x300 median well under 50 ms on one core. The scene is
``harness.world.procedural``'s kitchen for a fixed seed, its openables open (the result's ``scene`` counts its
objects, and the boxes once walls and open receptacles are split); poses are drawn with a fixed seed from the
cells the agent can stand on, with TEACh's yaws and horizons.

Run: ``.venv/bin/python -m bench.render_speed``; writes ``bench/results/render_speed.json``.
"""

from __future__ import annotations

import random
import sys
import time
from collections.abc import Sequence

import numpy as np

from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.render.camera import ALFRED_CAMERA, TEACH_CAMERA, CameraSpec
from harness.render.geometry import primitives
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.world.model import AgentState, World
from harness.world.procedural.generate import generate_kitchen
from symbolic.thor import ALFRED_HFOV_DEG, ALFRED_IMAGE_SIDE, TEACH_HFOV_DEG, TEACH_IMAGE_SIDE

SEED = 0
RUNS: tuple[tuple[CameraSpec, int], ...] = (
    (ALFRED_CAMERA, 50),
    (TEACH_CAMERA, 20),
)
TARGET_300_MEDIAN_MS = 50.0
OPENED_FOR_TIMING = frozenset({"Fridge", "Cabinet", "Drawer", "Microwave"})


def kitchen() -> World:
    """The generator's kitchen for SEED, with its fridge, cabinets and drawers open so that the hollow-shell
    and sliding-drawer paths (more boxes, contents visible) are timed too."""
    world = generate_kitchen(SEED)
    for obj in world.objects.values():
        if obj.object_type in OPENED_FOR_TIMING:
            obj.is_open = True
    return world


def poses(world: World, n: int, rng: random.Random) -> list[AgentState]:
    """n standing poses on reachable cells with TEACh's yaws and horizons."""
    cells = np.argwhere(reachable_grid(world))
    out = []
    for _ in range(n):
        ix, iz = cells[rng.randrange(len(cells))]
        x, z = world.room.cell_center(int(ix), int(iz))
        out.append(
            AgentState(x=x, z=z, yaw=rng.choice((0, 90, 180, 270)), horizon=rng.choice((-30, 0, 30, 60)))
        )
    return out


def time_renders(world: World, spec: CameraSpec, n: int, rng: random.Random) -> dict[str, float]:
    renderer = Renderer(spec)
    renderer.render(world)  # warm-up: first-use caches and allocator
    times = []
    for i, agent in enumerate(poses(world, n, rng)):
        world.agent = agent
        start = time.perf_counter()
        renderer.render(world, noise_seed=SEED + i)
        times.append((time.perf_counter() - start) * 1000.0)
    return {
        "frames": n,
        "median_ms": round(float(np.median(times)), 2),
        "p90_ms": round(float(np.percentile(times, 90)), 2),
    }


def main(argv: Sequence[str] | None = None) -> int:
    # No options but --out; the parser answers --help and refuses stray arguments.
    args = bench_parser("render_speed", __doc__).parse_args(argv)
    run = BenchRun.start("render_speed", argv)
    rng = random.Random(SEED)
    world = kitchen()
    results: dict[str, object] = {
        "seed": SEED,
        "scene": f"worldgen kitchen seed {SEED} with openables open: {len(world.objects)} objects, "
        f"{len(primitives(world))} boxes",
    }
    for spec, n in RUNS:
        results[f"{spec.width}x{spec.height}_hfov{spec.hfov_deg:g}"] = time_renders(world, spec, n, rng)
    small = results[f"{ALFRED_IMAGE_SIDE}x{ALFRED_IMAGE_SIDE}_hfov{ALFRED_HFOV_DEG:g}"]
    assert isinstance(small, dict)
    results["target_300_median_ms"] = TARGET_300_MEDIAN_MS
    results["ratio_300_median_to_target"] = round(small["median_ms"] / TARGET_300_MEDIAN_MS, 3)
    large = results[f"{TEACH_IMAGE_SIDE}x{TEACH_IMAGE_SIDE}_hfov{TEACH_HFOV_DEG:g}"]
    assert isinstance(large, dict)
    summary = (
        f"render_speed: 300x300 median {small['median_ms']} ms (p90 {small['p90_ms']}), "
        f"900x900 median {large['median_ms']} ms (p90 {large['p90_ms']})"
    )
    return run.finish(args.out, results, [summary])


if __name__ == "__main__":
    sys.exit(main())
