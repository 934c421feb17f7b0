"""Quality of the shipped depth and segmentation networks on frames of unseen worlds.

The issue's bars: depth abs rel ≤ 0.15 and segmentation mIoU ≥ 0.6 on valid_unseen frames; also reported:
δ<1.25, RMSE, task-class mIoU and the IoU of every class TEACh tasks name. Frames are rendered by the
harness from valid_unseen worlds (``harness.perception_data``; never seen in training) unless ``--frames``
names a folder in the dataset layout. ``--compare-depth DIR ...`` evaluates further depth checkpoints on
the same frames (the issue asks which bins serve better: HLSM's 50 x 0.1 m or TEACh's 100 x 5 cm). The
networks run in the arithmetic the agent uses (``models.perception.engine.resolve`` of ``LearnedConfig``:
float32 by default, which ONNX Runtime computes to within 2 µm of torch's); when that is bfloat16, the
headline metrics in float32 are given beside (``float32_reference``).

Run: ``.venv/bin/python -m bench.perception_quality [--worlds 60]``; writes
``bench/results/perception_quality.json``.
"""

from __future__ import annotations

import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from agent.perception.learned import LearnedConfig
from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.perception_data import render_frames
from harness.render.camera import CameraSpec
from models.perception.dataset import load_frames

SEED = 0
DEPTH_ABS_REL_MAX = 0.15
SEGMENTATION_MIOU_MIN = 0.6
FRAME_SIDE = 256  # rendered frames (px); metrics are computed at this side


def _depth_entry(directory: Path, metrics: dict[str, Any]) -> dict[str, Any]:
    from models.perception.network import read_info  # torch loads inside the command, not for --help

    config, info = read_info(directory)
    assert config.bins is not None
    return {
        "checkpoint": str(directory),
        "bins": config.bins.to_dict(),
        "input_side": config.input_side,
        "train_steps": info.step,
        **{k: metrics[k] for k in ("abs_rel", "delta_1", "rmse_m", "pixels")},
    }


def _headline(depth: dict[str, Any], segmentation: dict[str, Any]) -> dict[str, float]:
    return {
        "depth_abs_rel": depth["abs_rel"],
        "depth_delta_1": depth["delta_1"],
        "segmentation_miou": segmentation["miou"],
        "segmentation_task_miou": segmentation["task_miou"],
        "segmentation_pixel_accuracy": segmentation["pixel_accuracy"],
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("perception_quality", __doc__)
    parser.add_argument(
        "--frames", type=Path, default=None, help="evaluate on this folder instead of rendering"
    )
    parser.add_argument(
        "--worlds", type=int, default=60, help="valid_unseen worlds to render (10 frames each)"
    )
    parser.add_argument("--compare-depth", type=Path, nargs="*", default=[])
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)
    run = BenchRun.start("perception_quality", argv)
    import torch  # torch loads after parsing, so --help answers at once

    from models.perception.engine import resolve
    from models.perception.evaluate import evaluate_model
    from models.perception.network import load_checkpoint

    torch.set_num_threads(args.threads)
    config = LearnedConfig()
    _, dtype = resolve(config.engine, config.precision)
    with tempfile.TemporaryDirectory() as scratch:
        root = args.frames
        if root is None:
            root = Path(scratch) / "valid_unseen"
            render_frames(
                root, "valid_unseen", args.worlds, 10, CameraSpec(FRAME_SIDE, FRAME_SIDE, 90.0), SEED
            )
        frames = load_frames(root, FRAME_SIDE, use_cache=args.frames is not None)
        depth_model = load_checkpoint(config.networks.depth)
        seg_model = load_checkpoint(config.networks.segmentation)
        depth = [_depth_entry(config.networks.depth, evaluate_model(depth_model, frames, dtype))]
        depth += [
            _depth_entry(d, evaluate_model(load_checkpoint(d), frames, dtype)) for d in args.compare_depth
        ]
        seg = evaluate_model(seg_model, frames, dtype)
        float32 = None
        if dtype != torch.float32:  # what the arithmetic costs in quality, on the same frames
            float32 = _headline(evaluate_model(depth_model, frames), evaluate_model(seg_model, frames))
    result = {
        "frames": {
            "source": str(args.frames or "rendered valid_unseen"),
            "count": len(frames),
            "side": FRAME_SIDE,
        },
        "dtype": str(dtype).removeprefix("torch."),
        "float32_reference": float32,
        "depth": depth[0],
        "depth_compared": depth[1:],
        "segmentation": {"checkpoint": str(config.networks.segmentation), **seg},
        "bars": {
            "depth_abs_rel_max": DEPTH_ABS_REL_MAX,
            "depth_met": depth[0]["abs_rel"] <= DEPTH_ABS_REL_MAX,
            "segmentation_miou_min": SEGMENTATION_MIOU_MIN,
            "segmentation_met": seg["miou"] >= SEGMENTATION_MIOU_MIN,
        },
    }
    summary = {k: v for k, v in result.items() if k != "segmentation"}
    summary["segmentation"] = {k: seg[k] for k in ("miou", "task_miou", "pixel_accuracy", "task_class_iou")}
    return run.finish(args.out, result, [json.dumps(summary, indent=2)])


if __name__ == "__main__":
    sys.exit(main())
