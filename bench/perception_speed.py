"""Learned perception speed per step on CPU, per engine: torch against ONNX Runtime, and how far they differ.

The budget (DESIGN.md §8): median ≤ 80 ms per 300x300 step at one thread on a CPU without native bfloat16,
so both engines compute float32 here (``LearnedConfig.precision`` "float32"; where this CPU has native
bfloat16, torch in bfloat16 is timed too, as ``torch_bfloat16``). The networks run at their own small sides
(the frame is area-downscaled first, outputs resized back by nearest neighbour; sides in the result), so the
time barely depends on the camera; 900x900 (TEACh) is timed too. Per engine: the whole step
(``LearnedPerception.perceive``) and each network with its reading (``PerceptionEngine.read_depth`` /
``read_classes`` at the network's side). The engines take turns call by call in one process, so a burst of
load on the shared machine falls on both alike; ratios are of medians. Wall-clock times are reported with the
load average and beside the process's CPU time, which is what a step costs on an idle core. Torch and ONNX
Runtime use ``--threads`` intra-op threads (default 1: with two threads on a machine already busy, OpenMP's
spinning threads made a step ten times slower in our measurements).

Agreement, on ``--agreement-frames`` frames (default 60) against torch float32: the share of pixels whose
segmentation argmax matches (pooled, and the worst frame; tolerance ≥ 99.5%), the mean |ΔE| of the expected
depth per frame (mean and worst; tolerance ≤ 1 cm, a tenth of the shipped network's 0.1 m bin), and the
share of pixels whose W90 matches. The budget's ratio is of the engine ``LearnedConfig.engine`` "auto" runs
in float32 (``budget_engine``); ``load_s`` is what loading the checkpoints and building the default engine
(the ONNX export) takes, which the service's preload pays once; ``service_step_ms`` times the default
step alone for ``bench.under_load``. The
goal transformer's exploring step (encode the frame with EfficientNet-Lite0, score the next action over a
16-step history) is timed as well. Frames come from unseen worlds of the harness with fixed seeds.

Run: ``.venv/bin/python -m bench.perception_speed [--threads 1]``; writes
``bench/results/perception_speed.json``.
"""

from __future__ import annotations

import json
import random
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from functools import partial
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from agent.exploration_gt import DEFAULT_CHECKPOINT as GT_CHECKPOINT
from agent.geometry import Camera
from agent.perception.base import Observation
from agent.perception.learned import LearnedConfig, LearnedModels, LearnedPerception, load_learned_models
from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.render.camera import CameraSpec
from harness.render.renderer import Renderer
from harness.sim.navgrid import reachable_grid
from harness.world.procedural.config import WorldGenConfig
from harness.world.procedural.generate import generate_world
from harness.world.splits import world_seed
from symbolic.thor import TEACH_HFOV_DEG

if TYPE_CHECKING:
    import torch

SEED = 0
BUDGET_300_MEDIAN_MS = 80.0
SIDES = (300, 900)
REFERENCE = "torch"
"""The engine the others are compared with: training's own code, in float32."""
SEGMENTATION_AGREEMENT_MIN = 0.995
"""Tolerance: share of pixels whose argmax class an engine must share with the reference."""
DEPTH_MEAN_ABS_MAX_M = 0.01
"""Tolerance: a frame's mean |ΔE| of expected depth, metres (a tenth of a 0.1 m depth bin)."""
TARGET = "Mug"


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


def engine_configs(config: LearnedConfig) -> dict[str, LearnedConfig]:
    """The engines compared, by label: torch and onnx in float32, and torch in bfloat16 where native."""
    import torch

    from models.perception.network import inference_dtype

    configs = {
        "torch": replace(config, engine="torch", precision="float32"),
        "onnx": replace(config, engine="onnx", precision="float32"),
    }
    if inference_dtype("auto") == torch.bfloat16:
        configs["torch_bfloat16"] = replace(config, engine="torch", precision="bfloat16")
    return configs


def timed(call: Callable[[], object], repeats: int) -> dict[str, float]:
    """Wall-clock median and p90, and the median CPU time of this process (what the step would take on
    an idle core: on a shared machine the wall clock also counts time spent waiting for a core)."""
    call()  # warm-up: allocator and first-use caches
    times, cpu_times = [], []
    for _ in range(repeats):
        wall, cpu = _one_call(call)
        times.append(wall)
        cpu_times.append(cpu)
    return summary(times, cpu_times)


def _one_call(call: Callable[[], object]) -> tuple[float, float]:
    start, cpu_start = time.perf_counter(), time.process_time()
    call()
    return (time.perf_counter() - start) * 1000.0, (time.process_time() - cpu_start) * 1000.0


