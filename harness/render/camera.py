"""THE camera convention of this project: pinhole intrinsics, pose, pixel <-> world.

The renderer draws with these formulas and the agent's mapping must invert them exactly (it keeps its own
copy, so this docstring is the reference both follow):

- World frame is AI2-THOR's (Unity, left-handed): x and z horizontal, y up. Yaw 0 faces +z, yaw 90 faces
  +x: forward = (sin θ, 0, cos θ), right = (cos θ, 0, −sin θ). Horizon h in degrees, positive looks down.
- Camera frame is OpenCV's: x right, y down, z forward. ``camera_to_world(pose)`` has the world
  directions of those three axes as its columns: right, down = −cos h·up − sin h·forward, and
  forward' = cos h·forward − sin h·up. Because Unity is left-handed this matrix is orthogonal with
  determinant −1; its inverse is still its transpose.
- Pinhole from the HORIZONTAL field of view: fx = (W/2)/tan(hfov/2), fy = fx (square pixels), principal
  point (cx, cy) = (W/2, H/2). Pixel (row i, column j) covers [j, j+1) x [i, i+1) and its ray goes through
  its centre (u, v) = (j + 0.5, i + 0.5); equivalently cx = (W−1)/2 in integer pixel indices, as FILM's
  and HLSM's depth-to-point code has it. Row 0 is the top of the image.
- Depth is z-depth, the distance along the optical axis, as AI2-THOR's depth frames are (metres).
  A camera-frame point is depth·((u−cx)/fx, (v−cy)/fy, 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from harness.world.model import AgentState
from symbolic.thor import (
    ALFRED_HFOV_DEG,
    ALFRED_IMAGE_SIDE,
    CAMERA_HEIGHT_M,
    TEACH_HFOV_DEG,
    TEACH_IMAGE_SIDE,
)


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole parameters in pixels."""

    fx: float
    fy: float
    cx: float
    cy: float


@dataclass(frozen=True)
class CameraPose:
    """Where the camera is (metres, world frame) and where it looks (degrees, AI2-THOR's yaw and horizon)."""

    x: float
    y: float
    z: float
    yaw_deg: float
    horizon_deg: float

    @classmethod
    def of_agent(cls, agent: AgentState) -> CameraPose:
        """The agent's eye: at its camera height above its floor position, turned and tilted as it is."""
        return cls(agent.x, agent.camera_height, agent.z, float(agent.yaw), float(agent.horizon))

    @property
    def position(self) -> np.ndarray:
        """float64 [3]: (x, y, z) of the optical centre."""
        return np.array([self.x, self.y, self.z], dtype=np.float64)


