"""The perception contract: what a step brings in (Observation) and what the map needs (Percept).

HLSM (seed 000 §4.2, perception step) turns each RGB frame into depth, a depth-confidence mask and
semantic segmentation; JARVIS (seed 002 §3.2) does the same with its own networks. The oracle back-end
takes them from the caller; the learned one will estimate them from RGB. Both return a Percept, so
swapping back-ends changes nothing outside ``agent/perception``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np

from agent.geometry import Camera, Pose, pixel_ray_slopes


class ObservationError(ValueError):
    """A step input that cannot be used; the app answers 422 naming ``field``."""

    def __init__(self, field: str, detail: str) -> None:
        self.field = field
        self.detail = detail
        super().__init__(f"{field}: {detail}")


@dataclass(frozen=True, eq=False)
class Observation:
    """One decoded, validated step input (DESIGN.md §4); arrays are [H, W] in the session camera's size."""

    rgb: np.ndarray | None = None
    """uint8 [H, W, 3] in RGB order."""
    depth: np.ndarray | None = None
    """float32 [H, W] z-depth, metres; finite and >= 0 (0 = no reading)."""
    depth_uncertainty: np.ndarray | None = None
    """float32 [H, W] width of the 90% interval of each depth reading, metres (HLSM's W90)."""
    instances: np.ndarray | None = None
    """int32 [H, W] instance ids; every id appears in ``legend`` except 0, which means "nothing known"."""
    legend: Mapping[int, str] = field(default_factory=dict)
    """Instance id -> canonical ontology type."""
    instance_ids_persistent: bool = True
    """Whether an id names the same object in every frame (a simulator's) or only in this one (a
    segmenter's); becomes ``Percept.persistent_ids``."""
    pose: Pose | None = None
    """World-frame pose when the caller knows it."""
    last_action_success: bool | None = None
    held_object: str | None = None
    """Canonical type of what the agent holds, when the caller says."""


@dataclass(frozen=True, eq=False)
class Percept:
    """What the map update consumes: depth with its trusted pixels, and per-pixel classes and instances."""

    depth: np.ndarray
    """float32 [H, W] z-depth, metres."""
    depth_valid: np.ndarray
    """bool [H, W]: pixels whose depth the map may use (equation (5) of HLSM when uncertainty is known)."""
    class_ids: np.ndarray
    """uint8 [H, W] agent class ids (``agent.classes``), 0 = unknown."""
    instances: np.ndarray
    """int32 [H, W] instance ids (0 = none)."""
    instance_types: Mapping[int, str]
    """Instance id -> canonical type of the instances in this frame."""
    persistent_ids: bool = True
    """Whether an instance id names the same object in every frame (the simulator's ids, as the oracle
    gives them). The learned back-end numbers connected components afresh each frame, so the executor then
    recognises an instance it failed on, put down or finished with by where it is, not by its id."""
    depth_far: np.ndarray | None = None
    """float32 [H, W]: the far end of each reading's 90% interval (None: the depth is exact). Reach is
    judged on it, so an object the network puts at 1.2 m give or take 0.4 m is walked closer to first."""

    def __post_init__(self) -> None:
        H, W = self.depth.shape
        for name in ("depth_valid", "class_ids", "instances", "depth_far"):
            if getattr(self, name) is None:
                continue
            shape = getattr(self, name).shape
            assert shape == (H, W), f"{name} has shape {shape}, depth has {(H, W)}"
        assert self.class_ids.dtype == np.uint8, f"class_ids must be uint8, got {self.class_ids.dtype}"
        assert self.depth_valid.dtype == bool, f"depth_valid must be bool, got {self.depth_valid.dtype}"


@dataclass(frozen=True)
class HandRegion:
    """The directions in which what the agent holds shows: bounds on the camera-frame ray slopes x/z
    (right over forward) and y/z (down over forward), so one region serves every resolution and field
    of view.

    The held object rides 0.45 m ahead of the camera, 0.13 m right and down, at most 0.2 m across, as
    AI2-THOR's hand carries it (the harness draws it so). Measured over every pickupable type in the
    harness's rooms it covers x/z 0.06-0.66 and y/z 0.06-0.58, whatever the pitch; the defaults add 0.04.
    """

    x_over_z: tuple[float, float] = (0.02, 0.70)
    y_over_z: tuple[float, float] = (0.02, 0.625)

    def mask(self, camera: Camera) -> np.ndarray:
        """bool [H, W]: the pixels whose rays pass through the region."""
        x_over_z, y_over_z = pixel_ray_slopes(camera)
        columns = (x_over_z >= self.x_over_z[0]) & (x_over_z <= self.x_over_z[1])  # [W]
        rows = (y_over_z >= self.y_over_z[0]) & (y_over_z <= self.y_over_z[1])  # [H]
        return rows[:, None] & columns[None, :]


def without_hand(percept: Percept, hand: np.ndarray) -> Percept:
    """The percept with the hand's pixels (bool [H, W], ``HandRegion.mask``) unknown: no trusted depth,
    class or instance there.

    With true depth the held object is told apart by its nearness (HLSM A.3); an estimated depth puts
    it about 1 m ahead (0.4 m true, the networks rarely saw a held object), where it would be mapped as
    an obstacle and clicked as whatever the network calls it (a held plate read as the sink basin took
    the Place, and the plate went onto the counter instead)."""
    instances = np.where(hand, 0, percept.instances).astype(percept.instances.dtype)
    shown = set(np.unique(instances).tolist())
    return replace(
        percept,
        depth_valid=percept.depth_valid & ~hand,
        class_ids=np.where(hand, 0, percept.class_ids).astype(np.uint8),
        instances=instances,
        instance_types={i: name for i, name in percept.instance_types.items() if i in shown},
    )


class Perception(Protocol):
    """A perception back-end: one observation in, one percept out."""

    def perceive(self, obs: Observation, *, target_type: str | None) -> Percept:
        """``target_type`` is the current subgoal's object: HLSM trusts its depth more (eq. 5)."""
        ...


def confident_depth(
    depth: np.ndarray,
    uncertainty: np.ndarray | None,
    target_mask: np.ndarray | None,
    *,
    c1: float = 0.3,
    c2: float = 1.0,
) -> np.ndarray:
    """bool [H, W]: pixels whose depth the map may trust.

    HLSM eq. (5) (appendix A.3): M = (W90 < c1·E) ∨ ((W90 < c2·E) ∧ target), with W90 the width of the 90%
    interval, E the expected depth and ``target`` the current subgoal's class mask; c1 = 0.3, c2 = 1.0
    give the target more slack. Without uncertainty every finite positive reading is trusted.
    """
    valid = np.isfinite(depth) & (depth > 0)
    if uncertainty is None:
        return valid
    confident = uncertainty < c1 * depth
    if target_mask is not None:
        confident |= (uncertainty < c2 * depth) & target_mask
    return valid & confident
