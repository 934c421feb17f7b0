"""The agent's camera and body geometry in AI2-THOR's frame, and dead reckoning.

Conventions (the harness renderer uses the same ones, ``harness/render/camera.py``): x and z are horizontal, y
is up with the floor at y = 0; yaw 0 faces +z and yaw 90 faces +x, so the forward vector is
(sin θ, 0, cos θ) and the right vector (cos θ, 0, −sin θ); a positive horizon looks down. The camera is a
pinhole built from the HORIZONTAL field of view, fx = fy = (W/2)/tan(hfov/2), principal point at the image
centre, pixel (row r, col c) spanning [c, c+1) × [r, r+1); depth is z-depth along the optical axis, in
metres, as AI2-THOR's depth frames are.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from symbolic.thor import (
    CAMERA_HEIGHT_M,
    GRID_STEP_M,
    HORIZON_MAX_DEG,
    HORIZON_MIN_DEG,
    TEACH_LOOK_STEP_DEG,
    TURN_STEP_DEG,
)

_MOVES: dict[str, tuple[float, float]] = {
    "Forward": (1.0, 0.0),
    "Backward": (-1.0, 0.0),
    "Pan Right": (0.0, 1.0),
    "Pan Left": (0.0, -1.0),
}
"""Motion actions as (forward, right) steps of GRID_STEP_M in the body frame (TEACh's action table)."""

_TURNS: dict[str, int] = {"Turn Right": TURN_STEP_DEG, "Turn Left": -TURN_STEP_DEG}
"""AI2-THOR's RotateRight adds to the yaw."""

_LOOKS: dict[str, int] = {"Look Down": 1, "Look Up": -1}
"""Looking down increases the horizon."""


@dataclass(frozen=True)
class Pose:
    """Where the agent stands and looks: metres on the floor plane, degrees for angles."""

    x: float  # metres
    z: float  # metres
    yaw: float = 0.0  # degrees in [0, 360); 0 faces +z, 90 faces +x
    horizon: float = 0.0  # degrees; positive looks down, AI2-THOR keeps it in [-30, 60]

    def forward(self) -> tuple[float, float]:
        """Unit (x, z) the body faces."""
        yaw = math.radians(self.yaw)
        return math.sin(yaw), math.cos(yaw)

    def right(self) -> tuple[float, float]:
        """Unit (x, z) to the body's right."""
        yaw = math.radians(self.yaw)
        return math.cos(yaw), -math.sin(yaw)

    def apply_motion(self, action: str, success: bool, *, look_step_deg: float = TEACH_LOOK_STEP_DEG) -> Pose:
        """The pose after ``action``, for dead reckoning when the caller sends no pose.

        Only successful motion changes the pose (a blocked Forward leaves the agent where it was, as in
        AI2-THOR); moves are GRID_STEP_M in the body frame, turns TURN_STEP_DEG, looks ``look_step_deg``
        (TEACh 30°, ALFRED 15°) clamped to AI2-THOR's horizon limits. Object actions do not move the body.
        """
        if not success:
            return self
        if action in _MOVES:
            ahead, aside = _MOVES[action]
            (fx, fz), (rx, rz) = self.forward(), self.right()
            return replace(
                self,
                x=self.x + GRID_STEP_M * (ahead * fx + aside * rx),
                z=self.z + GRID_STEP_M * (ahead * fz + aside * rz),
            )
        if action in _TURNS:
            return replace(self, yaw=(self.yaw + _TURNS[action]) % 360.0)
        if action in _LOOKS:
            horizon = self.horizon + _LOOKS[action] * look_step_deg
            return replace(self, horizon=min(max(horizon, HORIZON_MIN_DEG), HORIZON_MAX_DEG))
        return self


def track_pose(
    previous: Pose,
    *,
    reported: Pose | None,
    last_action: str | None,
    last_action_success: bool | None,
    look_step_deg: float = TEACH_LOOK_STEP_DEG,
) -> Pose:
    """The pose for this step: the caller's world-frame pose when given, else dead reckoning.

    DESIGN.md §3: a pose in the request wins; otherwise the previous pose moves by the last action when it
    succeeded (unknown success counts as success here: the caller infers it from the image change first).
    """
    if reported is not None:
        return reported
    if last_action is None:
        return previous
    return previous.apply_motion(last_action, last_action_success is not False, look_step_deg=look_step_deg)


@dataclass(frozen=True)
class Camera:
    """The egocentric pinhole camera the caller's frames come from (square pixels)."""

    width: int  # pixels
    height: int  # pixels
    hfov_deg: float  # horizontal field of view, degrees, in (0, 180)
    height_m: float = CAMERA_HEIGHT_M  # metres above the floor

    def __post_init__(self) -> None:
        if self.width < 1 or self.height < 1:
            raise ValueError(f"camera size must be positive, got {self.width}x{self.height}")
        if not 0.0 < self.hfov_deg < 180.0:
            raise ValueError(f"hfov_deg must lie in (0, 180), got {self.hfov_deg}")
        if self.height_m <= 0.0:
            raise ValueError(f"height_m must be positive metres, got {self.height_m}")

    @property
    def focal_px(self) -> float:
        """fx = fy = (W/2) / tan(hfov/2): the focal length from the horizontal field of view."""
        return (self.width / 2.0) / math.tan(math.radians(self.hfov_deg) / 2.0)


@functools.lru_cache(maxsize=16)
def pixel_ray_slopes(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Camera-frame ray slopes through pixel centres: x/z per column [W] and y/z per row [H], float32.

    Rays scaled to z = 1 turn a z-depth into a point with one multiply; the table is separable, so a
    camera costs two short vectors. Cached per camera and read-only (shared between sessions).
    """
    f = camera.focal_px
    x_over_z = ((np.arange(camera.width) + 0.5 - camera.width / 2.0) / f).astype(np.float32)  # [W]
    y_over_z = ((np.arange(camera.height) + 0.5 - camera.height / 2.0) / f).astype(np.float32)  # [H]
    x_over_z.flags.writeable = False
    y_over_z.flags.writeable = False
    return x_over_z, y_over_z


@functools.lru_cache(maxsize=16)
def pixel_ray_lengths(camera: Camera) -> np.ndarray:
    """float32 [H, W]: Euclidean length of each unit-z ray; distance from the eye = z-depth × length."""
    x_over_z, y_over_z = pixel_ray_slopes(camera)
    lengths = np.sqrt(1.0 + x_over_z[None, :] ** 2 + y_over_z[:, None] ** 2).astype(np.float32)
    lengths.flags.writeable = False
    return lengths


def pixel_axis_distances(depth: np.ndarray, camera: Camera, horizon_deg: float) -> np.ndarray:
    """float32 [H, W]: horizontal metres from the agent's vertical axis to each pixel's surface.

    AI2-THOR's reach (``visibilityDistance``) is a capsule about that axis, so this, not the distance from
    the eye, decides what can be clicked. A pixel's world offset is z-depth × (x/z · right + y/z · down +
    forward); right and the level part of down and forward are orthonormal, so its level length is
    z-depth × sqrt((x/z)² + (cos h − (y/z) sin h)²) for a camera pitched h down, whatever the yaw.
    """
    x_over_z, y_over_z = pixel_ray_slopes(camera)
    pitch = math.radians(horizon_deg)
    level = math.cos(pitch) - y_over_z[:, None] * math.sin(pitch)  # [H, 1]
    return (depth * np.sqrt(x_over_z[None, :] ** 2 + level**2)).astype(np.float32)


def camera_position(camera: Camera, pose: Pose) -> np.ndarray:
    """float64 [3]: the optical centre in the world (the eye, camera.height_m above the floor)."""
    return np.array([pose.x, camera.height_m, pose.z], dtype=np.float64)


def camera_to_world(pose: Pose) -> np.ndarray:
    """float64 [3, 3] rotation whose columns are the camera's right, down and optical axes in the world.

    With yaw θ and horizon h (down positive): right = (cos θ, 0, −sin θ), forward = (sin θ cos h, −sin h,
    cos θ cos h), down = (−sin θ sin h, −cos h, −cos θ sin h).
    """
    yaw, pitch = math.radians(pose.yaw), math.radians(pose.horizon)
    sy, cy, sp, cp = math.sin(yaw), math.cos(yaw), math.sin(pitch), math.cos(pitch)
    right = (cy, 0.0, -sy)
    down = (-sy * sp, -cp, -cy * sp)
    forward = (sy * cp, -sp, cy * cp)
    return np.array([right, down, forward], dtype=np.float64).T


def depth_to_xyz(
    depth: np.ndarray, camera: Camera, pose: Pose, mask: np.ndarray | None = None, *, stride: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World x, y, z (float32 [N] each) of the pixels in ``mask`` (all pixels when None), row-major order.

    Back-projection of the pinhole model: p = C + d · R · (x/z, y/z, 1), with d the z-depth. Computed per
    axis on the whole image and then masked: cheaper in numpy than gathering [N, 3] rays. With ``stride``
    > 1, ``depth`` (and ``mask``) hold every stride-th pixel, ``full[s // 2 :: s, s // 2 :: s]``.
    """
    x_over_z, y_over_z = pixel_ray_slopes(camera)
    if stride > 1:
        x_over_z, y_over_z = x_over_z[stride // 2 :: stride], y_over_z[stride // 2 :: stride]
    H, W = depth.shape
    assert (len(y_over_z), len(x_over_z)) == (H, W), f"depth {W}x{H} vs camera {camera} at stride {stride}"
    assert mask is None or mask.shape == (H, W), f"mask {None if mask is None else mask.shape} vs {(H, W)}"
    rotation = camera_to_world(pose).astype(np.float32)
    centre = camera_position(camera, pose).astype(np.float32)
    axes = []
    for axis in range(3):
        direction = rotation[axis, 0] * x_over_z[None, :] + rotation[axis, 1] * y_over_z[:, None]  # [H, W]
        direction += rotation[axis, 2]
        direction *= depth
        direction += centre[axis]
        axes.append(direction.reshape(-1) if mask is None else direction[mask])
    return axes[0], axes[1], axes[2]


def depth_to_points(
    depth: np.ndarray, camera: Camera, pose: Pose, mask: np.ndarray | None = None
) -> np.ndarray:
    """float32 [N, 3] world points (x, y, z) of the pixels in ``mask`` (all pixels when None), row-major."""
    return np.stack(depth_to_xyz(depth, camera, pose, mask), axis=1)


def project_points(
    points: np.ndarray, camera: Camera, pose: Pose
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous (rows, cols, depth) of world points [N, 3]: the exact inverse of ``depth_to_points``.

    Pixel (r, c) spans rows [r, r+1) and cols [c, c+1), so ``floor`` gives the pixel index; rows and cols
    are NaN for points at or behind the camera (depth <= 0).
    """
    assert points.ndim == 2 and points.shape[1] == 3, f"points must be [N, 3], got {points.shape}"
    local = (points - camera_position(camera, pose)) @ camera_to_world(pose)  # [N, 3] camera frame
    depth = local[:, 2]
    in_front = depth > 0
    scale = camera.focal_px / np.where(in_front, depth, 1.0)
    cols = np.where(in_front, local[:, 0] * scale + camera.width / 2.0, np.nan)
    rows = np.where(in_front, local[:, 1] * scale + camera.height / 2.0, np.nan)
    return rows, cols, depth
