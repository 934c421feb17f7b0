"""Semantic segmentation over the ontology's classes (HLSM §4.2 and A.3; the JARVIS seed's segmentation).

Output channel k is class k of ``dataset.ontology_classes()`` (0 = Nothing), the agent's ClassIndex ids.
Indoor frames are mostly floor, wall and furniture, so the loss weights each class by the inverse square
root of its pixel share (clipped), which lifts the small objects tasks name without drowning the rest.
"""

from __future__ import annotations

import numpy as np
import torch
from torch.nn import functional as F

from models.perception.dataset import IGNORE_LABEL

WEIGHT_RANGE = (0.25, 6.0)
"""Clip of the class weights relative to the median class, so one-pixel classes cannot dominate."""


def class_weights(labels: np.ndarray, num_classes: int) -> np.ndarray:
    """float32 [C]: (median share / share)^0.5 clipped to WEIGHT_RANGE; 1 for classes never seen."""
    counts = np.bincount(labels.reshape(-1), minlength=max(num_classes, IGNORE_LABEL + 1))[:num_classes]
    seen = counts > 0
    weights = np.ones(num_classes, dtype=np.float32)
    if seen.any():
        share = counts[seen] / counts[seen].sum()
        weights[seen] = np.clip(np.sqrt(np.median(share) / share), *WEIGHT_RANGE)
    return weights


def segmentation_loss(
    logits: torch.Tensor, labels: torch.Tensor, weights: torch.Tensor | None
) -> torch.Tensor:
    """Weighted pixel-wise cross entropy; IGNORE_LABEL pixels do not count. logits [B, C, H, W], labels
    int64 [B, H, W]."""
    return F.cross_entropy(logits, labels, weight=weights, ignore_index=IGNORE_LABEL)
