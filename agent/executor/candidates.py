"""Where the target may be hidden: the containers and open receptacles that may hold it, in the order to
look.

Closed containers come from two sources: the instances seen so far (``sightings``: one per cabinet door,
with a point on its face) and the map's container cells cut into parts (one cabinet of a row, upper or
lower), for containers never seen as instances. Open receptacles (tables, counters, shelves) are looked at
from near, part by part: small things show only from near.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from agent.executor.config import SearchConfig
from agent.executor.mapview import MapCluster, SessionMapView
from agent.executor.state import Box, Point, Sighting, in_box
from symbolic.ontology import Ontology


@dataclass(frozen=True)
class ContainerCandidate:
    """One part of a mapped container cluster (one cabinet of a row, upper or lower), or one sighted
    container instance, that may hold the target."""

    object_type: str
    target: Point  # world (x, y, z): the part's centre at its band's middle height
    top_low_m: float  # metres: the lowest the part's top can be
    distance_m: float  # metres from the agent, horizontally
    instance_id: int | None = None  # the sighted instance (``sightings``); None for a map part


def container_types(ontology: Ontology, target_type: str) -> tuple[str, ...]:
    """Enclosing receptacle types (Fridge, Cabinet, Drawer, Microwave, ...) that may hold the target,
    directly or in a bowl or pot inside (``Ontology.may_hold``)."""
    if target_type not in ontology or not ontology.get(target_type).pickupable:
        return ()
    return tuple(sorted(c for c in ontology.enclosing if ontology.may_hold(c, target_type)))


def surface_types(ontology: Ontology, target_type: str) -> tuple[str, ...]:
    """Receptacles in the open (tables, counters, shelves, sofas...) that accept the target."""
    if target_type not in ontology or not ontology.get(target_type).pickupable:
        return ()
    return tuple(r for r in ontology.receptacles_for(target_type) if r not in ontology.enclosing)


def searched_box(point: Point, config: SearchConfig) -> Box:
    """The region a looked-into container part rules out when its own extent is unknown."""
    r, h = config.checked_radius_m, config.band_gap_m
    return (point[0] - r, point[1] - h, point[2] - r), (point[0] + r, point[1] + h, point[2] + r)


def was_searched(point: Point, checked: list[Box], margin_m: float = 0.1) -> bool:
    """Whether a container part lies in a container already looked into (its box, with a margin)."""
    return any(in_box(point, box, margin_m) for box in checked)


def container_parts(
    view: SessionMapView,
    cluster: MapCluster,
    object_type: str,
    config: SearchConfig,
    tile_m: float | None = None,
) -> list[tuple[Point, float]]:
    """(centre, lowest top) of each part of a receptacle cluster: ``tile_m`` (default ``part_m``) tiles of
    its cells, each split into the height bands it occupies (a wall cabinet above a base cabinet are two
    containers)."""
    class_id = view.map.classes.id_of(object_type)
    lows, highs = view.bin_edges()  # [B] each
    holds = view.map.voxels[cluster.ii, cluster.jj] == class_id  # [N, B]
    side = tile_m or config.part_m
    column = np.floor(cluster.xs / side).astype(np.int64)  # [N] tile index along x
    row = np.floor(cluster.zs / side).astype(np.int64)  # [N] along z
    keys = (column - column.min()) * (int(row.max() - row.min()) + 1) + (row - row.min())  # [N] tile ids
    _, tile, counts = np.unique(keys, return_inverse=True, return_counts=True)  # [N] tile of each cell, [T]
    xs, zs = np.bincount(tile, cluster.xs) / counts, np.bincount(tile, cluster.zs) / counts  # [T] centroids
    cell, bin_ = np.nonzero(holds)
    tile_holds = np.zeros((len(counts), holds.shape[1]), dtype=bool)  # [T, B]
    tile_holds[tile[cell], bin_] = True
    parts = []
    for t in np.flatnonzero(counts >= config.min_part_cells):
        x, z = float(xs[t]), float(zs[t])
        bins = np.flatnonzero(tile_holds[t])
        for band in (bins[lows[bins] < config.upper_from_m], bins[lows[bins] >= config.upper_from_m]):
            if len(band):
                centre = float((lows[band] + highs[band]).mean() / 2)
                parts.append(((x, centre, z), float(lows[band.max()])))
    return parts


def _mapped_candidates(
    view: SessionMapView, kinds: Sequence[str], checked: list[Box], config: SearchConfig, tile_m: float
) -> list[ContainerCandidate]:
    """Parts of the mapped receptacles of ``kinds`` not looked into (or at) yet, in map order."""
    found = []
    pose = view.pose
    for object_type in kinds:
        for cluster in view.clusters(object_type):
            for point, top_low in container_parts(view, cluster, object_type, config, tile_m):
                if not was_searched(point, checked):
                    distance = math.hypot(point[0] - pose.x, point[2] - pose.z)
                    found.append(ContainerCandidate(object_type, point, top_low, distance))
    return found


def container_candidates(
    view: SessionMapView, ontology: Ontology, target_type: str, checked: list[Box], config: SearchConfig
) -> list[ContainerCandidate]:
    """Mapped container parts that may hold the target and were not looked into yet (``opening_order``
    ranks them with the sighted instances)."""
    kinds = container_types(ontology, target_type)
    return _mapped_candidates(view, kinds, checked, config, config.part_m)


def surface_candidates(
    view: SessionMapView, ontology: Ontology, target_type: str, looked: list[Box], config: SearchConfig
) -> list[ContainerCandidate]:
    """Parts of mapped open receptacles that may hold the target and were not looked at from near by yet,
    nearest first: small things (a salt shaker on a high shelf, a card on a table) show only from near."""
    kinds = surface_types(ontology, target_type)
    found = _mapped_candidates(view, kinds, looked, config, config.surface_part_m)
    return sorted(found, key=lambda c: c.distance_m)


def sighted_candidates(
    view: SessionMapView, ontology: Ontology, target_type: str, seen: list[Sighting]
) -> list[ContainerCandidate]:
    """Sighted container instances that may hold the target and were not opened for it yet."""
    kinds = container_types(ontology, target_type)
    pose = view.pose
    return [
        ContainerCandidate(
            s.object_type,
            s.point,
            s.point[1],
            math.hypot(s.point[0] - pose.x, s.point[2] - pose.z),
            s.instance_id,
        )
        for s in seen
        if s.object_type in kinds and target_type not in s.searched_for
    ]


def unsighted(
    parts: list[ContainerCandidate], seen: list[Sighting], config: SearchConfig
) -> list[ContainerCandidate]:
    """The map parts that are no sighted instance's (those are opened, or were, through the sighting)."""

    def sighted(part: ContainerCandidate) -> bool:
        x, y, z = part.target
        return any(
            s.object_type == part.object_type
            and math.hypot(s.point[0] - x, s.point[2] - z) <= config.sighted_part_m
            and abs(s.point[1] - y) <= config.sighted_band_m
            for s in seen
        )

    return [p for p in parts if not sighted(p)]


def opening_order(
    candidates: list[ContainerCandidate],
    prefer: str | None,
    config: SearchConfig,
    unseen_at: Sequence[tuple[float, float]] = (),
) -> list[ContainerCandidate]:
    """Containers within ``container_depth_m`` of a spot where X was mapped and then not seen
    (``unseen_at``, world (x, z)) first: it was seen inside and the door has shut since. Then the plan's
    hinted type, then nearest first, map parts counted ``part_penalty_m`` farther."""

    def key(c: ContainerCandidate) -> tuple[bool, bool, float]:
        depth = config.container_depth_m
        holds = any(math.hypot(c.target[0] - x, c.target[2] - z) <= depth for x, z in unseen_at)
        far = c.distance_m + (config.part_penalty_m if c.instance_id is None else 0.0)
        return not holds, c.object_type != prefer, far

    return sorted(candidates, key=key)
