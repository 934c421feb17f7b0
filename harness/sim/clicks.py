"""From a click point to the object it means, through the instance mask, as TEACh does it.

TEACh's ``SimulatorTHOR.__get_oid_at_frame_xy_with_affordance`` reads the instance segmentation at
``(round(y*900), round(x*900))``; if that pixel's object lacks the affordance the action needs, it scans a
square of ``hotspot_pixel_width`` = 10 pixels around the click and picks, among objects that have it, the
one with the largest share of its visible pixels inside the square (its "IoU" tie-break). We do the same,
with the radius scaled to the frame size, and break remaining ties by the nearest pixel.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from symbolic.thor import TEACH_IMAGE_SIDE

TEACH_CLICK_RADIUS_PX = 10
"""TEACh's search half-width in pixels of its 900x900 frame (``hotspot_pixel_width``)."""

InstanceFilter = Callable[[int], bool]
"""Whether the object with this instance id has the affordance an action needs."""


@dataclass(frozen=True)
class ClickHit:
    """The object a click resolved to and the pixel of that object the action measures distance at."""

    instance_id: int
    row: int
    col: int


def click_radius_px(width: int, height: int) -> int:
    """TEACh's 10 px at 900 px, scaled to this frame's larger side; never below 1 px."""
    return max(1, round(TEACH_CLICK_RADIUS_PX * max(width, height) / TEACH_IMAGE_SIDE))


def click_pixel(x: float, y: float, width: int, height: int) -> tuple[int, int]:
    """(row, col) TEACh reads for a relative click; ``x = col / width`` addresses column ``col`` exactly."""
    if not (0.0 <= x <= 1.0 and 0.0 <= y <= 1.0):
        raise ValueError(f"click (x={x}, y={y}) must be fractions of the frame in [0, 1]")
    col = min(int(np.round(x * width)), width - 1)
    row = min(int(np.round(y * height)), height - 1)
    return row, col


def resolve_click(
    instances: np.ndarray, x: float, y: float, wanted: InstanceFilter, radius_px: int
) -> ClickHit | None:
    """The object at the click if wanted, else the best wanted object within ``radius_px``, else None."""
    H, W = instances.shape
    row, col = click_pixel(x, y, W, H)
    at_click = int(instances[row, col])
    if wanted(at_click):
        return ClickHit(at_click, row, col)

    r0, r1 = max(0, row - radius_px), min(H, row + radius_px + 1)
    c0, c1 = max(0, col - radius_px), min(W, col + radius_px + 1)
    window = instances[r0:r1, c0:c1]  # [h, w]
    ids, counts_in_window = np.unique(window, return_counts=True)
    best: tuple[float, float, int] | None = None  # (-share, distance², id): smaller is better
    best_pixel = (row, col)
    for iid, in_window in zip(ids.tolist(), counts_in_window.tolist(), strict=True):
        if not wanted(iid):
            continue
        share = in_window / int(np.count_nonzero(instances == iid))
        rows, cols = np.nonzero(window == iid)
        d2 = (rows + r0 - row) ** 2 + (cols + c0 - col) ** 2  # [n] squared pixel distances to the click
        nearest = int(np.argmin(d2))
        key = (-share, float(d2[nearest]), iid)
        if best is None or key < best:
            best = key
            best_pixel = (int(rows[nearest]) + r0, int(cols[nearest]) + c0)
    if best is None:
        return None
    return ClickHit(best[2], best_pixel[0], best_pixel[1])


def click_point_of(instances: np.ndarray, instance_id: int) -> tuple[float, float] | None:
    """A relative (x, y) that lands on the object: its mask pixel farthest from the mask's edge, or None."""
    mask = (instances == instance_id).astype(np.uint8)  # [H, W]
    if not mask.any():
        return None
    inside = cv2.distanceTransform(mask, cv2.DIST_L2, 3)  # [H, W] distance to the nearest non-object pixel
    row, col = np.unravel_index(int(np.argmax(inside)), inside.shape)
    H, W = instances.shape
    return float(col) / W, float(row) / H
