"""Container geometry: a container's body in the map, its extent, its front and the door that swings out.

The map knows where a fridge's voxels are, not which way it opens. Two cues tell: the side of it with the
most floor to stand on (a fridge or cabinet opens toward the room), and, once it was opened, the way its
door was seen to swing (the new cells of the map lie in front; the side they lie to is the hinge). From
the front the inside shows; from beyond the line of a swung door, the door hides it. The extent of the
container the plan opened (seen when clicking it, grown as the agent looks in) says which X is "in" it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agent.executor import sightings
from agent.executor.clicks import Click, pixel_points
from agent.executor.context import SideFloor, StepContext
from agent.executor.mapview import MapCluster
from agent.executor.state import Box, Memory, Pending, Point, Sighting

SIDE_DIRECTIONS: tuple[float, ...] = sightings.DIRECTIONS
"""The four sides of a container (degrees; 0 toward +z, 90 toward +x)."""

FrontRecord = tuple[float, float, float, float]
"""What opening a container taught (``Memory.fronts``): x, z (metres), the direction it opens toward
(degrees), and how far across the front the door swung out (metres, signed: the hinge side)."""

SLIDING_TYPES: frozenset[str] = frozenset({"Drawer"})
"""Containers that slide straight out (AI2-THOR's drawers): no door swings to one side of their front, so
what opening one teaches keeps the middle of the map's row (measured from the drawer's own middle, its
slide would read as a door to one side)."""


def joined(*given: Box | None) -> Box | None:
    """The smallest box holding all the boxes given (None ones left out); None when there are none."""
    boxes = [box for box in given if box is not None]
    if not boxes:
        return None
    low = [min(box[0][k] for box in boxes) for k in range(3)]
    high = [max(box[1][k] for box in boxes) for k in range(3)]
    return (low[0], low[1], low[2]), (high[0], high[1], high[2])


@dataclass(eq=False)
class ContainerFronts:
    """Bodies, extents, fronts and doors of containers (module docstring); owns ``Memory.fronts`` and
    ``Memory.opened_box``, and reads the container sightings' face votes."""

    ctx: StepContext
    memory: Memory
    containers: list[Sighting]

    # ----- bodies and extents ------------------------------------------------------------------------
    def body(self, kind: str, near: Point) -> MapCluster | None:
        """The mapped cells of the container of type ``kind`` around a point of it."""
        return self.ctx.view.nearest_part(kind, near[0], near[2], self.ctx.cfg.search.container_reach_m)

    def extent_of(self, instance_id: int) -> Box | None:
        """The world box of an instance's visible pixels in this frame (every 4th pixel is enough)."""
        ctx = self.ctx
        rows, cols = np.nonzero((ctx.view.percept.instances == instance_id) & ctx.view.usable)
        if len(rows) == 0:
            return None
        points = pixel_points(rows[::4], cols[::4], ctx.view.percept.depth, ctx.view.camera, ctx.pose)
        lo, hi = points.min(axis=0), points.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(lo[2])), (float(hi[0]), float(hi[1]), float(hi[2]))

    def footprint(self, kind: str, point: Point) -> tuple[float, float, int] | None:
        """The mapped centroid and cell count of the container of type ``kind`` around a clicked point."""
        cfg = self.ctx.cfg.search
        body = self.body(kind, point)
        reach = cfg.opened_part_m + cfg.footprint_margin_m
        part = body.around(point[0], point[2], reach) if body is not None else None
        return None if part is None else (part.x, part.z, len(part.xs))

    def container_box(self, kind: str, click: Click) -> Box | None:
        """The extent of a container about to be opened: its pixels in this frame, joined with its mapped
        cells near the click (a fridge at the edge of the view shows only a sliver)."""
        ctx, cfg = self.ctx, self.ctx.cfg.search
        boxes = []
        seen = self.extent_of(click.instance_id)
        if seen is not None:
            boxes.append(seen)
        body = self.body(kind, click.point)
        part = body.around(click.point[0], click.point[2], cfg.opened_part_m) if body is not None else None
        if part is not None:
            lo = (float(part.xs.min()), 0.0, float(part.zs.min()))
            boxes.append((lo, (float(part.xs.max()), part.top_m, float(part.zs.max()))))
        box = joined(*boxes)
        if box is None:
            return None
        low, high = list(box[0]), list(box[1])
        for k, here in ((0, ctx.pose.x), (2, ctx.pose.z)):  # the inside lies behind the face seen
            if here < low[k]:
                high[k] = max(high[k], low[k] + cfg.container_depth_m)
            elif here > high[k]:
                low[k] = min(low[k], high[k] - cfg.container_depth_m)
        return (low[0], low[1], low[2]), (high[0], high[1], high[2])

    def opened_box(self, kind: str, pending: Pending) -> Box | None:
        """After an Open: the box seen when clicking (``container_box``) joined with the opened instance's
        pixels now (with fresh ids, the instance under the click, if it is one)."""
        click = pending.click
        if click is None:
            return pending.box
        percept = self.ctx.view.percept
        instance_id = click.instance_id
        if not percept.persistent_ids:
            instance_id = int(percept.instances[click.row, click.col])
            if percept.instance_types.get(instance_id) != kind:
                return pending.box
        return joined(pending.box, self.extent_of(instance_id))

    def remember_opened(self, kind: str, pending: Pending) -> None:
        """After an Open: the opened container's box (``opened_box``) and its front (``learn_front``)."""
        box = self.opened_box(kind, pending)
        if box is not None:
            self.memory.opened_box[kind] = box
        self.learn_front(kind, pending)

    def grow_opened_box(self, kind: str, instance_id: int | None) -> None:
        """While looking into the container the plan opened: join its pixels in this frame to its box. A
        drawer clicked at the bottom edge of the view shows a sliver and, open, its far end at a level
        camera; looking down shows the rest, and what lies there is inside it."""
        box = self.memory.opened_box.get(kind)
        if box is None or instance_id is None or not self.ctx.view.percept.persistent_ids:
            return
        grown = joined(box, self.extent_of(instance_id))
        if grown is not None:
            self.memory.opened_box[kind] = grown

    # ----- sides and fronts --------------------------------------------------------------------------
    def side_floor(self, body: MapCluster) -> list[SideFloor]:
        """The four sides of a piece of furniture (90° sectors around its centre): (standable known cells
        ``side_floor_m`` from its centre, bool [X, Z] cells within ``front_half_angle_deg`` of that side's
        direction and as far, the direction in degrees); computed once a step for each body."""
        ctx = self.ctx
        if body in ctx.side_floors:
            return ctx.side_floors[body]
        view = ctx.view
        frame = view.map.frame
        near_m, far_m = ctx.cfg.search.side_floor_m
        X, Z = view.map.shape
        ci, cj = frame.world_to_cell(body.x, body.z)
        r = math.ceil(far_m / frame.cell_m) + 1
        i0, i1, j0, j1 = max(ci - r, 0), min(ci + r + 1, X), max(cj - r, 0), min(cj + r + 1, Z)
        window = (slice(i0, i1), slice(j0, j1))
        xs = frame.origin_x + (np.arange(i0, i1) + 0.5) * frame.cell_m  # [Xw]
        zs = frame.origin_z + (np.arange(j0, j1) + 0.5) * frame.cell_m  # [Zw]
        dx, dz = xs[:, None] - body.x, zs[None, :] - body.z  # [Xw, Zw] each
        distance = np.hypot(dx, dz)
        floor = view.standable()[window] & (view.map.explored() | view.map.visited())[window]
        ring = floor & (distance >= near_m) & (distance <= far_m)
        bearing = np.degrees(np.arctan2(dx, dz))  # [Xw, Zw]: 0 toward +z, 90 toward +x
        sides = []
        for centre in SIDE_DIRECTIONS:
            off = np.abs((bearing - centre + 180.0) % 360.0 - 180.0)
            cells = np.zeros((X, Z), dtype=bool)
            cells[window] = (off <= ctx.cfg.front_half_angle_deg) & (distance <= far_m)
            sides.append((int((ring & (off <= 45.0)).sum()), cells, centre))
        ctx.side_floors[body] = sides
        return sides

    def sides(self, body: MapCluster) -> list[SideFloor]:
        """The four sides of a piece of furniture (``side_floor``), its known front first (``known_front``),
        then most open floor first."""
        sides = self.side_floor(body)
        front = self.known_front(body, sides)
        return sorted(sides, key=lambda side: (side[2] != front, -side[0]))

    def front_record(self, body: MapCluster) -> FrontRecord | None:
        """What was learned when this container opened (``Memory.fronts``): the record nearest it."""
        same_m = self.ctx.cfg.search.front_same_m
        near = [f for f in self.memory.fronts if body.distance_to(f[0], f[1]) <= same_m]
        return min(near, key=lambda f: math.hypot(f[0] - body.x, f[1] - body.z), default=None)

    def known_front(self, body: MapCluster, sides: list[SideFloor] | None = None) -> float | None:
        """The direction this container was seen to open toward (``Memory.fronts``), if it was and there is
        floor to stand on that way (at least ``front_floor_share`` of the most open side's, ``side_floor``,
        passed as ``sides`` when at hand): a microwave's door swings sideways, so its swing can point at
        the wall beside it."""
        record = self.front_record(body)
        if record is None:
            return None
        front = record[2]
        floor_toward = {direction: count for count, _, direction in sides or self.side_floor(body)}
        most = max(floor_toward.values())
        share = self.ctx.cfg.search.front_floor_share
        return front if most == 0 or floor_toward.get(front, 0) >= share * most else None

    def front_cells(self, body: MapCluster) -> np.ndarray | None:
        """bool [X, Z]: cells on the side of a container that faces the room, or None when no side stands out.

        A fridge or cabinet opens toward open floor: the side with clearly the most floor (``sides``) is
        its front, and its inside shows from there rather than past a swung door from the side.
        """
        cfg = self.ctx.cfg
        sides = self.sides(body)
        (best, cells, direction), (second, _, _) = sides[0], sides[1]
        if direction == self.known_front(body, sides):
            return cells
        if best < cfg.front_min_cells or best < cfg.front_margin * second:
            return None
        return cells

    def facing(self, kind: str, face: Point, instance_id: int | None) -> float | None:
        """The axis direction (degrees) a container's face looks toward: the way its door was seen to
        swing (``known_front``), else the face of it seen most (``sightings.facing``); None for a container
        known only from the map. A fridge approached from beside it shows its side most."""
        body = self.body(kind, face)
        swung = self.known_front(body) if body is not None else None
        if swung is not None:
            return swung
        known = sightings.find(self.containers, kind, face, instance_id, self.ctx.cfg.search)
        return sightings.facing(known) if known is not None else None

    def swung_front(self, kind: str, point: Point) -> tuple[float, FrontRecord] | None:
        """The front of the container around ``point`` (``known_front``) and what was learned when it opened
        (``front_record``); None unless both are known."""
        body = self.body(kind, point)
        if body is None:
            return None
        front, record = self.known_front(body), self.front_record(body)
        return None if front is None or record is None else (front, record)

    def front_middle(self, kind: str, clicked: Point) -> Point:
        """The middle of the front face of the container opened at ``clicked`` (a point on its face or door
        edge), at its height: across the front, the middle of the instance opened, or of the map cells it
        covered before it opened (``Memory.fronts``; the map keeps its swung door's cells); ``clicked`` when
        the front is unknown."""
        swung = self.swung_front(kind, clicked)
        if swung is None:
            return clicked
        front, (x0, z0, _, _) = swung
        return (clicked[0], clicked[1], z0) if abs(front) == 90.0 else (x0, clicked[1], clicked[2])

    def door_clear(self, kind: str, point: Point) -> np.ndarray:
        """bool [X, Z]: the cells from which the swung door of the container around ``point`` does not hide
        its inside, all of them when no door was seen to swing to one side. The door stands out of the
        front at the hinge, so the inside shows only from the far side of the door's line."""
        ctx, cfg = self.ctx, self.ctx.cfg.search
        frame = ctx.view.map.frame
        clear = np.ones(ctx.view.map.shape, dtype=bool)
        swung = self.swung_front(kind, point)
        if swung is None:
            return clear
        front, (x0, z0, _, door) = swung
        if abs(door) < cfg.door_aside_m:
            return clear  # a drawer slides straight out: nothing stands to one side of its front
        across_x = abs(front) != 90.0  # a front toward ±z runs along x
        X, Z = clear.shape
        if across_x:
            across = frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m - (x0 + door)
            return np.broadcast_to((across * -np.sign(door) >= cfg.door_clearance_m)[:, None], (X, Z)).copy()
        across = frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m - (z0 + door)
        return np.broadcast_to((across * -np.sign(door) >= cfg.door_clearance_m)[None, :], (X, Z)).copy()

    def front_cone(self, cells: np.ndarray, face: Point, facing: float | None, min_m: float) -> np.ndarray:
        """The cells ``min_m`` or more from a face point and, when its facing (degrees, 0 toward +z, 90
        toward +x) is given, within ``front_cone_deg`` of it; kitchens are axis-aligned, so it snaps to an
        axis."""
        frame = self.ctx.view.map.frame
        X, Z = cells.shape
        dx = (frame.origin_x + (np.arange(X) + 0.5) * frame.cell_m - face[0])[:, None]  # [X, 1]
        dz = (frame.origin_z + (np.arange(Z) + 0.5) * frame.cell_m - face[2])[None, :]  # [1, Z]
        distance = np.hypot(dx, dz)  # [X, Z]
        kept = cells & (distance >= min_m)
        if facing is None:
            return kept
        axis = math.radians(90.0 * round(facing / 90.0))
        along = dx * math.sin(axis) + dz * math.cos(axis)
        cone = math.cos(math.radians(self.ctx.cfg.search.front_cone_deg))
        return kept & (along >= cone * distance)

    def learn_front(self, kind: str, pending: Pending) -> None:
        """After an Open: the door swung out in front, so the container's cells grew that way; remember
        the side (``Memory.fronts``) when they clearly did, with where across the front the door stands from
        the middle of the instance clicked (seen when clicking, ``Pending.box``; under true segmentation)."""
        ctx, cfg = self.ctx, self.ctx.cfg.search
        if pending.before is None or pending.click is None:
            return
        after = self.footprint(kind, pending.click.point)
        x0, z0, n0 = pending.before
        if after is None or after[2] < n0 + cfg.front_min_new_cells:
            return
        x1, z1, n1 = after
        # centroid of the new cells alone: (n1·c1 − n0·c0) / (n1 − n0)
        nx, nz = (n1 * x1 - n0 * x0) / (n1 - n0), (n1 * z1 - n0 * z0) / (n1 - n0)
        bearing = math.degrees(math.atan2(nx - x0, nz - z0))  # 0 toward +z, 90 toward +x
        side = SIDE_DIRECTIONS[round(bearing / 90.0) % 4]
        if pending.box is not None and kind not in SLIDING_TYPES and ctx.view.percept.persistent_ids:
            # across the front, the middle of the instance opened, not of the row the map merged it into
            # (true segmentation only, as is the second look past a door)
            (lo_x, _, lo_z), (hi_x, _, hi_z) = pending.box
            x0, z0 = (x0, (lo_z + hi_z) / 2.0) if abs(side) == 90.0 else ((lo_x + hi_x) / 2.0, z0)
        fronts = self.memory.fronts
        fronts[:] = [f for f in fronts if math.hypot(f[0] - x0, f[1] - z0) > cfg.front_same_m]
        door = nz - z0 if abs(side) == 90.0 else nx - x0  # across the front: where the door swung out
        fronts.append((x0, z0, side, door))
        ctx.events.append(f"the {kind} at ({x0:.2f}, {z0:.2f}) opens toward {side:g}°")
