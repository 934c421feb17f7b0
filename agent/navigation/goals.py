"""Where to stand to interact with a target: JARVIS's "nearest empty space near the object" made precise.

A goal cell is a cell the body fits on (the caller's ``standable`` mask) that is close enough to the target
to act on it, not so close that the body overlaps it, and, for a narrow camera, from which the target can
be brought into view by the 90° turns available.

How close is close enough: AI2-THOR checks its 1.5 m ``visibilityDistance`` with an OverlapCapsule around
the agent's vertical axis (``collidersWithinCapsuleCastOfAgent``), i.e. a horizontal distance whatever the
target's height: an egg on the fridge's bottom shelf is as reachable as a mug on the counter. Our harness
measures the same way (``harness.sim.reach``). The agent stands within that distance less a margin for 5 cm
cells, for the click landing beyond the target's nearest cell and for what the clicks keep in hand.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from agent.navigation.base import GridFrame
from symbolic.thor import INTERACTION_DISTANCE_M


@dataclass(frozen=True)
class ReachConfig:
    """Distances that decide which cells count as within reach of a target."""

    interaction_distance_m: float = INTERACTION_DISTANCE_M  # AI2-THOR's visibilityDistance, horizontal
    reach_margin_m: float = 0.25  # metres kept in hand: two 5 cm cells of map error, the click landing on
    # the target's far side, and the clicks' own 0.1 m margin (``ClickConfig.reach_m``)
    min_distance_m: float = 0.3  # metres: the 0.2 m body must not overlap the target, and with the
    # camera looking fully down (60°) a 60° vertical field of view still shows the floor from 0.3 m
    view_margin_deg: float = 5.0  # degrees: keep the target this far inside the image's side edges

    def __post_init__(self) -> None:
        if not 0.0 <= self.min_distance_m < self.reach_m:
            raise ValueError(f"need 0 <= min_distance_m < reach, got {self.min_distance_m}, {self.reach_m}")

    @property
    def reach_m(self) -> float:
        """How far (horizontally) the agent may stand from the target's nearest cell."""
        return self.interaction_distance_m - self.reach_margin_m


def interaction_goal_cells(
    target_mask: np.ndarray,
    standable: np.ndarray,
    frame: GridFrame,
    *,
    hfov_deg: float | None = None,
    config: ReachConfig | None = None,
) -> np.ndarray:
    """bool [X, Z]: standable cells from which the target (``target_mask``) can be interacted with.

    Distances run from each cell's centre to the nearest target cell's centre (exact Euclidean distance
    transform). With ``hfov_deg`` given, a cell also needs that nearest target cell within the image's
    horizontal field of view, less ``view_margin_deg`` at each side, after the best 90° turn: TEACh's 90°
    view then loses only cells near the diagonals, ALFRED's 60° view loses a third of the bearings.
    """
    config = config or ReachConfig()
    if target_mask.shape != standable.shape:
        raise ValueError(f"target_mask has shape {target_mask.shape}, standable {standable.shape}")
    if target_mask.dtype != np.bool_ or standable.dtype != np.bool_:
        raise ValueError(
            f"target_mask and standable must be bool, got {target_mask.dtype}, {standable.dtype}"
        )
    if not target_mask.any():
        return np.zeros_like(standable)
    reach = config.reach_m
    not_target = np.ascontiguousarray(~target_mask).view(np.uint8)  # [X, Z] zero on target cells
    distance_m = cv2.distanceTransform(not_target, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) * frame.cell_m
    goal = standable & (distance_m <= reach) & (distance_m >= config.min_distance_m)
    if hfov_deg is not None and goal.any():
        goal &= _target_in_view(not_target, hfov_deg - 2.0 * config.view_margin_deg)
    return goal


def _target_in_view(not_target: np.ndarray, usable_fov_deg: float) -> np.ndarray:
    """bool [X, Z]: whether the nearest target cell lies within ``usable_fov_deg`` of a lattice heading."""
    if usable_fov_deg >= 90.0:
        return np.ones(not_target.shape, dtype=bool)
    _, labels = cv2.distanceTransformWithLabels(
        not_target, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL
    )  # [X, Z] label k marks the k-th target cell in row-major order
    targets = np.argwhere(not_target == 0)  # [N, 2], row-major like the labels
    nearest = targets[labels - 1]  # [X, Z, 2]
    X, Z = not_target.shape
    di = nearest[..., 0] - np.arange(X)[:, None]  # [X, Z] offsets in cells along x
    dj = nearest[..., 1] - np.arange(Z)[None, :]  # [X, Z] along z
    yaw = np.degrees(np.arctan2(di, dj))  # [X, Z]; 0 faces +z, 90 faces +x
    off_heading = np.abs((yaw + 45.0) % 90.0 - 45.0)  # [X, Z] degrees to the nearest lattice heading
    return off_heading <= usable_fov_deg / 2.0