@dataclass(frozen=True)
class CameraSpec:
    """An egocentric camera: image size, horizontal field of view and mount height."""

    width: int  # pixels
    height: int  # pixels
    hfov_deg: float  # horizontal field of view, degrees (TEACh 90, ALFRED 60)
    height_m: float = CAMERA_HEIGHT_M  # optical centre above the floor, metres (AI2-THOR's default agent)

    def __post_init__(self) -> None:
        if self.width < 1:
            raise ValueError(f"width must be a positive number of pixels, got {self.width}")
        if self.height < 1:
            raise ValueError(f"height must be a positive number of pixels, got {self.height}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"hfov_deg must lie in (0, 180), got {self.hfov_deg}")
        if not self.height_m > 0.0:
            raise ValueError(f"height_m must be positive, got {self.height_m}")

    def intrinsics(self) -> Intrinsics:
        fx = (self.width / 2.0) / math.tan(math.radians(self.hfov_deg) / 2.0)
        return Intrinsics(fx=fx, fy=fx, cx=self.width / 2.0, cy=self.height / 2.0)

    def pose_at(self, x: float, z: float, yaw_deg: float, horizon_deg: float) -> CameraPose:
        """A pose of this camera for a body standing at (x, z): the eye is ``height_m`` above the floor."""
        return CameraPose(x, self.height_m, z, yaw_deg, horizon_deg)


ALFRED_CAMERA = CameraSpec(ALFRED_IMAGE_SIDE, ALFRED_IMAGE_SIDE, ALFRED_HFOV_DEG)
"""ALFRED's frames: 300x300 with a 60° field of view."""
TEACH_CAMERA = CameraSpec(TEACH_IMAGE_SIDE, TEACH_IMAGE_SIDE, TEACH_HFOV_DEG)
"""TEACh's frames: 900x900 with a 90° field of view."""


class ImagePoints(NamedTuple):
    """Projections of world points: continuous pixel coordinates and z-depth (metres).

    Pixel index is (floor(v), floor(u)); u and v are NaN where depth <= 0 (the point is behind the camera).
    """

    u: np.ndarray
    v: np.ndarray
    depth: np.ndarray


def camera_to_world(pose: CameraPose) -> np.ndarray:
    """float64 [3, 3]: columns are the world directions of the camera's right, down and forward axes."""
    yaw = math.radians(pose.yaw_deg)
    horizon = math.radians(pose.horizon_deg)
    forward = np.array([math.sin(yaw), 0.0, math.cos(yaw)])
    right = np.array([math.cos(yaw), 0.0, -math.sin(yaw)])
    up = np.array([0.0, 1.0, 0.0])
    optical_axis = math.cos(horizon) * forward - math.sin(horizon) * up
    down = -math.cos(horizon) * up - math.sin(horizon) * forward
    return np.stack([right, down, optical_axis], axis=1)


def pixel_ray_tables(spec: CameraSpec) -> tuple[np.ndarray, np.ndarray]:
    """Camera-frame ray slopes through pixel centres: x/z per column [W] and y/z per row [H], float32.

    Rays are normalised to z = 1, so a ray parameter IS z-depth; the table is separable, so per-spec
    storage is two short vectors instead of an [H, W, 3] array.
    """
    k = spec.intrinsics()
    x_over_z = (np.arange(spec.width, dtype=np.float64) + 0.5 - k.cx) / k.fx  # [W]
    y_over_z = (np.arange(spec.height, dtype=np.float64) + 0.5 - k.cy) / k.fy  # [H]
    return x_over_z.astype(np.float32), y_over_z.astype(np.float32)


def rays_world(spec: CameraSpec, pose: CameraPose) -> np.ndarray:
    """float32 [3, H, W]: world direction of every pixel's ray, scaled so that camera-frame z is 1.

    A hit at ray parameter t lies at ``pose.position + t * ray`` and has z-depth t.
    """
    x_over_z, y_over_z = pixel_ray_tables(spec)
    R = camera_to_world(pose).astype(np.float32)
    rays = np.empty((3, spec.height, spec.width), dtype=np.float32)
    for axis in range(3):
        rays[axis] = R[axis, 0] * x_over_z[None, :] + R[axis, 1] * y_over_z[:, None] + R[axis, 2]
    return rays


def pixel_to_world(depth: np.ndarray, spec: CameraSpec, pose: CameraPose) -> np.ndarray:
    """float32 [H, W, 3]: the world point each pixel's z-depth (metres) puts on its ray."""
    if depth.shape != (spec.height, spec.width):
        raise ValueError(f"depth must have shape {(spec.height, spec.width)}, got {depth.shape}")
    rays = rays_world(spec, pose)  # [3, H, W]
    origin = pose.position.astype(np.float32)
    points = origin[:, None, None] + depth.astype(np.float32)[None] * rays  # [3, H, W]
    return np.ascontiguousarray(np.moveaxis(points, 0, -1))


def world_to_pixel(points: np.ndarray, spec: CameraSpec, pose: CameraPose) -> ImagePoints:
    """Project world points [..., 3] into the image; the exact inverse of ``pixel_to_world``."""
    points = np.asarray(points, dtype=np.float64)
    if points.shape[-1] != 3:
        raise ValueError(f"points must have a last axis of size 3, got shape {points.shape}")
    k = spec.intrinsics()
    cam = (points - pose.position) @ camera_to_world(pose)  # [..., 3] (x right, y down, z forward)
    depth = cam[..., 2]
    in_front = depth > 0
    safe_depth = np.where(in_front, depth, 1.0)
    u = np.where(in_front, k.fx * cam[..., 0] / safe_depth + k.cx, np.nan)
    v = np.where(in_front, k.fy * cam[..., 1] / safe_depth + k.cy, np.nan)
    return ImagePoints(u=u, v=v, depth=depth)