def summary(times: Sequence[float], cpu_times: Sequence[float]) -> dict[str, float]:
    return {
        "median_ms": round(float(np.median(times)), 2),
        "p90_ms": round(float(np.percentile(times, 90)), 2),
        "cpu_median_ms": round(float(np.median(cpu_times)), 2),
        "calls": len(times),
    }


def parts(perception: LearnedPerception, rgb: np.ndarray) -> dict[str, Callable[[], object]]:
    """What is timed per engine on one frame: the whole step, and each network with its reading."""
    models = perception.models
    depth_in = _small(rgb, models.depth.config.input_side)
    seg_in = _small(rgb, models.segmentation.config.input_side)
    target = models.segmentation.config.classes.index(TARGET)
    obs = Observation(rgb=rgb)
    return {
        "step": lambda: perception.perceive(obs, target_type=TARGET),
        "depth_network": lambda: perception.engine.read_depth(depth_in),
        "segmentation_network": lambda: perception.engine.read_classes(seg_in, target),
    }


def time_interleaved(
    perceptions: dict[str, LearnedPerception], images: list[np.ndarray], repeats: int
) -> dict[str, dict[str, dict[str, float]]]:
    """Engine -> part -> timing over every frame and repeat, the engines taking turns call by call."""
    samples: dict[tuple[str, str], tuple[list[float], list[float]]] = {}
    for rgb in images:
        calls = {label: parts(perception, rgb) for label, perception in perceptions.items()}
        for part in calls[REFERENCE]:
            for label in calls:
                calls[label][part]()  # warm-up: allocator and first-use caches
            for _ in range(repeats):
                for label in calls:
                    wall, cpu = _one_call(calls[label][part])
                    times = samples.setdefault((label, part), ([], []))
                    times[0].append(wall)
                    times[1].append(cpu)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for (label, part), (wall_times, cpu_times) in samples.items():
        out.setdefault(label, {})[part] = summary(wall_times, cpu_times)
    return out


def ratios(timings: dict[str, dict[str, dict[str, float]]], label: str) -> dict[str, float]:
    """``label``'s median over the reference's, per part (below 1: faster)."""
    reference = timings[REFERENCE]
    return {
        part: round(row["median_ms"] / reference[part]["median_ms"], 3)
        for part, row in timings[label].items()
    }


def agreement(reference: LearnedPerception, other: LearnedPerception, images: list[np.ndarray]) -> dict:
    """How far ``other``'s readings are from ``reference``'s on the same frames, against the tolerances."""
    models = reference.models
    target = models.segmentation.config.classes.index(TARGET)
    same, pixels, frame_agreement, depth_diff, width_same, top_diff = 0, 0, [], [], [], 0.0
    for rgb in images:
        depth_in = _small(rgb, models.depth.config.input_side)
        a, b = reference.engine.read_depth(depth_in), other.engine.read_depth(depth_in)
        depth_diff.append(float(np.abs(a.expected - b.expected).mean()))
        width_same.append(float((np.abs(a.width90 - b.width90) < 1e-6).mean()))
        seg_in = _small(rgb, models.segmentation.config.input_side)
        c, d = reference.engine.read_classes(seg_in, target), other.engine.read_classes(seg_in, target)
        matches = int((c.channel == d.channel).sum())
        same, pixels = same + matches, pixels + c.channel.size
        frame_agreement.append(matches / c.channel.size)
        top_diff = max(top_diff, float(np.abs(c.top_probability - d.top_probability).max()))
    pooled = same / pixels
    return {
        "frames": len(images),
        "segmentation_argmax_agreement": round(pooled, 6),
        "segmentation_argmax_agreement_worst_frame": round(min(frame_agreement), 6),
        "segmentation_top_probability_max_abs_diff": float(f"{top_diff:.3g}"),
        "depth_mean_abs_diff_cm": round(100.0 * float(np.mean(depth_diff)), 4),
        "depth_mean_abs_diff_worst_frame_cm": round(100.0 * max(depth_diff), 4),
        "w90_agreement": round(float(np.mean(width_same)), 6),
        "within_tolerance": pooled >= SEGMENTATION_AGREEMENT_MIN and max(depth_diff) <= DEPTH_MEAN_ABS_MAX_M,
    }


def service_step_ms(threads: int = 1, n_frames: int = 8, repeats: int = 5) -> dict[str, Any]:
    """The 300x300 step with the engine the service runs by default, in float32, at ``threads`` threads."""
    import torch

    from models.perception.engine import resolve

    torch.set_num_threads(threads)
    config = replace(LearnedConfig(), precision="float32")
    perception = LearnedPerception(Camera(300, 300, TEACH_HFOV_DEG), config)
    rows = [
        timed(partial(perception.perceive, Observation(rgb=rgb), target_type=TARGET), repeats)
        for rgb in frames(300, n_frames)
    ]
    return {
        "engine": resolve(config.engine, config.precision)[0],
        "dtype": "float32",
        "threads": threads,
        "frames": n_frames,
        **{key: round(float(np.median([row[key] for row in rows])), 2) for key in rows[0] if key != "calls"},
    }


