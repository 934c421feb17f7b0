"""HLSM's semantic voxel map with observability (seed 000 §4.2), at JARVIS's 5 cm resolution (seed 002 §5).

One uint8 voxel array [X, Z, B] holds both of HLSM's maps: 255 = never observed (V^O = 0), 0 = observed
empty, k = observed holding class k (the argmax of V^S; with oracle segmentation it is one-hot anyway).
Equation (1), V^S_t = V̂^S_t · V̂^O_t + V^S_{t-1} · (1 − V̂^O_t), becomes: the voxels this frame observes are
overwritten with what it shows, every other voxel keeps its value. A voxel is observed when it holds
points, or when its test point projects onto a pixel whose depth lies beyond it (HLSM's free-space test,
done here from the voxel side so no ray is marched; the test point is the middle of the voxel's bottom
face rather than HLSM's centre, see ``MapConfig.bin_bottoms_m``). The 2D maps the navigator and the
executor need (presence per class, obstacles, explored, free, visited, collisions) are derived on demand.
The whole update is integer and in place on a small sub-volume: no class-by-voxel tensor is ever built.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import json
import math
import struct
import zlib
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from typing import Any

import cv2
import numpy as np

from agent.classes import UNOBSERVED_ID, ClassIndex, load_class_index
from agent.geometry import Camera, Pose, camera_position, depth_to_xyz, pixel_ray_lengths
from agent.mapping.config import HEIGHT_QUANTUM_M, MapConfig
from agent.perception.base import Percept

UNKNOWN_SURFACE_ID = 254
"""Voxel value for a surface whose class is unknown (a pixel with depth but class 0): occupied, no type."""
_NEAR_M = 0.05
"""Points closer than this to the image plane are not tested (the projection blows up)."""
_FLOOR_HEIGHT = np.zeros(1, dtype=np.float32)
"""Height of the floor surface, metres (the world's y = 0)."""
_MAGIC = b"JSM1"
VOXEL_LAYOUT = "bin-major"
"""How ``to_bytes`` lays the voxel grid out: [B, X, Z], its memory order (``_voxel_grid``)."""
MAP_ZLIB_LEVEL = 1
"""Measured on a kitchen session after 60 steps (a 614 KB grid): level 1 writes 10 KB in 1.4 ms, level 6
4.6 KB in 5-11 ms. A Redis-backed service encodes the map after every step, so level 1."""
_COLLISION_EVENTS_KEPT = 64
"""Blocked moves remembered with their pose and action (JARVIS Alg. 3 saves pose and action)."""
_VISITED_BIT, _COLLISION_BIT = np.uint8(1), np.uint8(2)


@dataclass(frozen=True)
class GridFrame:
    """World <-> cell conversion of the 2D maps: cell (i, j) spans x ∈ [x0 + i·c, x0 + (i+1)·c), z alike."""

    origin_x: float  # metres, world x of the min corner of cell (0, 0)
    origin_z: float  # metres
    cell_m: float  # metres
    shape: tuple[int, int]  # (X, Z) cells

    def world_to_cell(self, x: float, z: float) -> tuple[int, int]:
        """The cell containing world point (x, z); may lie outside ``shape``."""
        return math.floor((x - self.origin_x) / self.cell_m), math.floor((z - self.origin_z) / self.cell_m)

    def cell_to_world(self, i: int, j: int) -> tuple[float, float]:
        """World (x, z) of a cell's centre."""
        return self.origin_x + (i + 0.5) * self.cell_m, self.origin_z + (j + 0.5) * self.cell_m

    def contains(self, i: int, j: int) -> bool:
        return 0 <= i < self.shape[0] and 0 <= j < self.shape[1]


@dataclass(frozen=True)
class CollisionEvent:
    """A move that was blocked: where the agent stood and what it tried."""

    pose: Pose
    action: str
    step: int


@dataclass(frozen=True)
class UpdateStats:
    """What one frame did to the map (for traces and the bench)."""

    points: int  # pixels projected into voxels
    carved: int  # voxels seen empty this frame (already-empty ones included)
    grew: bool  # the map was enlarged for this frame


class SemanticMap:
    """The persistent 3D map of one session, with its 2D views; see the module docstring."""

    def __init__(
        self, camera: Camera, start: Pose, config: MapConfig = MapConfig(), classes: ClassIndex | None = None
    ) -> None:
        self.camera = camera
        self.config = config
        self.classes = classes or load_class_index()
        side = config.cells(config.initial_extent_m)
        centre_i, centre_j = (math.floor(v / config.cell_m) for v in (start.x, start.z))
        self._offset = (centre_i - side // 2, centre_j - side // 2)  # global cell index of local cell (0, 0)
        self._voxels = _voxel_grid(side, side, config.n_bins)
        self._flags = np.zeros((side, side), dtype=np.uint8)  # bit 0 visited, bit 1 collision
        self._last_seen: dict[int, int] = {}  # class id -> step it was last in view
        self._collision_events: list[CollisionEvent] = []
        self.steps = 0
        """Frames integrated so far."""
        self._views: dict[str, np.ndarray] = {}  # derived 2D maps, dropped whenever the state changes
        self._encoded: bytes | None = None  # ``to_bytes`` of the current state, dropped with the views
        self._tables = _tables(config, self.classes)

    # ----- geometry -------------------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """(X, Z) cells of the 2D maps."""
        X, Z, _ = self._voxels.shape
        return X, Z

    @property
    def frame(self) -> GridFrame:
        """The current world <-> cell conversion (it changes when the map grows)."""
        c = self.config.cell_m
        return GridFrame(self._offset[0] * c, self._offset[1] * c, c, self.shape)

    def world_to_cell(self, x: float, z: float) -> tuple[int, int]:
        return self.frame.world_to_cell(x, z)

    def cell_to_world(self, i: int, j: int) -> tuple[float, float]:
        return self.frame.cell_to_world(i, j)

    @property
    def voxels(self) -> np.ndarray:
        """uint8 [X, Z, B] read-only view: 255 unobserved, 0 empty, k class id k."""
        view = self._voxels.view()
        view.flags.writeable = False
        return view

    @property
    def nbytes(self) -> int:
        """Bytes the map holds in memory (arrays plus the small records)."""
        records = 16 * len(self._last_seen) + 64 * len(self._collision_events)
        return self._voxels.nbytes + self._flags.nbytes + records

    # ----- update ---------------------------------------------------------------------------------------
    def update(self, percept: Percept, pose: Pose, *, holding: bool = False) -> UpdateStats:
        """Integrate one frame seen from ``pose`` (HLSM's projection and accumulation steps, eq. (1)).

        Points come from the trusted pixels within ``max_depth_m`` (and, while ``holding``, not nearer
        than ``holding_min_distance_m``, so the held object never enters the map, HLSM A.3). Free space
        is carved first, then floor cells in plain view are probed, then voxels holding points take their
        class, so a surface always wins over the free space in front of a neighbouring surface.
        """
        cfg, cam = self.config, self.camera
        H, W = percept.depth.shape
        assert (cam.width, cam.height) == (W, H), f"percept {W}x{H} vs camera {cam.width}x{cam.height}"
        depth = percept.depth
        usable = percept.depth_valid
        if holding:
            usable = usable & (depth * pixel_ray_lengths(cam) >= cfg.holding_min_distance_m)
        carve_depth = np.minimum(depth, np.float32(cfg.max_depth_m)) * usable  # 0 where not trusted
        stride = cfg.pixel_stride(W, H)
        class_ids = percept.class_ids
        if stride > 1:  # hits from the centre pixel of each block; carving from each block's nearest pixel
            first = stride // 2
            depth, usable = depth[first::stride, first::stride], usable[first::stride, first::stride]
            class_ids = class_ids[first::stride, first::stride]
            carve_depth = cv2.erode(carve_depth, np.ones((stride, stride), np.uint8), anchor=(0, 0))
            carve_depth = carve_depth[::stride, ::stride]
        hit_mask = usable & (depth <= cfg.max_depth_m)
        xs, ys, zs = depth_to_xyz(depth, cam, pose, hit_mask, stride=stride)  # [N] world metres each
        codes = _lookup(class_ids[hit_mask], self._tables.hit_code)  # [N] uint16: priority << 8 | class
        gi = np.floor(xs * np.float32(1 / cfg.cell_m)).astype(np.int32)  # [N] global cells
        gj = np.floor(zs * np.float32(1 / cfg.cell_m)).astype(np.int32)
        cam_i, cam_j = (math.floor(v / cfg.cell_m) for v in (pose.x, pose.z))
        lo_i, hi_i = min(cam_i, int(gi.min(initial=cam_i))), max(cam_i, int(gi.max(initial=cam_i)))
        lo_j, hi_j = min(cam_j, int(gj.min(initial=cam_j))), max(cam_j, int(gj.max(initial=cam_j)))
        # The camera's cell first: when the view needs more than max_extent_m the map then gives up points
        # of the view, never the cell the agent stands on (the same growth as one call otherwise).
        grew_to_camera = self._ensure_covers(cam_i, cam_i, cam_j, cam_j)
        grew = self._ensure_covers(lo_i, hi_i, lo_j, hi_j) or grew_to_camera
        X, Z = self.shape
        li, lj = gi - self._offset[0], gj - self._offset[1]
        i0, i1 = max(lo_i - self._offset[0], 0), min(hi_i - self._offset[0] + 1, X)
        j0, j1 = max(lo_j - self._offset[1], 0), min(hi_j - self._offset[1] + 1, Z)
        if (i1 - i0, j1 - j0) != (hi_i - lo_i + 1, hi_j - lo_j + 1):  # the map hit max_extent_m
            inside = (li >= i0) & (li < i1) & (lj >= j0) & (lj < j1)
            li, lj, ys, codes = li[inside], lj[inside], ys[inside], codes[inside]

        box = (i0, i1, j0, j1)
        carved = 0
        if i0 < i1 and j0 < j1:  # else the whole view lies beyond max_extent_m
            carved = self._carve(carve_depth, pose, box, stride)
            self._probe_floor(depth * usable, class_ids, pose, box, stride)
            self._write_hits(li, lj, ys, codes, box)
        self._mark_visited(pose)
        self.steps += 1
        self._changed()
        return UpdateStats(points=len(codes), carved=carved, grew=grew)

    def _project_box(
        self, pose: Pose, box: tuple[int, int, int, int], heights: np.ndarray, stride: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Project the points at ``heights`` (metres) above every cell centre of ``box`` into the image.

        Returns z-depth, block row and block column (pixel // stride, clipped into the image) and whether
        the point is in view, each [Xb, Zb, len(heights)]. Dense arithmetic, no boolean gathers (they cost
        more than the maths in numpy). The camera-frame coordinates follow ``geometry.camera_to_world``.
        """
        i0, i1, j0, j1 = box
        cam = self.camera
        W, H = cam.width, cam.height
        centre = camera_position(cam, pose)
        cell = self.config.cell_m
        dx = ((self._offset[0] + np.arange(i0, i1) + 0.5) * cell - centre[0]).astype(np.float32)  # [Xb]
        dz = ((self._offset[1] + np.arange(j0, j1) + 0.5) * cell - centre[2]).astype(np.float32)  # [Zb]
        dy = heights - np.float32(centre[1])  # [K]
        yaw, pitch = math.radians(pose.yaw), math.radians(pose.horizon)
        sy, cy, sp, cp = (
            np.float32(v) for v in (math.sin(yaw), math.cos(yaw), math.sin(pitch), math.cos(pitch))
        )
        f = np.float32(cam.focal_px)
        across = (cy * dx)[:, None] - (sy * dz)[None, :]  # [Xb, Zb] camera x
        ahead = (sy * dx)[:, None] + (cy * dz)[None, :]  # [Xb, Zb] horizontal distance along the view
        z_cam = (cp * ahead)[:, :, None] - sp * dy  # [Xb, Zb, K] z-depth
        y_cam = (-sp * ahead)[:, :, None] - cp * dy  # [Xb, Zb, K] camera y (down)
        scale = f / np.maximum(z_cam, np.float32(_NEAR_M))
        cols = (across * f)[:, :, None] * (scale / f) + np.float32(W / 2)
        rows = y_cam * scale + np.float32(H / 2)
        in_view = (z_cam > _NEAR_M) & (cols >= 0) & (cols < W) & (rows >= 0) & (rows < H)
        block_rows = np.clip(rows, 0, H - 1).astype(np.int32) // stride
        block_cols = np.clip(cols, 0, W - 1).astype(np.int32) // stride
        return z_cam, block_rows, block_cols, in_view

    def _carve(self, nearest: np.ndarray, pose: Pose, box: tuple[int, int, int, int], stride: int) -> int:
        """Set to empty the voxels of ``box`` whose test point lies in front of the surface seen through it.

        HLSM's observability test, run from the voxel side: a voxel is seen empty when the depth at the
        pixel of its test point (bottom-face middle) lies beyond that point. ``nearest`` holds the nearest
        trusted depth of each stride x stride block (0 = nothing trusted), so carving is conservative at
        object edges. The floor bin is never carved (nothing lies below the floor); ``_probe_floor``
        observes it.
        """
        i0, i1, j0, j1 = box
        z_cam, rows, cols, in_view = self._project_box(pose, box, self._tables.carve_heights, stride)
        surface = nearest.reshape(-1).take(rows * nearest.shape[1] + cols)
        seen = in_view & (z_cam + np.float32(self.config.carve_margin_m) < surface)
        sub = self._voxels[i0:i1, j0:j1, 1:]
        np.bitwise_and(sub, seen.view(np.uint8) - np.uint8(1), out=sub)  # seen -> 0, others kept
        return int(np.count_nonzero(seen))

    def _probe_floor(
        self,
        depth: np.ndarray,
        class_ids: np.ndarray,
        pose: Pose,
        box: tuple[int, int, int, int],
        stride: int,
    ) -> None:
        """Give the floor bin of every cell whose floor point is in plain view the class seen there.

        Pixels sample a far floor more sparsely than 5 cm cells (at 3.5 m, one 300 px row spans ~6 cm of
        floor), so hits alone leave stripes of "unexplored" floor; sampling from the cell side closes them.
        ``depth`` (0 = untrusted) and ``class_ids`` hold the block-centre pixels.
        """
        i0, i1, j0, j1 = box
        z_cam, rows, cols, in_view = self._project_box(pose, box, _FLOOR_HEIGHT, stride)
        rows, cols = np.minimum(rows, depth.shape[0] - 1), np.minimum(cols, depth.shape[1] - 1)
        pixel = (rows * depth.shape[1] + cols)[:, :, 0]
        surface = depth.reshape(-1).take(pixel)
        seen = (
            in_view[:, :, 0] & (surface > 0) & (np.abs(z_cam[:, :, 0] - surface) < self.config.floor_probe_m)
        )
        seen_class = self._tables.hit_code[class_ids.reshape(-1).take(pixel)].astype(np.uint8)  # low byte
        floor = self._voxels[i0:i1, j0:j1, 0]
        np.copyto(floor, seen_class, where=seen)

    def _write_hits(
        self,
        li: np.ndarray,
        lj: np.ndarray,
        ys: np.ndarray,
        codes: np.ndarray,
        box: tuple[int, int, int, int],
    ) -> None:
        """Each voxel holding points takes the highest-priority class among them (one byte per voxel)."""
        if not len(codes):
            return
        i0, i1, j0, j1 = box
        B = self.config.n_bins
        Zb = j1 - j0
        quanta = ys * np.float32(1 / HEIGHT_QUANTUM_M)  # [N] centimetres above the floor
        np.clip(quanta, 0, self._tables.top_quantum, out=quanta)
        bins = _lookup(quanta.astype(np.uint8), self._tables.height_bin)  # [N] uint8
        local = ((li - i0) * Zb + (lj - j0)) * B + bins  # [N] flat index into the box
        best = np.zeros((i1 - i0) * Zb * B, dtype=np.uint16)
        np.maximum.at(best, local, codes)
        hit = np.flatnonzero(best)
        classes = best[hit].astype(np.uint8)  # the low byte: the class
        a, rest = np.divmod(hit, Zb * B)
        c, b = np.divmod(rest, B)
        self._voxels[i0 + a, j0 + c, b] = classes
        for class_id in np.flatnonzero(np.bincount(classes, minlength=256)[1:UNKNOWN_SURFACE_ID]) + 1:
            self._last_seen[int(class_id)] = self.steps

    def _mark_visited(self, pose: Pose) -> None:
        """The cells under the agent's body are floor it stood on (known free, even if never in view)."""
        radius = self.config.visited_radius_m
        self._flags[self._disc(pose.x, pose.z, radius)] |= _VISITED_BIT

    def _disc(self, x: float, z: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """Local (i, j) indices of the cells whose centre lies within ``radius`` of (x, z), inside the map."""
        c = self.config.cell_m
        frame = self.frame
        i_lo, j_lo = frame.world_to_cell(x - radius, z - radius)
        i_hi, j_hi = frame.world_to_cell(x + radius, z + radius)
        ii, jj = np.meshgrid(np.arange(i_lo, i_hi + 1), np.arange(j_lo, j_hi + 1), indexing="ij")
        cx, cz = frame.origin_x + (ii + 0.5) * c, frame.origin_z + (jj + 0.5) * c
        keep = ((cx - x) ** 2 + (cz - z) ** 2 <= radius**2 + 1e-12) & (ii >= 0) & (jj >= 0)
        keep &= (ii < self.shape[0]) & (jj < self.shape[1])
        return ii[keep], jj[keep]

    def record_collision(self, pose: Pose, action: str, blocked_xz: np.ndarray | None = None) -> None:
        """Remember that ``action`` from ``pose`` was blocked (JARVIS Alg. 3's collision memory).

        ``blocked_xz`` (float [K, 2] world metres) names the blocked places; by default the strip
        ``collision_depth_m`` ahead along the move, ``collision_half_width_m`` to each side, is marked.
        """
        if blocked_xz is None:
            blocked_xz = self._strip_ahead(pose, action)
        ij = np.floor(np.asarray(blocked_xz, dtype=np.float64) / self.config.cell_m).astype(np.int64)
        li, lj = ij[:, 0] - self._offset[0], ij[:, 1] - self._offset[1]
        X, Z = self.shape
        keep = (li >= 0) & (li < X) & (lj >= 0) & (lj < Z)
        self._flags[li[keep], lj[keep]] |= _COLLISION_BIT
        self._collision_events = [*self._collision_events, CollisionEvent(pose, action, self.steps)][
            -_COLLISION_EVENTS_KEPT:
        ]
        self._changed()

    def _strip_ahead(self, pose: Pose, action: str) -> np.ndarray:
        """float [K, 2]: centres of the cells whose centre lies in the strip in front of a blocked move.

        Cells are picked by their centres, not by sampling the strip's edges: the agent stands on cell
        corners, so an edge point 0.15 m ahead lies on a cell boundary, and floating-point rounding put it
        in the nearer cell for moves toward +x or +z only. That cell is within the navigator's collision
        radius of the cell the agent stood on, so a blocked move toward +x/+z closed the node it was made
        from, and a row of them walled the agent into a corridor it had walked along.
        """
        moved = pose.apply_motion(action, True)
        dx, dz = moved.x - pose.x, moved.z - pose.z
        length = math.hypot(dx, dz)
        if length == 0:
            raise ValueError(f"action {action!r} does not move the agent; give blocked_xz explicitly")
        ux, uz = dx / length, dz / length
        near, far = self.config.collision_depth_m
        half = self.config.collision_half_width_m
        c = self.config.cell_m
        reach = math.hypot(far, half)
        i = np.arange(math.floor((pose.x - reach) / c), math.floor((pose.x + reach) / c) + 1)
        j = np.arange(math.floor((pose.z - reach) / c), math.floor((pose.z + reach) / c) + 1)
        cx, cz = np.meshgrid((i + 0.5) * c, (j + 0.5) * c, indexing="ij")
        along = (cx - pose.x) * ux + (cz - pose.z) * uz
        side = (cx - pose.x) * uz - (cz - pose.z) * ux
        tolerance = 1e-6
        keep = (along >= near - tolerance) & (along <= far + tolerance) & (np.abs(side) <= half + tolerance)
        return np.stack([cx[keep], cz[keep]], axis=1)

    @property
    def collision_events(self) -> tuple[CollisionEvent, ...]:
        return tuple(self._collision_events)

    # ----- growth ---------------------------------------------------------------------------------------
    def cover(self, x: float, z: float, margin_m: float = 0.5) -> bool:
        """Grow (if needed) so the world point (x, z) and ``margin_m`` around it lie in the map: a place the
        agent was told to go to (a TATC commander's stand hint) must be plannable before it was seen."""
        cell, margin = self.config.cell_m, self.config.cells(margin_m)
        i, j = math.floor(x / cell), math.floor(z / cell)
        return self._ensure_covers(i - margin, i + margin, j - margin, j + margin)

    def can_hold(self, x: float, z: float) -> bool:
        """Whether the world point (x, z) lies in the map or where it can still grow to.

        The map never drops what it has and a side is at most ``max_extent_m``, so along each axis a cell
        fits while the span from the far edge of the current content to it stays within that limit
        (``_grown_range``). A pose beyond that cannot be mapped, planned from or clicked from: the step
        must be refused before anything changes (the navigator would fail after the map had grown).
        """
        if not (math.isfinite(x) and math.isfinite(z)):
            return False
        limit = self.config.cells(self.config.max_extent_m)
        cell = self.config.cell_m
        for value, offset, size in zip((x, z), self._offset, self.shape, strict=True):
            index = math.floor(value / cell)
            if not offset + size - limit <= index < offset + limit:
                return False
        return True

    def check_pose(self, pose: Pose) -> None:
        """ValueError naming the pose and the reachable extent when ``can_hold`` refuses it."""
        if self.can_hold(pose.x, pose.z):
            return
        frame = self.frame
        X, Z = self.shape
        span = self.config.max_extent_m
        x_lo, z_lo = frame.origin_x + X * frame.cell_m - span, frame.origin_z + Z * frame.cell_m - span
        x_hi, z_hi = frame.origin_x + span, frame.origin_z + span
        raise ValueError(
            f"({pose.x:.3f}, {pose.z:.3f}) lies outside what this session's map can hold: x in "
            f"[{x_lo:.2f}, {x_hi:.2f}), z in [{z_lo:.2f}, {z_hi:.2f}) metres (a map spans at most "
            f"{span:g} m a side and keeps what it has seen)"
        )

    def _ensure_covers(self, lo_i: int, hi_i: int, lo_j: int, hi_j: int) -> bool:
        """Grow in ``grow_step_m`` steps so global cells [lo, hi] fit, up to ``max_extent_m`` a side.

        The old content keeps its world position (offsets are whole cells). Past the maximum the map keeps
        everything it has and grows toward the needed side as far as allowed; points beyond are dropped.
        """
        cfg = self.config
        step, limit = cfg.cells(cfg.grow_step_m), cfg.cells(cfg.max_extent_m)
        X, Z = self.shape
        new_i = _grown_range(self._offset[0], X, lo_i, hi_i, step, limit)
        new_j = _grown_range(self._offset[1], Z, lo_j, hi_j, step, limit)
        if new_i == (self._offset[0], X) and new_j == (self._offset[1], Z):
            return False
        (oi, nx), (oj, nz) = new_i, new_j
        si, sj = self._offset[0] - oi, self._offset[1] - oj
        voxels = _voxel_grid(nx, nz, cfg.n_bins)
        voxels[si : si + X, sj : sj + Z] = self._voxels
        flags = np.zeros((nx, nz), dtype=np.uint8)
        flags[si : si + X, sj : sj + Z] = self._flags
        self._voxels, self._flags, self._offset = voxels, flags, (oi, oj)
        self._changed()
        return True

    # ----- 2D views -------------------------------------------------------------------------------------
    def presence(self, object_type: str | int) -> np.ndarray:
        """bool [X, Z]: cells with a voxel of this type (a canonical type name or a class id); read-only,
        computed once per map update (a step asks for a type several times)."""
        class_id = object_type if isinstance(object_type, int) else self.classes.id_of(object_type)
        return self._view(f"presence:{class_id}", lambda: (self._by_bin() == class_id).any(axis=0))

    def obstacles(self) -> np.ndarray:
        """bool [X, Z]: something other than floor occupies the obstacle band (HLSM A.6.1's OBSTACLE)."""
        return self._view("obstacles", self._compute_obstacles)

    def _compute_obstacles(self) -> np.ndarray:
        band = self._by_bin()[self.config.obstacle_bins]  # [band bins, X, Z], contiguous
        blocked = _lookup(band.reshape(-1), self._tables.blocks.view(np.uint8))
        return blocked.reshape(band.shape).max(axis=0).view(bool)

    def explored(self) -> np.ndarray:
        """bool [X, Z]: the column's ground is known: its floor-level voxel was hit, or something solid is.

        Deliberately stricter than "any voxel observed": over a table the camera sees empty air behind it
        but not the floor, and a frontier explorer must still want to look there (HLSM's ground set also
        requires a seen FLOOR).
        """
        return self._view("explored", lambda: (self._by_bin()[0] != UNOBSERVED_ID) | self.obstacles())

    def free(self) -> np.ndarray:
        """bool [X, Z]: known ground without obstacle or remembered collision (where the agent may stand)."""
        return self._view(
            "free", lambda: (self.explored() | self.visited()) & ~self.obstacles() & ~self.collisions()
        )

    def visited(self) -> np.ndarray:
        """bool [X, Z]: cells under the agent's body at some step."""
        return (self._flags & _VISITED_BIT) > 0

    def collisions(self) -> np.ndarray:
        """bool [X, Z]: cells where a move was blocked."""
        return (self._flags & _COLLISION_BIT) > 0

    def types_present(self) -> dict[str, int]:
        """Type -> number of voxels it holds, for every type in the map (the picture's legend)."""
        counts = np.bincount(self._by_bin().ravel(), minlength=256)
        return {
            self.classes.type_of(class_id): int(counts[class_id])
            for class_id in range(1, len(self.classes) + 1)
            if counts[class_id]
        }

    @property
    def last_seen(self) -> Mapping[str, int]:
        """Type -> the step (0-based update count) it was last in view."""
        return {self.classes.type_of(c): step for c, step in self._last_seen.items()}

    def _by_bin(self) -> np.ndarray:
        """uint8 [B, X, Z]: the voxels as they lie in memory, one height bin after another (no copy)."""
        return self._voxels.transpose(2, 0, 1)

    def _changed(self) -> None:
        """Drop what was derived from the state before a change."""
        self._views.clear()
        self._encoded = None

    def _view(self, name: str, compute: Callable[[], np.ndarray]) -> np.ndarray:
        view = self._views.get(name)
        if view is None:
            view = compute()
            view.flags.writeable = False
            self._views[name] = view
        return view

    def copy(self) -> SemanticMap:
        """An independent copy (the arrays copied in their memory layout: 0.02 ms, where a row-major copy of
        the bin-major voxel grid took 0.3-0.6): what the service's readers draw from while the session steps
        on (``app.live_view``)."""
        clone = copy.copy(self)
        clone._voxels, clone._flags = self._voxels.copy(order="K"), self._flags.copy()
        clone._last_seen, clone._views = dict(self._last_seen), dict(self._views)
        clone._collision_events = list(self._collision_events)
        return clone

    # ----- serialisation --------------------------------------------------------------------------------
    def to_bytes(self) -> bytes:
        """Compact snapshot: a JSON header and the zlib-compressed arrays (unobserved runs compress away).
        Kept until the map changes: a step's session snapshot and its published view both take it."""
        if self._encoded is None:
            self._encoded = self._encode()
        return self._encoded

    def _encode(self) -> bytes:
        header = {
            "config": asdict(self.config),
            "camera": asdict(self.camera),
            "classes": _class_fingerprint(self.classes),
            "offset": list(self._offset),
            "shape": list(self._voxels.shape),
            "steps": self.steps,
            "last_seen": sorted(self._last_seen.items()),
            "collisions": [
                {"pose": asdict(e.pose), "action": e.action, "step": e.step} for e in self._collision_events
            ],
            "layout": VOXEL_LAYOUT,
        }
        head = json.dumps(header, separators=(",", ":")).encode()
        voxels = self._voxels.transpose(2, 0, 1).tobytes()  # the grid's own memory order: no transposing copy
        body = zlib.compress(voxels + self._flags.tobytes(), level=MAP_ZLIB_LEVEL)
        return _MAGIC + struct.pack("<I", len(head)) + head + body

    @classmethod
    def from_bytes(cls, data: bytes, classes: ClassIndex | None = None) -> SemanticMap:
        """The map ``to_bytes`` wrote; ValueError if it is not one or the class table changed since."""
        if not data.startswith(_MAGIC):
            raise ValueError("not a semantic map snapshot (bad magic)")
        (head_len,) = struct.unpack("<I", data[4:8])
        header = json.loads(data[8 : 8 + head_len])
        classes = classes or load_class_index()
        if header["classes"] != _class_fingerprint(classes):
            raise ValueError("snapshot was written with a different class table (ontology changed)")
        config = _config_from_dict(header["config"])
        semantic_map = cls(Camera(**header["camera"]), Pose(0.0, 0.0), config, classes)
        X, Z, B = header["shape"]
        raw = zlib.decompress(data[8 + head_len :])
        assert len(raw) == X * Z * B + X * Z, f"snapshot body has {len(raw)} bytes, header says {X}x{Z}x{B}"
        semantic_map._voxels = _voxel_grid(X, Z, B)
        voxels = np.frombuffer(raw[: X * Z * B], dtype=np.uint8)
        if header.get("layout") == VOXEL_LAYOUT:
            semantic_map._voxels[...] = voxels.reshape(B, X, Z).transpose(1, 2, 0)
        else:  # written before the layout was recorded: row-major [X, Z, B]
            semantic_map._voxels[...] = voxels.reshape(X, Z, B)
        semantic_map._flags = np.frombuffer(raw[X * Z * B :], dtype=np.uint8).reshape(X, Z).copy()
        semantic_map._offset = (header["offset"][0], header["offset"][1])
        semantic_map.steps = header["steps"]
        semantic_map._last_seen = {int(c): int(s) for c, s in header["last_seen"]}
        semantic_map._collision_events = [
            CollisionEvent(Pose(**e["pose"]), e["action"], e["step"]) for e in header["collisions"]
        ]
        return semantic_map


def _lookup(values: np.ndarray, table: np.ndarray) -> np.ndarray:
    """table[values] for uint8 values [N] and a [256] table, as a flat array: cv2.LUT reads it several
    times faster than numpy's fancy indexing (which the map's hot loops would otherwise spend on)."""
    if not values.size:
        return np.zeros(0, dtype=table.dtype)
    return cv2.LUT(values.reshape(-1, 1), table).reshape(-1)


@dataclass(frozen=True, eq=False)
class _Tables:
    """Lookup tables derived once per (config, classes)."""

    hit_code: np.ndarray  # uint16 [256]: class id -> priority << 8 | stored class (0 -> unknown surface)
    blocks: np.ndarray  # bool [256]: voxel value -> occupies the obstacle band
    height_bin: np.ndarray  # uint8 [256]: centimetre index -> height bin (indices past the top unused)
    top_quantum: int  # the highest centimetre index with its own entry (higher heights are clipped to it)
    carve_heights: np.ndarray  # float32 [B-1]: heights whose visibility carves bins 1..B-1


@functools.lru_cache(maxsize=8)
def _tables(config: MapConfig, classes: ClassIndex) -> _Tables:
    hit_code = (classes.priority.astype(np.uint16) << 8) | np.arange(256, dtype=np.uint16)
    hit_code[0] = UNKNOWN_SURFACE_ID  # priority 0: any known class in the same voxel wins
    blocks = ~classes.walkable.copy()
    blocks[[0, UNOBSERVED_ID]] = False
    quanta = round(config.height_edges_m[-1] / HEIGHT_QUANTUM_M) + 1
    centres = (np.arange(quanta + 1) + 0.5) * HEIGHT_QUANTUM_M
    assert quanta < 256, "MapConfig keeps height_edges_m under MAX_TOP_EDGE_M"
    height_bin = np.zeros(256, dtype=np.uint8)
    height_bin[: quanta + 1] = np.searchsorted(np.asarray(config.height_edges_m), centres, side="right")
    carve_heights = np.asarray(config.bin_bottoms_m(), dtype=np.float32)
    for table in (hit_code, blocks, height_bin, carve_heights):
        table.flags.writeable = False
    return _Tables(hit_code, blocks, height_bin, quanta, carve_heights)


def _voxel_grid(X: int, Z: int, B: int) -> np.ndarray:
    """uint8 [X, Z, B] of unobserved voxels, laid out one height bin after another ([B, X, Z] in memory).

    The questions a step asks of whole columns (is this type anywhere above the cell? does anything block
    the obstacle band?) then read contiguous slabs, 30 times faster than reducing the short last axis of an
    [X, Z, B] array; a step asks them for several types. Indexing stays [x, z, bin] everywhere.
    """
    return np.full((B, X, Z), UNOBSERVED_ID, dtype=np.uint8).transpose(1, 2, 0)


def _grown_range(offset: int, size: int, lo: int, hi: int, step: int, limit: int) -> tuple[int, int]:
    """(new offset, new size) of one axis covering [lo, hi] in whole ``step``s, at most ``limit`` cells."""
    new_lo = offset - step * math.ceil(max(offset - lo, 0) / step)
    new_hi = offset + size + step * math.ceil(max(hi + 1 - (offset + size), 0) / step)
    if new_hi - new_lo > limit:
        new_lo = max(new_lo, offset + size - limit)
        new_hi = min(new_hi, new_lo + limit)
    return new_lo, new_hi - new_lo


def _class_fingerprint(classes: ClassIndex) -> str:
    return hashlib.sha1("\n".join(classes.types).encode()).hexdigest()[:16]


def _config_from_dict(data: dict[str, Any]) -> MapConfig:
    tuples = {k: tuple(v) for k, v in data.items() if isinstance(v, list)}
    return MapConfig(**{**data, **tuples})
