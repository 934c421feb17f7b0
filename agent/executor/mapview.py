"""The agent's map and current frame seen through the queries of JARVIS's action-level predicates.

``symbolic.predicates.MapView`` is the interface of Table 5's right column (Observe, Near, Move, Target,
Interactive, Ignore); this module implements it over the session's ``SemanticMap``, the current percept and
the executor's memory of ignored detections and look-arounds, and caches every per-step computation
(pixel distances, the visible instances of a type, the standable floor, the map clusters of a type), so
the executor can ask freely within one step.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np

from agent.classes import UNOBSERVED_ID
from agent.executor.clicks import (
    ClickConfig,
    ClickFrame,
    VisibleInstance,
    pixel_distances,
    usable_pixels,
    visible_instances,
)
from agent.geometry import Camera, Pose, pixel_axis_distances
from agent.mapping import SemanticMap
from agent.navigation.base import NavGrids, body_fits
from agent.perception.base import Percept
from symbolic.predicates import Cell
from symbolic.thor import AGENT_RADIUS_M


@dataclass(frozen=True)
class IgnoredSpot:
    """A place where a type was ruled out (Table 5's Ignore): a false detection or an instance given up on."""

    object_type: str
    x: float  # metres, world
    z: float  # metres
    radius_m: float  # metres around (x, z)
    reason: str
    subgoal_index: int | None  # the subgoal it applies to; None for the whole episode
    until_seen: bool = False
    """Ruled out for not being seen there (Ignore after look-arounds, ``FalseDetections.not_seen_from_here``),
    so lifted once an instance of its type shows within reach inside it under true segmentation
    (``FalseDetections.lift_in_sight``). A false detection ruled out after a failed action
    (``FalseDetections.rule_out``) stays ruled out: it would show again."""

    def covers(self, x: float, z: float) -> bool:
        return math.hypot(x - self.x, z - self.z) <= self.radius_m


WorldBox = tuple[tuple[float, float, float], tuple[float, float, float]]
"""World (min corner, max corner), metres."""


@dataclass(frozen=True, eq=False)
class MapCluster:
    """One connected region of a type's map cells: a candidate instance to walk to (adjacent instances of
    one type, such as a row of cabinets, share a cluster)."""

    shape: tuple[int, int]  # the map's (X, Z)
    ii: np.ndarray  # int [N] map indices of its cells along x
    jj: np.ndarray  # int [N] along z
    xs: np.ndarray  # float [N] world x of its cell centres, metres
    zs: np.ndarray  # float [N] world z
    x: float  # metres, world centroid
    z: float
    nearest_m: float  # metres from the agent to its nearest cell
    top_m: float  # metres, upper edge of the highest height bin holding the type
    top_low_m: float  # metres, lower edge of that bin: the lowest its top can be (reach is judged on it)

    @functools.cached_property
    def cells(self) -> np.ndarray:
        """bool [X, Z]: its cells as a map layer (made when asked: most clusters are only ranked)."""
        cells = np.zeros(self.shape, dtype=bool)
        cells[self.ii, self.jj] = True
        return cells

    @property
    def aim_m(self) -> float:
        """Metres: the height to point the camera at (the middle of the highest bin holding the type)."""
        return (self.top_m + self.top_low_m) / 2

    def distance_to(self, x: float, z: float) -> float:
        """Metres from a world point to the cluster's nearest cell centre."""
        return float(np.sqrt((self.xs - x) ** 2 + (self.zs - z) ** 2).min())

    def outside(self, box: WorldBox, margin_m: float = 0.1) -> MapCluster | None:
        """The part of the cluster outside a world box's x-z rectangle (a full counter left out), or None."""
        (x0, _, z0), (x1, _, z1) = box
        inside = (self.xs >= x0 - margin_m) & (self.xs <= x1 + margin_m)
        inside &= (self.zs >= z0 - margin_m) & (self.zs <= z1 + margin_m)
        if inside.all():
            return None
        return self if not inside.any() else self._part(~inside)

    def within(self, box: WorldBox, margin_m: float = 0.1) -> MapCluster | None:
        """The part of the cluster inside a world box (a container's extent), or None: cells within its
        x-z rectangle, and the cluster's lowest top no higher than the box's top (the mug on the counter
        above a cabinet is not in the cabinet)."""
        (x0, y0, z0), (x1, _, z1) = box[0], box[1]
        inside = (self.xs >= x0 - margin_m) & (self.xs <= x1 + margin_m)
        inside &= (self.zs >= z0 - margin_m) & (self.zs <= z1 + margin_m)
        if not inside.any() or self.top_low_m > box[1][1] + margin_m or self.top_m < y0 - margin_m:
            return None
        return self if inside.all() else self._part(inside)

    def around(self, x: float, z: float, radius_m: float) -> MapCluster | None:
        """The part of the cluster within ``radius_m`` of a world point (one cabinet of a row), or None."""
        near = (self.xs - x) ** 2 + (self.zs - z) ** 2 <= radius_m**2
        if not near.any():
            return None
        if near.all():
            return self
        return self._part(near)

    def _part(self, near: np.ndarray) -> MapCluster:
        """The cluster cut down to the cells where ``near`` (bool [N]) holds."""
        xs, zs = self.xs[near], self.zs[near]
        nearest = self.nearest_m  # unchanged where the part holds the nearest cell; a bound otherwise
        return MapCluster(
            self.shape,
            self.ii[near],
            self.jj[near],
            xs,
            zs,
            float(xs.mean()),
            float(zs.mean()),
            nearest,
            self.top_m,
            self.top_low_m,
        )

    def parts(self, tile_m: float, min_cells: int) -> list[tuple[float, float]]:
        """World (x, z) centroids of the cluster's cells grouped in ``tile_m`` squares: one spot per part
        of a long cluster (each cabinet of a row), for visiting them one by one."""
        keys = np.floor(self.xs / tile_m).astype(np.int64) * 100_003 + np.floor(self.zs / tile_m).astype(
            np.int64
        )
        spots = []
        for key in np.unique(keys):
            member = keys == key
            if int(member.sum()) >= min_cells:
                spots.append((float(self.xs[member].mean()), float(self.zs[member].mean())))
        return spots or [(self.x, self.z)]


class SessionMapView:
    """``symbolic.predicates.MapView`` over one step's map, pose and percept (module docstring)."""

    def __init__(
        self,
        semantic_map: SemanticMap,
        percept: Percept,
        camera: Camera,
        pose: Pose,
        *,
        holding: bool,
        held_type: str | None = None,
        last_success: bool | None,
        ignored: list[IgnoredSpot],
        explore_attempts: Mapping[str, int],
        click_config: ClickConfig,
        stand_clearance_m: float = AGENT_RADIUS_M,
        hand_class_ids: np.ndarray | None = None,
    ) -> None:
        self.map = semantic_map
        self.percept = percept
        self.camera = camera
        self.pose = pose
        self.holding = holding
        self.hand_class_ids = hand_class_ids
        """uint8 [H, W]: the classes the network gave the hand's region, 0 elsewhere, when the session
        took that region out of ``percept`` (``without_hand``); None otherwise."""
        self.click_config = click_config
        self.stand_clearance_m = stand_clearance_m  # metres the body's centre keeps from obstacles
        self._last_success = last_success
        self._ignored = ignored  # the executor's list: spots it adds this step apply at once (``forget``)
        self._explore_attempts = dict(explore_attempts)
        self.distances = pixel_distances(percept.depth, camera)  # [H, W] metres from the camera
        far = percept.depth if percept.depth_far is None else percept.depth_far  # reach on the far end
        self.reach = pixel_axis_distances(far, camera, pose.horizon)  # [H, W] from the body's axis
        held = None
        if holding and held_type in semantic_map.classes.types:
            held = np.asarray(percept.class_ids == semantic_map.classes.id_of(held_type))
        self.usable = usable_pixels(self.distances, holding, click_config, held)  # [H, W]
        self.click_frame = ClickFrame(percept.instances, self.reach, self.usable, percept.depth, camera, pose)
        self._visible: dict[str, list[VisibleInstance]] = {}
        self._in_frame: dict[str, list[VisibleInstance]] = {}
        self._clusters: dict[str, list[MapCluster]] = {}
        self._near_parts: dict[tuple[str, float, float, float], MapCluster | None] = {}
        self._standable: np.ndarray | None = None
        self._reachable_region: np.ndarray | None = None
        self._bin_edges: tuple[np.ndarray, np.ndarray] | None = None

    # ----- the frame ---------------------------------------------------------------------------------
    def class_mask(self, object_type: str) -> np.ndarray:
        """bool [H, W]: this frame's pixels of the type."""
        return np.asarray(self.percept.class_ids == self.map.classes.id_of(object_type))

    def visible(self, object_type: str) -> list[VisibleInstance]:
        """The type's instances in this frame outside ignored spots, clickable and nearest first."""
        if object_type not in self._visible:
            self._visible[object_type] = [
                v
                for v in self.in_frame(object_type)
                if not self.is_ignored(object_type, v.point[0], v.point[2])
            ]
        return self._visible[object_type]

    def in_frame(self, object_type: str) -> list[VisibleInstance]:
        """The type's instances in this frame, ignored spots or not (``visible`` leaves those out)."""
        if object_type not in self._in_frame:
            self._in_frame[object_type] = visible_instances(
                self.class_mask(object_type), self.click_frame, self.click_config
            )
        return self._in_frame[object_type]

    def clickable(self, object_type: str) -> list[VisibleInstance]:
        """Visible instances with enough pixels within reach to click."""
        return [v for v in self.visible(object_type) if v.clickable]

    # ----- the map -----------------------------------------------------------------------------------
    def grids(self) -> NavGrids:
        """The layers the navigator reads."""
        return NavGrids(
            obstacles=self.map.obstacles(),
            explored=self.map.explored() | self.map.visited(),
            collisions=self.map.collisions(),
        )

    def standable(self) -> np.ndarray:
        """bool [X, Z]: cells the body fits on, clear of obstacles and remembered collisions."""
        if self._standable is None:
            blocked = self.map.obstacles() | self.map.collisions()
            self._standable = body_fits(blocked, self.map.config.cell_m, self.stand_clearance_m)
        return self._standable

    def presence(self, object_type: str) -> np.ndarray:
        """bool [X, Z]: the type's mapped cells outside ignored spots."""
        cells = self.map.presence(object_type)
        spots = [s for s in self._ignored if s.object_type == object_type]
        if spots and cells.any():
            frame = self.map.frame
            X, Z = cells.shape
            xs = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m  # [X]
            zs = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m  # [Z]
            cells = cells.copy()
            for spot in spots:
                cells &= (xs[:, None] - spot.x) ** 2 + (zs[None, :] - spot.z) ** 2 > spot.radius_m**2
        return cells

    def clusters(self, object_type: str) -> list[MapCluster]:
        """Connected regions (8-neighbours) of the type's mapped cells, nearest first (at equal distance, the
        one whose first cell comes first in raster order)."""
        if object_type in self._clusters:
            return self._clusters[object_type]
        cells = self.presence(object_type)
        found: list[MapCluster] = []
        rows, cols = np.flatnonzero(cells.any(axis=1)), np.flatnonzero(cells.any(axis=0))
        if len(rows):
            # Labelled within the cells' bounding box: a type covers a small part of the map.
            i0, j0 = int(rows[0]), int(cols[0])
            box = cells[i0 : int(rows[-1]) + 1, j0 : int(cols[-1]) + 1]
            count, labels = cv2.connectedComponents(box.view(np.uint8), connectivity=8)
            frame = self.map.frame
            ai, aj = frame.world_to_cell(self.pose.x, self.pose.z)
            class_id = self.map.classes.id_of(object_type)
            lows, tops = self.bin_edges()
            # Per-cell values for every cluster at once; per cluster only slices of them.
            box_ii, box_jj, starts = _label_cells(labels, count)
            ii, jj = box_ii + i0, box_jj + j0  # [N] every labelled cell, grouped by label
            xs = frame.origin_x + (ii + 0.5) * frame.cell_m  # [N]
            zs = frame.origin_z + (jj + 0.5) * frame.cell_m
            steps = np.sqrt((ii - ai) ** 2 + (jj - aj) ** 2)  # [N] cells from the agent
            holds = self.map.voxels[ii, jj] == class_id  # [N, B]
            highest = holds.shape[1] - 1 - np.argmax(holds[:, ::-1], axis=1)  # [N] its highest bin there
            top_bin = np.where(holds.any(axis=1), highest, -1)  # [N] -1: no bin of this cell holds it
            nearest = np.minimum.reduceat(steps, starts[:-1]) * frame.cell_m  # [C]
            top = np.maximum.reduceat(top_bin, starts[:-1])  # [C]
            for k, (a, b) in enumerate(zip(starts[:-1].tolist(), starts[1:].tolist(), strict=True)):
                cx, cz = xs[a:b], zs[a:b]
                found.append(
                    MapCluster(
                        cells.shape,
                        ii[a:b],
                        jj[a:b],
                        cx,
                        cz,
                        float(cx.mean()),
                        float(cz.mean()),
                        float(nearest[k]),
                        float(tops[top[k]]),
                        float(lows[top[k]]),
                    )
                )
        found.sort(key=lambda c: (c.nearest_m, int(c.ii[0]), int(c.jj[0])))
        self._clusters[object_type] = found
        return found

    def nearest_part(self, object_type: str, x: float, z: float, radius_m: float) -> MapCluster | None:
        """The type's mapped cells within ``radius_m`` of a world point, of the cluster whose such part
        lies nearest it (one container among its neighbours); None when none is that near. The same
        object for the same question all step, so what is derived from it can be cached too."""
        key = (object_type, x, z, radius_m)
        if key not in self._near_parts:
            parts = [p for c in self.clusters(object_type) if (p := c.around(x, z, radius_m)) is not None]
            self._near_parts[key] = min(parts, key=lambda c: math.hypot(c.x - x, c.z - z)) if parts else None
        return self._near_parts[key]

    def in_sight(
        self, cells: np.ndarray, target: tuple[float, float, float], object_type: str, samples: int = 24
    ) -> np.ndarray:
        """bool [X, Z]: the cells of ``cells`` from whose camera the straight line to ``target`` (world x, y,
        z) crosses no mapped surface of another type (an open fridge door, a shelf above an object).

        The line is sampled from 0.2 m after the eye to 0.12 m before the target; never-observed voxels
        count as clear, as navigation plans through unknown space too.
        """
        ii, jj = np.nonzero(cells)  # [N]
        if not len(ii):
            return cells.copy()
        cfg, frame = self.map.config, self.map.frame
        eye_x = frame.origin_x + (ii + 0.5) * frame.cell_m  # [N]
        eye_z = frame.origin_z + (jj + 0.5) * frame.cell_m
        eye_y = self.camera.height_m
        dx, dz = target[0] - eye_x, target[2] - eye_z  # [N]
        dy = np.full_like(dx, target[1] - eye_y)
        length = np.sqrt(dx**2 + dy**2 + dz**2)
        start, stop = 0.2 / np.maximum(length, 0.3), 1.0 - 0.12 / np.maximum(length, 0.3)  # [N] fractions
        t = start[:, None] + (stop - start)[:, None] * np.linspace(0.0, 1.0, samples)[None, :]  # [N, S]
        px, py, pz = (
            eye_x[:, None] + t * dx[:, None],
            eye_y + t * dy[:, None],
            eye_z[:, None] + t * dz[:, None],
        )
        gi = np.floor((px - frame.origin_x) / frame.cell_m).astype(np.int64)
        gj = np.floor((pz - frame.origin_z) / frame.cell_m).astype(np.int64)
        edges = np.asarray(cfg.height_edges_m)
        gb = np.searchsorted(edges, py, side="right")  # [N, S] height bins
        X, Z = self.map.shape
        inside = (gi >= 0) & (gi < X) & (gj >= 0) & (gj < Z)
        values = np.zeros(gi.shape, dtype=np.uint8)
        values[inside] = self.map.voxels[gi[inside], gj[inside], gb[inside]]
        target_id = self.map.classes.id_of(object_type)
        blocked = (values != 0) & (values != UNOBSERVED_ID) & (values != target_id)
        clear = ~blocked.any(axis=1)  # [N]
        result = np.zeros_like(cells)
        result[ii[clear], jj[clear]] = True
        return result

    def spot_cluster(self, point: tuple[float, float, float], radius_m: float) -> MapCluster:
        """A pseudo-cluster: the cells within ``radius_m`` of a world point at its height, for walking to a
        remembered place where nothing of the type is mapped (an object put inside a toaster). With no cell
        that near, the map's cell nearest to the point: learned depth can place a remembered spot beyond
        the map's edge."""
        frame = self.map.frame
        X, Z = self.map.shape
        xs_all = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m
        zs_all = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m
        cells = (xs_all[:, None] - point[0]) ** 2 + (zs_all[None, :] - point[2]) ** 2 <= radius_m**2
        if not cells.any():
            i, j = frame.world_to_cell(point[0], point[2])
            cells[min(max(i, 0), X - 1), min(max(j, 0), Z - 1)] = True
        ii, jj = np.nonzero(cells)
        xs, zs = xs_all[ii], zs_all[jj]
        i, j = frame.world_to_cell(self.pose.x, self.pose.z)
        nearest = float(np.sqrt((ii - i) ** 2 + (jj - j) ** 2).min()) * frame.cell_m
        return MapCluster(cells.shape, ii, jj, xs, zs, point[0], point[2], nearest, point[1] + 0.1, point[1])

    def bin_edges(self) -> tuple[np.ndarray, np.ndarray]:
        """float [B] lower and upper edges of each height bin, metres (the open ends get 0 m and +0.2 m);
        read-only, made once per view."""
        if self._bin_edges is None:
            edges = self.map.config.height_edges_m
            lows, highs = np.asarray([0.0, *edges]), np.asarray([*edges, edges[-1] + 0.2])
            lows.flags.writeable = highs.flags.writeable = False
            self._bin_edges = lows, highs
        return self._bin_edges

    def reachable_region(self) -> np.ndarray:
        """bool [X, Z]: standable or unexplored cells connected to the agent (what FMM may plan through)."""
        if self._reachable_region is None:
            passable = self.standable() | ~(self.map.explored() | self.map.visited())
            passable = passable & ~self.map.obstacles()
            _, labels = cv2.connectedComponents(passable.view(np.uint8), connectivity=4)
            i, j = self.map.world_to_cell(self.pose.x, self.pose.z)
            X, Z = passable.shape
            window = labels[max(0, i - 3) : min(X, i + 4), max(0, j - 3) : min(Z, j + 4)]
            ids = np.unique(window[window > 0])
            self._reachable_region = np.isin(labels, ids)
        return self._reachable_region

    def forget(self, object_type: str) -> None:
        """Drop what this step cached about a type (after a new ignored spot for it)."""
        self._visible.pop(object_type, None)
        self._clusters.pop(object_type, None)
        self._near_parts = {key: part for key, part in self._near_parts.items() if key[0] != object_type}

    def is_ignored(self, object_type: str, x: float, z: float) -> bool:
        """Whether a world spot is ruled out for the type (an ignored spot covers it)."""
        return any(s.object_type == object_type and s.covers(x, z) for s in self._ignored)

    # ----- MapView (symbolic.predicates) -------------------------------------------------------------
    def is_free(self, cell: Cell) -> bool:
        return bool(self.map.free()[cell])

    def observed(self, obj_type: str) -> bool:
        return bool(self.visible(obj_type))

    def in_map(self, obj_type: str) -> bool:
        return bool(self.clusters(obj_type))

    def distance_to(self, obj_type: str) -> float | None:
        clusters = self.clusters(obj_type)
        seen = [v.nearest_m for v in self.visible(obj_type)]
        candidates = [c.nearest_m for c in clusters] + seen
        return min(candidates) if candidates else None

    def path_exists(self, goal: Cell) -> bool:
        X, Z = self.map.shape
        return 0 <= goal[0] < X and 0 <= goal[1] < Z and bool(self.reachable_region()[goal])

    def goal_cell(self, obj_type: str) -> Cell | None:
        clusters = self.clusters(obj_type)
        if not clusters:
            return None
        cell = self.map.world_to_cell(clusters[0].x, clusters[0].z)
        region = self.reachable_region() & self.standable()
        near = np.argwhere(region)
        if len(near) == 0:
            return None
        best = int(np.argmin((near[:, 0] - cell[0]) ** 2 + (near[:, 1] - cell[1]) ** 2))
        return int(near[best, 0]), int(near[best, 1])

    def last_action_succeeded(self) -> bool:
        return self._last_success is not False

    def explore_attempts(self, obj_type: str) -> int:
        return self._explore_attempts.get(obj_type, 0)


def _label_cells(labels: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(ii, jj) of the cells of labels 1..count-1 of a connected-components image, grouped by label and in
    row-major order within a label (as ``np.nonzero(labels == label)`` gives them), and where each label's
    run starts ([count], the last entry the total): one pass over the image instead of one per label (a
    row of cabinets maps as dozens of components)."""
    ii, jj = np.nonzero(labels)
    of = labels[ii, jj]
    order = np.argsort(of, kind="stable")  # stable: row-major order kept within a label
    starts = np.searchsorted(of[order], np.arange(1, count + 1))
    return ii[order], jj[order], starts
