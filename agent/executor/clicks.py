"""Where to click: the target's visible instances in this frame, and an interior pixel of the chosen one.

TEACh resolves a click through the instance segmentation at ``(round(y·H), round(x·W))`` and, when that
pixel's object lacks the action's affordance, searches a 10 px (of 900) square around it
(``SimulatorTHOR.__get_oid_at_frame_xy_with_affordance``); the simulator then measures the distance to the
surface seen at that pixel against AI2-THOR's 1.5 m. A click near the mask's centroid but well inside the
mask (distance transform) lands on the object even when the mask is thin or concave, and a pixel whose own
surface lies within reach passes the distance check. For Place on a large receptacle the click goes on its
visible upper surface, where AI2-THOR (and our harness) look for a free spot near the click.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import cv2
import numpy as np

from agent.geometry import Camera, Pose, camera_position, camera_to_world, pixel_ray_lengths, pixel_ray_slopes

ClickPurpose = Literal["object", "surface"]
"""``object``: any interior pixel (Pickup, Open, Toggle, Slice, Pour); ``surface``: a receptacle's top."""


@dataclass(frozen=True)
class ClickConfig:
    """How visible pixels become candidates and how one is chosen."""

    reach_m: float = 1.4  # metres from the body's vertical axis (``pixel_axis_distances``): AI2-THOR's 1.5 m
    # visibilityDistance capsule less a 0.1 m margin for depth quantisation and for TEACh's neighbourhood
    # search landing on a farther pixel
    min_pixels: int = 4  # reachable pixels an instance needs to count as clickable (a sliver is not)
    holding_min_distance_m: float = 0.7  # pixels nearer than this are the held object while holding
    # (HLSM A.3; the same distance keeps it out of the map)
    interior_fraction: float = 0.5  # candidates lie at least this share of the mask's largest inner
    # distance from its edge ...
    interior_cap_px: float = 6.0  # ... but need not lie farther than this (pixels at 300 px; scaled)
    surface_band_m: float = (
        0.06  # Place: pixels within this of the highest reachable surface point are its top
    )
    uncertain_top_quantile: float = 0.9  # with estimated depth, the top is measured from this quantile of
    # the heights, not the highest: a few pixels of a neighbour's depth bled into the mask are the highest


@dataclass(frozen=True)
class VisibleInstance:
    """One instance of the wanted type in this frame."""

    instance_id: int
    pixels: int  # visible pixels (held-object pixels excluded)
    reachable_pixels: int  # of them, within ``reach_m`` of the camera
    nearest_m: float  # metres from the camera to its nearest visible pixel
    point: tuple[float, float, float]  # world (x, y, z) centroid of its reachable (else visible) pixels

    @property
    def clickable(self) -> bool:
        return self.reachable_pixels > 0

    def distance_to(self, x: float, z: float) -> float:
        """Horizontal metres from its centroid to a world point."""
        return math.hypot(self.point[0] - x, self.point[2] - z)


@dataclass(frozen=True)
class Click:
    """A click: the pixel, and the relative point TEACh reads (x = column / W, y = row / H)."""

    row: int
    col: int
    x: float
    y: float
    instance_id: int
    point: tuple[float, float, float]  # world point of the clicked surface


@dataclass(frozen=True, eq=False)
class ClickFrame:
    """One frame as clicks are chosen in it: per pixel its instance, reach measure (metres from the body's
    axis, ``pixel_axis_distances``), whether it may be clicked (``usable_pixels``) and depth, and where the
    camera stood."""

    instances: np.ndarray  # int32 [H, W] instance ids (0 = none)
    distances: np.ndarray  # float32 [H, W] the reach measure, metres
    usable: np.ndarray  # bool [H, W]
    depth: np.ndarray  # float32 [H, W] z-depth, metres
    camera: Camera
    pose: Pose


def pixel_points(
    rows: np.ndarray, cols: np.ndarray, depth: np.ndarray, camera: Camera, pose: Pose
) -> np.ndarray:
    """float64 [N, 3] world points of the pixels (rows[k], cols[k]): ``geometry.depth_to_points`` for a
    few pixels, without back-projecting the whole image."""
    x_over_z, y_over_z = pixel_ray_slopes(camera)
    rays = np.stack([x_over_z[cols], y_over_z[rows], np.ones(len(rows), dtype=np.float32)], axis=1)  # [N, 3]
    local = rays * depth[rows, cols][:, None]  # [N, 3] camera frame
    return local @ camera_to_world(pose).T + camera_position(camera, pose)


