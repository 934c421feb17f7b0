"""Simulator step speed: median and p90 milliseconds per step at 300x300 (ALFRED) and 900x900 (TEACh).

What a harness loop pays per action: a motion step alone (grid lookups; the reachable grid is cached),
a motion step followed by the next observation (dominated by rendering), and an object interaction
both with a cold frame cache (the step renders depth and instances itself) and right after an
observe() (the runner's usual order: observe, ask the agent, step; the step reuses that frame). The
world is a generated kitchen (fixed seed); interactions click a visible object of a random pose with
the empty-handed action its type affords (Pickup, Open or ToggleOn), so both successes and failures
(too far, already open, inside a closed receptacle...) are timed.

Run: ``.venv/bin/python -m bench.step_speed``; writes ``bench/results/step_speed.json``.
"""

from __future__ import annotations

import random
import sys
import time
from collections.abc import Callable, Sequence
from functools import partial

import numpy as np

from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.render.camera import ALFRED_CAMERA, TEACH_CAMERA, CameraSpec
from harness.sim.clicks import click_point_of
from harness.sim.simulator import Simulator
from harness.world.model import World
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.generate import generate_world
from symbolic.ontology import load_ontology
from symbolic.thor import (
    MOTION_ACTIONS,
)

SEED = 0
RUNS: tuple[tuple[CameraSpec, int], ...] = (
    (ALFRED_CAMERA, 60),
    (TEACH_CAMERA, 20),
)
"""Camera and number of timed steps of each kind."""


def summary(times_ms: list[float]) -> dict[str, float]:
    return {
        "steps": len(times_ms),
        "median_ms": round(float(np.median(times_ms)), 3),
        "p90_ms": round(float(np.percentile(times_ms, 90)), 3),
    }


def timed(call: Callable[[], object]) -> float:
    start = time.perf_counter()
    call()
    return (time.perf_counter() - start) * 1000.0


def time_motion(world: World, spec: CameraSpec, n: int, rng: random.Random) -> dict[str, dict[str, float]]:
    """Random motion actions from the start pose: the step alone, and the step plus the next frame."""
    sim = Simulator(world.copy(), spec)
    sim.observe()
    alone: list[float] = []
    with_frame: list[float] = []
    for _ in range(n):
        action = rng.choice(MOTION_ACTIONS)
        alone.append(timed(partial(sim.step, action)))
        with_frame.append(alone[-1] + timed(sim.observe))
    return {"motion_step": summary(alone), "motion_step_and_observe": summary(with_frame)}


def interaction_for(object_type: str) -> str | None:
    """The empty-handed object action a type most obviously affords (what a driver would click it for)."""
    info = load_ontology().get(object_type)
    if info.pickupable:
        return "Pickup"
    if info.openable:
        return "Open"
    if info.toggleable:
        return "ToggleOn"
    return None


def time_interactions(
    world: World, spec: CameraSpec, n: int, rng: random.Random
) -> tuple[dict[str, dict[str, float]], float]:
    """Click a random visible object from a random reachable pose, cold and after an observe()."""
    probe = Simulator(world.copy(), spec)
    cells = np.argwhere(probe.reachable())
    cold: list[float] = []
    warm: list[float] = []
    successes = 0
    while len(cold) < n:
        ix, iz = cells[rng.randrange(len(cells))]
        x, z = world.room.cell_center(int(ix), int(iz))
        yaw, horizon = rng.choice((0, 90, 180, 270)), rng.choice((0, 30, 60))
        sims = [Simulator(world.copy(), spec) for _ in range(2)]
        for sim in sims:
            sim.world.agent.x, sim.world.agent.z, sim.world.agent.yaw, sim.world.agent.horizon = (
                x,
                z,
                yaw,
                horizon,
            )
        frame = sims[1].observe()
        targets = sorted(i for i in frame.object_ids if interaction_for(frame.legend[i]) is not None)
        if not targets:
            continue
        instance_id = rng.choice(targets)
        click = click_point_of(frame.instances, instance_id)
        assert click is not None, "an id in the frame's legend has pixels"
        action = interaction_for(frame.legend[instance_id])
        assert action is not None
        cold.append(timed(partial(sims[0].step, action, *click)))
        warm.append(timed(partial(sims[1].step, action, *click)))
        successes += sims[1].history[-1].success
    timings = {"interaction_step_cold": summary(cold), "interaction_step_after_observe": summary(warm)}
    return timings, round(successes / n, 3)


def main(argv: Sequence[str] | None = None) -> int:
    # No options but --out; the parser answers --help and refuses stray arguments.
    args = bench_parser("step_speed", __doc__).parse_args(argv)
    run = BenchRun.start("step_speed", argv)
    rng = random.Random(SEED)
    world = generate_world(WorldGenConfig(kind="kitchen", seed=SEED))
    results: dict[str, object] = {
        "seed": SEED,
        "scene": f"generated kitchen {world.name}, {len(world.objects)} objects",
    }
    lines = []
    for spec, n in RUNS:
        key = f"{spec.width}x{spec.height}_hfov{spec.hfov_deg:g}"
        timings = time_motion(world, spec, n, rng)
        interaction_timings, success_rate = time_interactions(world, spec, n, rng)
        timings.update(interaction_timings)
        results[key] = {**timings, "interaction_success_rate": success_rate}
        median = {name: t["median_ms"] for name, t in timings.items()}
        lines.append(
            f"{key}: motion {median['motion_step']} ms (+observe {median['motion_step_and_observe']}), "
            f"interaction cold {median['interaction_step_cold']} ms, "
            f"after observe {median['interaction_step_after_observe']} ms"
        )
    return run.finish(args.out, results, ["step_speed: " + "; ".join(lines)])


if __name__ == "__main__":
    sys.exit(main())
