"""Instance masks from a semantic segmentation and a depth map, for the executor's clicks.

The networks give classes, not instances, but an interaction clicks one object (TEACh's click point, HLSM's
instance mask from its 3D argument mask). Two objects of one class are split where they do not touch in
the image, and where they touch in the image but not in space: a depth discontinuity between neighbouring
pixels (a jump larger than ``depth_jump_rel`` of the nearer depth) separates them. Per class: the far
side of every jump is cut out, 4-connected components of what is left become instances, and the cut
pixels join the component beside them; components under ``min_pixels`` are dropped (speckle).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

_CROSS = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=np.uint8)


@dataclass(frozen=True)
class InstanceSplitConfig:
    depth_jump_rel: float = 0.1  # a jump over 10% of the nearer depth separates surfaces
    min_pixels: int = 4  # smaller components are speckle, not objects (pixels at the split's resolution)


def depth_cuts(depth: np.ndarray, depth_jump_rel: float) -> np.ndarray:
    """bool [H, W]: pixels on the far side of a depth discontinuity with a 4-neighbour."""
    cut = np.zeros(depth.shape, dtype=bool)
    for axis in (0, 1):
        a = depth[:-1, :] if axis == 0 else depth[:, :-1]
        b = depth[1:, :] if axis == 0 else depth[:, 1:]
        jump = np.abs(a - b) > depth_jump_rel * np.minimum(a, b)
        a_far, b_far = jump & (a > b), jump & (b > a)
        if axis == 0:
            cut[:-1, :] |= a_far
            cut[1:, :] |= b_far
        else:
            cut[:, :-1] |= a_far
            cut[:, 1:] |= b_far
    return cut


def split_instances(
    class_ids: np.ndarray,
    depth: np.ndarray,
    *,
    skip: Sequence[int] = (0,),
    config: InstanceSplitConfig = InstanceSplitConfig(),
) -> tuple[np.ndarray, dict[int, int]]:
    """(int32 [H, W] instance ids from 1, 0 = none; {instance id: class id}) for every class not in ``skip``.

    ``class_ids`` integer [H, W]; ``depth`` float [H, W] metres of the same shape.
    """
    if class_ids.shape != depth.shape:
        raise ValueError(f"class_ids has shape {class_ids.shape}, depth {depth.shape}")
    H, W = class_ids.shape
    cut = depth_cuts(depth.astype(np.float32), config.depth_jump_rel)
    instances = np.zeros((H, W), dtype=np.int32)
    instance_class: dict[int, int] = {}
    present = np.flatnonzero(np.bincount(class_ids.reshape(-1).astype(np.int64)))
    next_id = 1
    for class_id in (int(c) for c in present if c not in skip):
        mask = class_ids == class_id
        count, labels = cv2.connectedComponents((mask & ~cut).view(np.uint8), connectivity=4)
        if count <= 1:
            continue
        grown = cv2.dilate(labels.astype(np.float32), _CROSS).astype(np.int32)  # max label beside each pixel
        refill = mask & (labels == 0) & (grown > 0)
        labels[refill] = grown[refill]
        sizes = np.bincount(labels[mask], minlength=count)
        keep = np.flatnonzero(sizes >= config.min_pixels)
        keep = keep[keep > 0]
        if not len(keep):
            continue
        remap = np.zeros(count, dtype=np.int32)
        remap[keep] = np.arange(next_id, next_id + len(keep), dtype=np.int32)
        relabelled = remap[labels]
        instances[mask] = relabelled[mask]
        for new_id in range(next_id, next_id + len(keep)):
            instance_class[new_id] = class_id
        next_id += len(keep)
    return instances, instance_class
