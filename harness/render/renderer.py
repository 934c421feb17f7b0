"""The harness's camera: RGB, z-depth (metres) and instance segmentation of a world from the agent's eye.

Stands in for AI2-THOR's renderer, whose frames the JARVIS and HLSM agents consume (RGB for learned
perception; depth and instance masks for oracle perception and for resolving clicks). Vectorised ray
casting: every pixel has a ray (``harness.render.camera`` conventions); floor and ceiling are intersected
analytically for all pixels at once, then each box is slab-tested only against the rays inside its
projected screen rectangle and kept where it is nearer than the z-buffer. Work per frame is
O(pixels x overdraw) plus a small constant per box.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from harness.render.appearance import Exposure, Lighting, Surface, compile_surfaces, shade
from harness.render.camera import CameraPose, CameraSpec, camera_to_world, rays_world
from harness.render.geometry import Box, primitives
from harness.world.model import STRUCTURE_IDS, Room, World
from symbolic.thor import GRID_STEP_M

NEAR_M = 0.01  # surfaces nearer than this to the eye (z-depth, metres) are not drawn
MIN_RAY_COMPONENT = 1e-12  # ray components smaller than this are treated as this (avoids 0 * inf in slabs)
MIN_PLANE_SLOPE = 1e-6  # rays flatter than this never reach the floor or ceiling
SHADE_BATCH_PIXELS = 16384  # float32 batch temporaries stay at 64 KiB, which malloc recycles (no page faults)
PLANE_HALF_EXTENT_M = 1e6  # floor and ceiling act as boxes this wide when finding face normals

FLOOR_PRIM, CEILING_PRIM = 0, 1
"""Primitive indices of the two planes; boxes follow from 2."""

_CORNER_BITS = np.array([[i >> 2 & 1, i >> 1 & 1, i & 1] for i in range(8)], dtype=np.float64)  # [8, 3]
_EDGES = np.array([(i, i | bit) for i in range(8) for bit in (1, 2, 4) if not i & bit])  # [12, 2] box edges


@dataclass(frozen=True)
class Frame:
    """One egocentric observation as AI2-THOR reports it (plus the id maps the oracle needs)."""

    rgb: np.ndarray | None  # uint8 [H, W, 3]; None when rendered with want_rgb=False
    depth: np.ndarray  # float32 [H, W] z-depth in metres; 0 where a ray hit nothing
    instances: np.ndarray  # int32 [H, W] instance ids; 0 where a ray hit nothing
    legend: dict[int, str] = field(default_factory=dict)  # id -> object type of every id in the frame
    object_ids: dict[int, str] = field(default_factory=dict)  # id -> object id, for objects in the frame
    depth_uncertainty: np.ndarray | None = None  # float32 [H, W] metres: width of a depth estimate's 90%
    # interval, sent with a depth that is an estimate (the renderer's own depth is exact: None)
    instance_ids_persistent: bool = True  # False: ids numbered afresh for this frame (a segmenter's)


class Renderer:
    """Renders worlds through one camera; build once per camera and reuse across frames."""

    def __init__(self, spec: CameraSpec, lighting: Lighting | None = None) -> None:
        self.spec = spec
        self.lighting = lighting or Lighting()

    def render(self, world: World, *, noise_seed: int | None = None, want_rgb: bool = True) -> Frame:
        """Same world and noise_seed give the same frame; noise_seed None renders without light noise.

        ``want_rgb=False`` skips shading for callers that need only depth and segmentation (the expert,
        oracle perception, click resolution).
        """
        pose = CameraPose.of_agent(world.agent)
        eye = pose.position.astype(np.float32)
        rays = rays_world(self.spec, pose)  # [3, H, W]
        boxes = primitives(world)
        lo, hi = _prim_bounds(world.room, boxes)  # [P, 3] each, planes first
        depth, prim = self._nearest_surfaces(world.room, boxes, lo, hi, pose, rays)
        hit = prim >= 0
        plane_ids = [STRUCTURE_IDS["Floor"], STRUCTURE_IDS["Ceiling"]]
        prim_instance = np.array([*plane_ids, *(box.instance_id for box in boxes)], dtype=np.int32)
        instances = np.where(hit, prim_instance[np.maximum(prim, 0)], 0).astype(np.int32)
        legend, object_ids = _legends(world, instances)
        rgb = None
        if want_rgb:
            surfaces = [_structure_surface("Floor", world), _structure_surface("Ceiling", world)]
            surfaces += [box.surface for box in boxes]
            rgb = self._colour(surfaces, lo, hi, eye, rays, depth, prim, hit, noise_seed)
        return Frame(
            rgb=rgb,
            depth=np.where(hit, depth, 0.0).astype(np.float32),
            instances=instances,
            legend=legend,
            object_ids=object_ids,
        )

    def _nearest_surfaces(
        self, room: Room, boxes: list[Box], lo: np.ndarray, hi: np.ndarray, pose: CameraPose, rays: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The z-buffer: float32 [H, W] depth of the nearest hit and int32 [H, W] its primitive (-1: none)."""
        H, W = self.spec.height, self.spec.width
        eye = pose.position.astype(np.float32)
        safe = np.where(np.abs(rays) < MIN_RAY_COMPONENT, np.float32(MIN_RAY_COMPONENT), rays)
        inv_rays = (1.0 / safe).astype(np.float32)  # [3, H, W]
        depth = np.full((H, W), np.inf, dtype=np.float32)
        prim = np.full((H, W), -1, dtype=np.int32)
        _draw_planes(room, eye, rays, inv_rays, depth, prim)
        rects = _screen_rects(lo, hi, pose, self.spec)  # [P, 4] row0, row1, col0, col1
        for i, box in enumerate(boxes, start=2):
            if not box.in_hand:
                _draw_box(i, lo[i], hi[i], rects[i], eye, inv_rays, depth, prim)
        in_hand = [i for i, box in enumerate(boxes, start=2) if box.in_hand]
        if in_hand:
            # The held object is drawn over everything (AI2-THOR never lets it vanish into a wall).
            hand_depth = np.full_like(depth, np.inf)
            hand_prim = np.full_like(prim, -1)
            for i in in_hand:
                _draw_box(i, lo[i], hi[i], rects[i], eye, inv_rays, hand_depth, hand_prim)
            held = hand_prim >= 0
            depth[held] = hand_depth[held]
            prim[held] = hand_prim[held]
        return depth, prim

    def _colour(
        self,
        surfaces: list[Surface],
        lo: np.ndarray,
        hi: np.ndarray,
        eye: np.ndarray,
        rays: np.ndarray,
        depth: np.ndarray,
        prim: np.ndarray,
        hit: np.ndarray,
        noise_seed: int | None,
    ) -> np.ndarray:
        """uint8 [H, W, 3]: every pixel shaded by its surface, world hit point and face normal, then exposed.

        Pixels are shaded in batches of SHADE_BATCH_PIXELS; pixels that hit nothing are black.
        """
        H, W = depth.shape
        table = compile_surfaces(surfaces)
        exposure = Exposure(noise_seed, self.lighting)
        surface_of_pixel = prim.ravel()
        ray_of_pixel = rays.reshape(3, H * W)
        depth_of_pixel = np.where(hit, depth, 0.0).ravel()
        image = np.empty((H * W, 3), dtype=np.uint8)
        for start in range(0, H * W, SHADE_BATCH_PIXELS):
            batch = slice(start, start + SHADE_BATCH_PIXELS)
            s = surface_of_pixel[batch]
            missed = s < 0
            s = np.maximum(s, 0)
            ray = ray_of_pixel[:, batch]  # [3, n]
            points = eye[:, None] + depth_of_pixel[batch] * ray  # [3, n]
            normal_axis, normal_sign = _face_normals(points, ray, lo.take(s, axis=0), hi.take(s, axis=0))
            colours = shade(table, s, points, normal_axis, normal_sign, self.lighting)
            colours[:, missed] = 0.0
            image[batch] = exposure.apply(colours)
        return image.reshape(H, W, 3)


