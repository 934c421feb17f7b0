"""How far the agent reaches: AI2-THOR's visibilityDistance is a cylinder about the agent's vertical axis.

iTHOR's documentation ("Object Visibility"): an object is visible, and so interactable, when it is in the
camera's viewport, a ray from the camera hits it unobstructed, and it lies "within a radius around the
agent's central vertical axis (default: 1.5 meters radius) ... a cylinder centered about the y axis of the
agent" (``GetAllVisibleSimObjPhysics`` measures each visibility point against the agent's position at the
point's own height). The distance is therefore horizontal: a mug at the back of a low cabinet, 1.2 m below
the eye, is in reach from where the agent sees into the cabinet, as in AI2-THOR, though the camera is more
than 1.5 m from it. The simulator, the expert and the world checks all measure reach with this module.
"""

from __future__ import annotations

import numpy as np

from symbolic.thor import INTERACTION_DISTANCE_M


def horizontal_distance(points: np.ndarray, agent_x: float, agent_z: float) -> np.ndarray:
    """float [...]: distance in the floor plane from the agent's vertical axis to world points [..., 3]."""
    points = np.asarray(points, dtype=np.float64)
    if points.shape[-1] != 3:
        raise ValueError(f"points must have a last axis of size 3 (x, y, z), got shape {points.shape}")
    return np.hypot(points[..., 0] - agent_x, points[..., 2] - agent_z)


def in_reach(
    points: np.ndarray, agent_x: float, agent_z: float, limit_m: float = INTERACTION_DISTANCE_M
) -> np.ndarray:
    """bool [...]: world points [..., 3] inside the agent's reach cylinder of radius ``limit_m``."""
    return horizontal_distance(points, agent_x, agent_z) <= limit_m