def _named(engine: str, dtype: torch.dtype) -> tuple[str, str]:
    return engine, str(dtype).removeprefix("torch.")


def _small(rgb: np.ndarray, side: int) -> np.ndarray:
    """The frame as the engines get it: area-downscaled to a network's side (``learned._network_input``)."""
    return cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)


def _perceptions(side: int, models: LearnedModels) -> dict[str, LearnedPerception]:
    camera = Camera(side, side, TEACH_HFOV_DEG)
    return {
        label: LearnedPerception(camera, config, models=models)
        for label, config in engine_configs(LearnedConfig()).items()
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("perception_speed", __doc__)
    parser.add_argument(
        "--threads", type=int, default=1, help="intra-op threads (2 oversubscribe a busy machine)"
    )
    parser.add_argument("--frames", type=int, default=8, help="frames timed per side")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls per frame, part and engine")
    parser.add_argument("--agreement-frames", type=int, default=60, help="frames the engines are compared on")
    args = parser.parse_args(argv)
    run = BenchRun.start("perception_speed", argv)
    import torch  # torch and the models load after parsing, so --help answers at once

    from models.goal_transformer.policy import load_goal_policy
    from models.perception.engine import resolve
    from models.perception.network import inference_dtype

    torch.set_num_threads(args.threads)
    config = LearnedConfig()
    started = time.perf_counter()
    models = load_learned_models(config.networks.depth, config.networks.segmentation, config)
    load_s = time.perf_counter() - started  # what the service's preload pays: checkpoints and export
    labels = engine_configs(config)
    results: dict[str, Any] = {
        "native_bfloat16": inference_dtype("auto") == torch.bfloat16,
        "threads": args.threads,
        "engines": {
            label: dict(zip(("engine", "dtype"), _named(*resolve(c.engine, c.precision)), strict=True))
            for label, c in labels.items()
        },
        "default_engine": {
            "here": " ".join(_named(*resolve(config.engine, config.precision))),
            "float32": " ".join(_named(*resolve(config.engine, "float32"))),
        },
        "network_sides_px": {
            "depth": models.depth.config.input_side,
            "segmentation": models.segmentation.config.input_side,
        },
        "load_s": round(load_s, 2),
    }
    for side in SIDES:
        perceptions = _perceptions(side, models)
        timings = time_interleaved(perceptions, frames(side, args.frames), args.repeats)
        results[f"{side}x{side}"] = {
            "frames": args.frames,
            "repeats": args.repeats,
            **timings,
            "median_ratio_to_torch": {
                label: ratios(timings, label) for label in timings if label != REFERENCE
            },
        }
    perceptions = _perceptions(300, models)
    compared = frames(300, args.agreement_frames)
    results["agreement_with_torch_float32"] = {
        "tolerance": {
            "segmentation_argmax_agreement_min": SEGMENTATION_AGREEMENT_MIN,
            "depth_mean_abs_diff_max_cm": 100.0 * DEPTH_MEAN_ABS_MAX_M,
        },
        **{
            label: agreement(perceptions[REFERENCE], perception, compared)
            for label, perception in perceptions.items()
            if label != REFERENCE
        },
    }
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
    budget_engine = resolve(config.engine, "float32")[0]  # what a CPU without native bfloat16 runs
    step = results["300x300"][budget_engine]["step"]
    results["budget_engine"] = budget_engine
    results["budget_300_median_ms"] = BUDGET_300_MEDIAN_MS
    results["ratio_300_median_to_budget"] = round(step["median_ms"] / BUDGET_300_MEDIAN_MS, 3)
    results["ratio_300_cpu_median_to_budget"] = round(step["cpu_median_ms"] / BUDGET_300_MEDIAN_MS, 3)
    for label in labels:
        row = results["300x300"][label]["step"]
        print(f"300x300 step, {label}: median {row['median_ms']} ms, p90 {row['p90_ms']} ms", end="")
        print(f", cpu median {row['cpu_median_ms']} ms")
    ratio = results["ratio_300_median_to_budget"]
    print(f"{budget_engine} float32: {ratio} of the {BUDGET_300_MEDIAN_MS} ms budget")
    print(json.dumps(results["agreement_with_torch_float32"], indent=2))
    run.write(args.out, results)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