def _face_normals(
    points: np.ndarray, ray: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Axis (int [n]) and sign (float32 [n]) of the box face each hit point lies on.

    The face is the one of the six box planes nearest the point; it faces the camera, so its normal
    points against the ray. points, ray: [3, n]; lo, hi: the hit box's corners, [n, 3].
    """
    to_face = np.minimum(np.abs(points - lo.T), np.abs(points - hi.T))  # [3, n]
    dx, dy, dz = to_face
    normal_axis = np.where((dy <= dx) & (dy <= dz), 1, np.where(dz < dx, 2, 0))
    along = np.where(normal_axis == 0, ray[0], np.where(normal_axis == 1, ray[1], ray[2]))
    normal_sign = np.where(along > 0, np.float32(-1.0), np.float32(1.0))
    return normal_axis, normal_sign


def _structure_surface(name: str, world: World) -> Surface:
    """Floor and ceiling look: keyed by the world's name so paint and boards vary between worlds."""
    return Surface(object_type=name, instance_key=world.name)


def _prim_bounds(room: Room, boxes: list[Box]) -> tuple[np.ndarray, np.ndarray]:
    """float32 [P, 3] min and max corners: floor slab, ceiling slab, then the boxes."""
    big = PLANE_HALF_EXTENT_M
    lo = [(-big, -1.0, -big), (-big, room.wall_height, -big), *(box.lo for box in boxes)]
    hi = [(big, 0.0, big), (big, room.wall_height + 1.0, big), *(box.hi for box in boxes)]
    return np.asarray(lo, dtype=np.float32), np.asarray(hi, dtype=np.float32)


def _draw_planes(
    room: Room,
    eye: np.ndarray,
    rays: np.ndarray,
    inv_rays: np.ndarray,
    depth: np.ndarray,
    prim: np.ndarray,
) -> None:
    """Ray-plane hits for every pixel: floor (y = 0, only over floor cells) and ceiling (y = wall height)."""
    ox, oy, oz = (float(c) for c in eye)
    t_floor = (0.0 - oy) * inv_rays[1]  # [H, W]
    on_floor = (rays[1] < -MIN_PLANE_SLOPE) & (t_floor > NEAR_M)
    t_safe = np.where(on_floor, t_floor, 0.0)
    cell_x = np.floor((ox + t_safe * rays[0] - room.origin[0]) / GRID_STEP_M)
    cell_z = np.floor((oz + t_safe * rays[2] - room.origin[1]) / GRID_STEP_M)
    NX, NZ = room.shape
    inside = (cell_x >= 0) & (cell_x < NX) & (cell_z >= 0) & (cell_z < NZ)
    ix = np.clip(cell_x, 0, NX - 1).astype(np.int64)
    iz = np.clip(cell_z, 0, NZ - 1).astype(np.int64)
    on_floor &= inside & room.floor[ix, iz]
    np.copyto(depth, t_floor, where=on_floor)
    prim[on_floor] = FLOOR_PRIM

    t_ceiling = (room.wall_height - oy) * inv_rays[1]
    on_ceiling = (rays[1] > MIN_PLANE_SLOPE) & (t_ceiling > NEAR_M) & (t_ceiling < depth)
    np.copyto(depth, t_ceiling, where=on_ceiling)
    prim[on_ceiling] = CEILING_PRIM


def _screen_rects(lo: np.ndarray, hi: np.ndarray, pose: CameraPose, spec: CameraSpec) -> np.ndarray:
    """int64 [P, 4] (row0, row1, col0, col1), end-exclusive: the pixels whose rays may hit each box.

    The box is clipped against the near plane (corners in front plus edge crossings) and the clipped
    solid's vertices are projected; empty rectangles mean the box is off screen or behind the eye.
    """
    k = spec.intrinsics()
    R = camera_to_world(pose)
    corners = lo[:, None, :] + _CORNER_BITS[None] * (hi - lo)[:, None, :]  # [P, 8, 3]
    cam = (corners - pose.position) @ R  # [P, 8, 3] camera frame
    a, b = cam[:, _EDGES[:, 0]], cam[:, _EDGES[:, 1]]  # [P, 12, 3]
    za, zb = a[..., 2], b[..., 2]
    crossing = (za - NEAR_M) * (zb - NEAR_M) < 0  # [P, 12]
    s = (NEAR_M - za) / np.where(crossing, zb - za, 1.0)
    clipped = a + s[..., None] * (b - a)  # [P, 12, 3]
    points = np.concatenate([cam, clipped], axis=1)  # [P, 20, 3]
    valid = np.concatenate([cam[..., 2] >= NEAR_M, crossing], axis=1)  # [P, 20]
    z = np.where(valid, points[..., 2], 1.0)
    u = k.fx * points[..., 0] / z + k.cx
    v = k.fy * points[..., 1] / z + k.cy
    W, H = spec.width, spec.height
    u_min = np.clip(np.where(valid, u, np.inf).min(axis=1), -2.0, W + 2.0)
    u_max = np.clip(np.where(valid, u, -np.inf).max(axis=1), -2.0, W + 2.0)
    v_min = np.clip(np.where(valid, v, np.inf).min(axis=1), -2.0, H + 2.0)
    v_max = np.clip(np.where(valid, v, -np.inf).max(axis=1), -2.0, H + 2.0)
    # Pixel j's ray passes through u = j + 0.5; one pixel of margin absorbs rounding.
    col0 = np.clip(np.ceil(u_min - 0.5) - 1, 0, W)
    col1 = np.clip(np.floor(u_max - 0.5) + 2, 0, W)
    row0 = np.clip(np.ceil(v_min - 0.5) - 1, 0, H)
    row1 = np.clip(np.floor(v_max - 0.5) + 2, 0, H)
    rects = np.stack([row0, row1, col0, col1], axis=1).astype(np.int64)
    rects[~valid.any(axis=1)] = 0
    return rects


def _draw_box(
    index: int,
    lo: np.ndarray,
    hi: np.ndarray,
    rect: np.ndarray,
    origin: np.ndarray,
    inv_rays: np.ndarray,
    depth: np.ndarray,
    prim: np.ndarray,
) -> None:
    """Slab test (Kay & Kajiya) of one box against the rays in its rectangle; keep nearer entry hits."""
    row0, row1, col0, col1 = (int(v) for v in rect)
    if row0 >= row1 or col0 >= col1:
        return
    inv = inv_rays[:, row0:row1, col0:col1]  # [3, h, w]
    t_lo = (lo - origin)[:, None, None] * inv  # ray parameter (= z-depth) at each slab's planes
    t_hi = (hi - origin)[:, None, None] * inv
    near = np.minimum(t_lo, t_hi).max(axis=0)  # [h, w] entry into the box
    far = np.maximum(t_lo, t_hi).min(axis=0)  # [h, w] exit
    depth_view = depth[row0:row1, col0:col1]
    hit = (near <= far) & (near > NEAR_M) & (near < depth_view)
    np.copyto(depth_view, near, where=hit)
    prim[row0:row1, col0:col1][hit] = index


def _legends(world: World, instances: np.ndarray) -> tuple[dict[int, str], dict[int, str]]:
    """Types of every id present in the frame, and object ids of the objects among them."""
    present = np.flatnonzero(np.bincount(instances.ravel()))
    structure_names = {iid: name for name, iid in STRUCTURE_IDS.items()}
    object_of_id = {iid: oid for oid, iid in world.instance_ids.items()}
    legend: dict[int, str] = {}
    object_ids: dict[int, str] = {}
    for iid in (int(i) for i in present if i != 0):
        if iid in structure_names:
            legend[iid] = structure_names[iid]
        else:
            object_id = object_of_id[iid]
            legend[iid] = world.objects[object_id].object_type
            object_ids[iid] = object_id
    return legend, object_ids
