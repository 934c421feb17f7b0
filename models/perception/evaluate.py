"""Quality of the perception networks on held-out frames (valid_unseen worlds).

Depth: absolute relative error mean(|D̂ - D| / D) and the share of pixels with max(D̂/D, D/D̂) < 1.25
(the usual monocular-depth metrics), over pixels with a reading. Segmentation: intersection over union per
class from the confusion matrix, the mean over classes present in the ground truth, and the mean over the
classes TEACh tasks name (``task_classes`` in the data's meta.json). Predictions are made as the agent
makes them: the frame area-resized to the network's side, the output resized back to the frame's side by
nearest neighbour; metrics are computed at the frame's side (``eval_side``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import torch
from tqdm import tqdm

from models.perception.dataset import IGNORE_LABEL, FrameArrays, load_frames
from models.perception.depth import expected_depth
from models.perception.network import PerceptionNet, Precision, inference_dtype, load_checkpoint

DELTA_THRESHOLD = 1.25


@dataclass(frozen=True)
class DepthMetrics:
    abs_rel: float  # mean |pred - true| / true
    delta_1: float  # share of pixels with max(pred/true, true/pred) < 1.25
    rmse_m: float  # root mean squared error, metres
    pixels: int


@dataclass(frozen=True)
class SegmentationMetrics:
    miou: float  # mean IoU over classes present in the ground truth
    task_miou: float  # mean IoU over the task classes present in the ground truth (nan if none)
    pixel_accuracy: float
    per_class_iou: dict[str, float]  # every class present in the ground truth
    task_class_iou: dict[str, float]


def depth_metrics(pred_m: np.ndarray, true_m: np.ndarray) -> DepthMetrics:
    """Metrics over pixels where the true depth is positive; pred and true of equal shape, metres."""
    if pred_m.shape != true_m.shape:
        raise ValueError(f"pred_m has shape {pred_m.shape}, true_m {true_m.shape}")
    valid = true_m > 0
    if not valid.any():
        raise ValueError("true_m has no positive depth to evaluate against")
    pred = np.maximum(pred_m[valid].astype(np.float64), 1e-3)
    true = true_m[valid].astype(np.float64)
    ratio = np.maximum(pred / true, true / pred)
    return DepthMetrics(
        abs_rel=float(np.mean(np.abs(pred - true) / true)),
        delta_1=float(np.mean(ratio < DELTA_THRESHOLD)),
        rmse_m=float(np.sqrt(np.mean((pred - true) ** 2))),
        pixels=int(valid.sum()),
    )


def confusion_matrix(pred: np.ndarray, true: np.ndarray, num_classes: int) -> np.ndarray:
    """int64 [C, C], rows true class, columns predicted; IGNORE_LABEL pixels are left out."""
    keep = true != IGNORE_LABEL
    flat = true[keep].astype(np.int64) * num_classes + pred[keep].astype(np.int64)
    return np.bincount(flat, minlength=num_classes * num_classes).reshape(num_classes, num_classes)


def segmentation_metrics(
    confusion: np.ndarray, classes: tuple[str, ...], task_classes: tuple[str, ...]
) -> SegmentationMetrics:
    """IoU = TP / (TP + FP + FN) per class present in the ground truth, and their means."""
    tp = np.diag(confusion).astype(np.float64)
    true_count = confusion.sum(axis=1)
    union = true_count + confusion.sum(axis=0) - tp
    present = true_count > 0
    iou = {classes[c]: float(tp[c] / union[c]) for c in np.flatnonzero(present)}
    task = {name: iou[name] for name in task_classes if name in iou}
    return SegmentationMetrics(
        miou=float(np.mean(list(iou.values()))) if iou else float("nan"),
        task_miou=float(np.mean(list(task.values()))) if task else float("nan"),
        pixel_accuracy=float(tp.sum() / max(confusion.sum(), 1)),
        per_class_iou=iou,
        task_class_iou=task,
    )


@torch.inference_mode()
def predict(model: PerceptionNet, rgb: np.ndarray, dtype: torch.dtype = torch.float32) -> np.ndarray:
    """Per-frame predictions at the frames' side: expected depth (float32 metres) or class (uint8).

    ``rgb`` uint8 [N, H, W, 3]; each frame is area-resized to the network's side first; the network runs
    in ``dtype`` (``PerceptionNet.infer``; the agent's is ``inference_dtype(LearnedConfig.precision)``).
    """
    config = model.config
    N, H, W, _ = rgb.shape
    side = config.input_side
    out = np.empty((N, H, W), dtype=np.float32 if config.task == "depth" else np.uint8)
    for i in tqdm(range(N), desc=f"predicting {config.task}", unit="frame", leave=False):
        small = cv2.resize(rgb[i], (side, side), interpolation=cv2.INTER_AREA)
        logits = model.infer(torch.from_numpy(small)[None], dtype)  # [1, out, side, side]
        if config.task == "depth":
            assert config.bins is not None
            result = expected_depth(logits.float().softmax(dim=1), config.bins)[0].numpy()
        else:
            result = logits.argmax(dim=1)[0].numpy().astype(np.uint8)
        out[i] = cv2.resize(result, (W, H), interpolation=cv2.INTER_NEAREST)
    return out


def evaluate_model(
    model: PerceptionNet, frames: FrameArrays, dtype: torch.dtype = torch.float32
) -> dict[str, Any]:
    """The task's metrics as a JSON-ready dict, the network run in ``dtype``."""
    pred = predict(model, frames.rgb, dtype)
    if model.config.task == "depth":
        return vars(depth_metrics(pred, frames.depth_mm.astype(np.float32) * 0.001))
    classes = model.config.classes
    if classes != frames.classes:
        raise ValueError("the network's classes differ from the dataset's (different ontology?)")
    confusion = confusion_matrix(pred, frames.labels, len(classes))
    return vars(segmentation_metrics(confusion, classes, frames.task_classes))


def validation_metrics(
    model: PerceptionNet, frames_root: Path, eval_side: int, limit: int | None
) -> dict[str, Any]:
    """The metrics a training run records in its checkpoint: which validation frames, how many, and the
    task's metrics on them."""
    frames = load_frames(frames_root, eval_side, limit=limit)
    with torch.inference_mode():
        metrics = evaluate_model(model, frames)
    return {"valid_frames": str(frames_root), "count": len(frames), **metrics}


def evaluate_checkpoint(
    checkpoint: Path, frames_root: Path, eval_side: int, limit: int | None, precision: Precision = "auto"
) -> dict[str, Any]:
    """Load a checkpoint and a frame folder, evaluate, and say on what and in which arithmetic."""
    model = load_checkpoint(checkpoint)
    frames = load_frames(frames_root, eval_side, limit=limit)
    dtype = inference_dtype(precision)
    metrics = evaluate_model(model, frames, dtype)
    return {
        "checkpoint": str(checkpoint),
        "frames": str(frames_root),
        "count": len(frames),
        "dtype": str(dtype).removeprefix("torch."),
        **metrics,
    }


def write_metrics(path: Path, metrics: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(metrics, indent=1, sort_keys=True))
