"""Learned perception speed per step on CPU: median and p90 ms of ``LearnedPerception.perceive``.

The issue's budget: median ≤ 80 ms per step at 300x300. The networks run at their own small sides (the
frame is area-downscaled first, outputs resized back by nearest neighbour; sides in the result), so the
time barely depends on the camera; 900x900 (TEACh) is timed too. Parts are timed apart (depth network,
segmentation network + instance split) and so is the goal transformer's exploring step (encode the frame
with EfficientNet-Lite0, score the next action over a 16-step history). Frames come from unseen worlds
of the harness with fixed seeds. Wall-clock times are reported with the load average (other jobs share
the two cores) and beside the process's CPU time, which is what a step costs on an idle core. Torch uses
``--threads`` intra-op threads (default 1: with two threads on a machine already busy, OpenMP's spinning
threads made a step ten times slower in our measurements). The networks run in the arithmetic the agent
uses (``LearnedConfig.precision``, recorded as ``dtype``); when that is bfloat16, the 300x300 step is also
timed in float32 (``300x300_float32``).

Run: ``.venv/bin/python -m bench.perception_speed [--threads 1]``; writes
``bench/results/perception_speed.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import time
from collections.abc import Callable
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np
import torch

from agent.exploration_gt import DEFAULT_CHECKPOINT as GT_CHECKPOINT
from agent.geometry import Camera
from agent.perception.base import Observation
from agent.perception.learned import LearnedConfig, LearnedPerception, load_learned_models
from harness.camera import CameraSpec
from harness.navgrid import reachable_grid
from harness.render import Renderer
from harness.splits import world_seed
from harness.worldgen import WorldGenConfig, generate_world
from models.goal_transformer.policy import load_goal_policy
from models.perception.network import inference_dtype
from symbolic.thor import TEACH_HFOV_DEG

RESULTS = Path(__file__).resolve().parent / "results" / "perception_speed.json"
SEED = 0
BUDGET_300_MEDIAN_MS = 80.0
SIDES = (300, 900)


def frames(side: int, n: int) -> list[np.ndarray]:
    """n RGB frames of unseen kitchens and living rooms from reachable poses (fixed seeds)."""
    rng = random.Random(SEED)
    renderer = Renderer(CameraSpec(side, side, TEACH_HFOV_DEG))
    out = []
    for i in range(n):
        world = generate_world(
            WorldGenConfig(("kitchen", "living_room")[i % 2], world_seed("valid_unseen", i))
        )
        cells = np.argwhere(reachable_grid(world))
        ix, iz = cells[rng.randrange(len(cells))]
        world.agent.x, world.agent.z = world.room.cell_center(int(ix), int(iz))
        world.agent.yaw, world.agent.horizon = rng.choice((0, 90, 180, 270)), rng.choice((0.0, 30.0))
        rgb = renderer.render(world, noise_seed=i).rgb
        assert rgb is not None
        out.append(rgb)
    return out


def timed(call: Callable[[], object], repeats: int) -> dict[str, float]:
    """Wall-clock median and p90, and the median CPU time of this process (what the step would take on
    an idle core: on a shared machine the wall clock also counts time spent waiting for a core)."""
    call()  # warm-up: allocator and first-use caches
    times, cpu_times = [], []
    for _ in range(repeats):
        start, cpu_start = time.perf_counter(), time.process_time()
        call()
        times.append((time.perf_counter() - start) * 1000.0)
        cpu_times.append((time.process_time() - cpu_start) * 1000.0)
    return {
        "median_ms": round(float(np.median(times)), 2),
        "p90_ms": round(float(np.percentile(times, 90)), 2),
        "cpu_median_ms": round(float(np.median(cpu_times)), 2),
    }


def time_perception(
    perception: LearnedPerception, images: list[np.ndarray], repeats: int
) -> dict[str, float]:
    """Medians over frames of each frame's median: the whole step and its two halves."""
    whole, depth_part, seg_part = [], [], []
    for rgb in images:
        obs = Observation(rgb=rgb)
        depth = perception.estimate_depth(rgb)[0]
        whole.append(timed(partial(perception.perceive, obs, target_type="Mug"), repeats))
        depth_part.append(timed(partial(perception.estimate_depth, rgb), repeats))
        seg_part.append(timed(partial(perception.estimate_classes, rgb, depth, "Mug"), repeats))

    def median(rows: list[dict[str, float]], key: str) -> float:
        return round(float(np.median([row[key] for row in rows])), 2)

    return {
        "frames": len(images),
        "perceive_median_ms": median(whole, "median_ms"),
        "perceive_p90_ms": median(whole, "p90_ms"),
        "perceive_cpu_median_ms": median(whole, "cpu_median_ms"),
        "depth_median_ms": median(depth_part, "median_ms"),
        "segmentation_and_instances_median_ms": median(seg_part, "median_ms"),
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        prog="python -m bench.perception_speed", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "--threads", type=int, default=1, help="torch threads (2 oversubscribes a busy machine)"
    )
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per frame")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    config = LearnedConfig()
    models = load_learned_models(config.networks.depth, config.networks.segmentation)
    results: dict[str, object] = {
        "threads": args.threads,
        "machine": {"cpu": platform.processor() or platform.machine(), "cores_visible": os.cpu_count()},
        "load_average_1min": round(os.getloadavg()[0], 2),
        "network_sides_px": {
            "depth": models.depth.config.input_side,
            "segmentation": models.segmentation.config.input_side,
        },
    }
    dtype = inference_dtype(config.precision)
    results["dtype"] = str(dtype).removeprefix("torch.")
    for side in SIDES:
        camera = Camera(side, side, TEACH_HFOV_DEG)
        perception = LearnedPerception(camera, config, models=models)
        results[f"{side}x{side}"] = time_perception(perception, frames(side, args.frames), args.repeats)
    if dtype != torch.float32:  # what the bfloat16 arithmetic saves
        exact = LearnedPerception(
            Camera(300, 300, TEACH_HFOV_DEG), replace(config, precision="float32"), models=models
        )
        results["300x300_float32"] = time_perception(exact, frames(300, args.frames), args.repeats)
    if (GT_CHECKPOINT / "config.json").is_file():
        policy = load_goal_policy(GT_CHECKPOINT)
        rgb = frames(300, 1)[0]
        history = np.stack([policy.encode(rgb)] * 16)
        previous: list[str | None] = [None, *["Forward"] * 15]
        results["goal_transformer_step"] = {
            "encode_frame": timed(lambda: policy.encode(rgb), args.repeats * 4),
            "score_16_steps": timed(
                lambda: policy.scores([("Navigate", "Mug")], history, previous), args.repeats * 4
            ),
        }
    small = results["300x300"]
    assert isinstance(small, dict)
    results["budget_300_median_ms"] = BUDGET_300_MEDIAN_MS
    results["ratio_300_median_to_budget"] = round(small["perceive_median_ms"] / BUDGET_300_MEDIAN_MS, 3)
    results["ratio_300_cpu_median_to_budget"] = round(
        small["perceive_cpu_median_ms"] / BUDGET_300_MEDIAN_MS, 3
    )
    results["load_average_1min_after"] = round(os.getloadavg()[0], 2)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(results, indent=2) + "\n")
    print(json.dumps(results, indent=2))
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