COUNTING_MAX_ID = 1 << 16
"""Ids in [0, this) are grouped by counting (a table of this many slots at most), others by sorting."""


def group_ids(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``np.unique(ids, return_inverse=True, return_counts=True)`` of integer ids [N]: the distinct ids
    ascending, each element's index among them, and their counts; by counting rather than sorting when the
    ids are small, as a frame's instance ids are (a quarter of the time)."""
    if len(ids) == 0 or int(ids.min()) < 0 or int(ids.max()) >= COUNTING_MAX_ID:
        return np.unique(ids, return_inverse=True, return_counts=True)
    per_id = np.bincount(ids)
    found = np.flatnonzero(per_id)
    slot = np.zeros(len(per_id), dtype=np.intp)
    slot[found] = np.arange(len(found))
    return found.astype(ids.dtype), slot[ids], per_id[found]


def pixel_distances(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """float32 [H, W]: Euclidean metres from the camera to each pixel's surface (0 = no reading)."""
    return depth * pixel_ray_lengths(camera)


def usable_pixels(
    distances: np.ndarray, holding: bool, config: ClickConfig, held: np.ndarray | None = None
) -> np.ndarray:
    """bool [H, W]: pixels with a depth reading that are not the held object: while holding, the pixels
    nearer than ``holding_min_distance_m`` that are of the held type (``held``, bool [H, W]), or all of
    them when that is not known. A microwave 0.5 m ahead stays clickable while the bowl for it is held."""
    usable = distances > 0
    if holding:
        near = distances < config.holding_min_distance_m
        usable &= ~(near & held) if held is not None else ~near
    return usable


def held_type_in_view(
    class_ids: np.ndarray,
    hand: np.ndarray,
    type_names: tuple[str, ...],
    pickupable: frozenset[str],
    wanted: str,
    min_share: float,
) -> str | None:
    """The pickupable type a frame shows in the hand when it is clearly not ``wanted`` (a Pickup Knife
    that took a plate): of the ``hand`` pixels (bool [H, W]: nearer than ``holding_min_distance_m`` with
    true depth, the hand's region with estimated depth) with a pickupable class (``class_ids`` k names
    ``type_names[k - 1]``), at least ``min_share`` of the frame, at least 60% one other type and at most
    25% ``wanted``. None when the hand shows ``wanted``, nothing, or nothing clear."""
    ids, counts = np.unique(class_ids[hand], return_counts=True)
    shown = {
        type_names[i - 1]: int(n)
        for i, n in zip(ids.tolist(), counts.tolist(), strict=True)
        if i > 0 and type_names[i - 1] in pickupable
    }
    total = sum(shown.values())
    if total == 0 or total < min_share * class_ids.size or shown.get(wanted, 0) > 0.25 * total:
        return None
    top = max(shown, key=lambda name: shown[name])
    return top if shown[top] >= 0.6 * total else None


def visible_instances(mask: np.ndarray, frame: ClickFrame, config: ClickConfig) -> list[VisibleInstance]:
    """The instances of ``frame`` covering ``mask`` (bool [H, W]: the wanted type's pixels), nearest first.

    Pixels of the type without an instance (id 0: the specks a learned segmenter's instance split drops)
    are not an instance: a click on "instance 0" would land on any unlabelled pixel of the frame.
    """
    instances, distances = frame.instances, frame.distances
    wanted = mask & frame.usable & (instances > 0)
    if not wanted.any():
        return []
    rows, cols = np.nonzero(wanted)  # [N] each
    ids = instances[wanted]  # [N], row-major as rows and cols
    dist = distances[wanted]  # [N]
    # All instances in one pass (a row of cabinets shows a dozen): per-instance sums by bincount.
    found_ids, inverse, pixels = group_ids(ids)  # [I], [N], [I]
    near = dist <= config.reach_m  # [N]
    reachable = np.bincount(inverse, weights=near, minlength=len(found_ids)).astype(np.int64)  # [I]
    pick = near | (reachable < config.min_pixels)[inverse]  # [N]: the reachable pixels, else all of them
    picked = np.bincount(inverse, weights=pick, minlength=len(found_ids))  # [I]
    points = pixel_points(rows, cols, frame.depth, frame.camera, frame.pose)  # [N, 3]
    sums = [np.bincount(inverse, weights=points[:, k] * pick, minlength=len(found_ids)) for k in range(3)]
    centres = np.stack(sums, axis=1) / picked[:, None]  # [I, 3]
    nearest = np.full(len(found_ids), np.inf, dtype=dist.dtype)
    np.minimum.at(nearest, inverse, dist)  # [I]
    found = [
        VisibleInstance(
            instance_id=int(found_ids[k]),
            pixels=int(pixels[k]),
            reachable_pixels=int(reachable[k]) if reachable[k] >= config.min_pixels else 0,
            nearest_m=float(nearest[k]),
            point=(float(centres[k, 0]), float(centres[k, 1]), float(centres[k, 2])),
        )
        for k in range(len(found_ids))
    ]
    return sorted(found, key=lambda v: (not v.clickable, v.nearest_m))


def interior_pixel(mask: np.ndarray, config: ClickConfig, scale: float = 1.0) -> tuple[int, int] | None:
    """(row, col) of a pixel well inside ``mask`` and nearest its centroid, or None for an empty mask.

    Candidates are the pixels at least min(interior_fraction · r_max, interior_cap_px · scale) from the
    mask's edge (r_max: its largest inner distance); of those, the one nearest the centroid of the mask.
    """
    if not mask.any():
        return None
    inner = cv2.distanceTransform(mask.astype(np.uint8), cv2.DIST_L2, 3)  # [H, W] pixels to the edge
    r_max = float(inner.max())
    threshold = min(config.interior_fraction * r_max, config.interior_cap_px * scale)
    rows, cols = np.nonzero(inner >= max(threshold, 1e-6))  # [N] candidates
    all_rows, all_cols = np.nonzero(mask)
    centre_r, centre_c = all_rows.mean(), all_cols.mean()
    best = int(np.argmin((rows - centre_r) ** 2 + (cols - centre_c) ** 2))
    return int(rows[best]), int(cols[best])


def choose_click(
    instance: VisibleInstance,
    frame: ClickFrame,
    purpose: ClickPurpose,
    config: ClickConfig,
    avoid: tuple[tuple[int, int], ...] = (),
    exact_depth: bool = True,
) -> Click | None:
    """The click on ``instance`` in ``frame``: an interior pixel of its reachable part (its top surface for
    ``surface``).

    ``avoid`` holds pixels of earlier failed clicks on it; the mask loses a disc around each so a retry
    lands elsewhere. None when nothing reachable is left. Without ``exact_depth`` (a network's estimate)
    the top is found below ``uncertain_top_quantile`` of the heights rather than below the highest.
    """
    depth, camera, pose = frame.depth, frame.camera, frame.pose
    H, W = frame.instances.shape
    scale = max(H, W) / 300.0
    region = (frame.instances == instance.instance_id) & frame.usable & (frame.distances <= config.reach_m)
    for row, col in avoid:
        cv2.circle(region.view(np.uint8), (col, row), max(2, round(config.interior_cap_px * scale)), 0, -1)
    if int(region.sum()) < config.min_pixels:
        return None
    if purpose == "surface":
        rows, cols = np.nonzero(region)
        heights = pixel_points(rows, cols, depth, camera, pose)[:, 1]  # [n] metres
        highest = heights.max() if exact_depth else np.quantile(heights, config.uncertain_top_quantile)
        top = heights >= float(highest) - config.surface_band_m
        if int(top.sum()) >= config.min_pixels:
            region = np.zeros_like(region)
            region[rows[top], cols[top]] = True
    pixel = interior_pixel(region, config, scale)
    if pixel is None:
        return None
    row, col = pixel
    point = pixel_points(np.array([row]), np.array([col]), depth, camera, pose)[0]
    return Click(
        row=row,
        col=col,
        x=col / W,
        y=row / H,
        instance_id=instance.instance_id,
        point=(float(point[0]), float(point[1]), float(point[2])),
    )
