"""Closed containers seen so far, one entry per instance: the container search's list of doors to try.

The map knows where cabinet voxels are, not where one cabinet ends and the next begins: a row of thirty
doors is one cluster, two drawers stacked 26 cm apart fall into the same height bins, and an opened door
adds cells in front of the row, so a search by map parts opens some doors twice and never reaches others
(a kettle behind a door seen a dozen times, a knife in the drawer above the one opened). Segmentation does
tell instances apart, so every instance of a container type seen in a frame is remembered here with a
world point on its face; the search opens those one by one and falls back to map parts only for
containers never seen as instances.

Oracle segmentation ids are stable within an episode; a learned segmenter's connected components are not,
so an id only identifies a sighting near where it was seen before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agent.executor.clicks import group_ids
from agent.executor.config import SearchConfig
from agent.executor.mapview import SessionMapView
from agent.executor.state import ContainerVisit, Point, Sighting
from agent.geometry import Camera, Pose, camera_position, camera_to_world, pixel_ray_slopes
from symbolic.ontology import Ontology

DIRECTIONS: tuple[float, ...] = (0.0, 90.0, 180.0, -90.0)
"""The four axis directions a face can look toward, degrees (0 toward +z, 90 toward +x)."""


def same_instance(
    sighting: Sighting, object_type: str, point: Point, instance_id: int | None, cfg: SearchConfig
) -> bool:
    """Whether an instance seen at ``point`` is the one ``sighting`` remembers."""
    if sighting.object_type != object_type:
        return False
    if math.dist(sighting.point, point) <= cfg.sighting_same_place_m:
        return True
    across = math.hypot(sighting.point[0] - point[0], sighting.point[2] - point[2])
    return instance_id == sighting.instance_id and across <= cfg.sighting_same_id_m


def find(
    sightings: list[Sighting], object_type: str, point: Point, instance_id: int | None, cfg: SearchConfig
) -> Sighting | None:
    """The remembered instance seen at ``point`` (the nearest when several qualify), or None."""
    matches = [s for s in sightings if same_instance(s, object_type, point, instance_id, cfg)]
    return min(matches, key=lambda s: math.dist(s.point, point)) if matches else None


@dataclass(frozen=True)
class Seen:
    """One container instance in this frame (``observe``)."""

    object_type: str
    instance_id: int
    pixels: int  # visible pixels, estimated from the samples
    point: Point  # world centroid of its visible samples
    votes: tuple[int, int, int, int]  # samples of its vertical faces looking toward each of DIRECTIONS


def observe(
    class_ids: np.ndarray,
    instances: np.ndarray,
    depth: np.ndarray,
    usable: np.ndarray,
    camera: Camera,
    pose: Pose,
    kinds: dict[int, str],
    cfg: SearchConfig,
) -> list[Seen]:
    """The instances of the container classes ``kinds`` (class id -> type) in a frame, from one
    back-projection of every ``cfg.sighting_stride_px``-th pixel in the box around them (it runs every step).

    Each instance's face votes come from surface normals of neighbouring samples (on one instance, no
    edge between them): a cabinet's front shows in most views, its side only from beside it, so the votes
    of all views tell the way it faces.
    """
    S = cfg.sighting_stride_px
    is_kind = np.zeros(256, dtype=bool)  # class id -> one of ``kinds`` (a table beats np.isin here)
    is_kind[list(kinds)] = True
    wanted = is_kind[class_ids[::S, ::S]] & usable[::S, ::S] & (instances[::S, ::S] != 0)
    rows_in, cols_in = np.nonzero(wanted)
    if len(rows_in) == 0:
        return []
    r0, r1 = int(rows_in.min()), min(int(rows_in.max()) + 2, wanted.shape[0])
    c0, c1 = int(cols_in.min()), min(int(cols_in.max()) + 2, wanted.shape[1])
    rows, cols = slice(r0 * S, r1 * S, S), slice(c0 * S, c1 * S, S)  # the samples' pixels: no gathers
    ids = instances[rows, cols]  # [h, w]
    ok = wanted[r0:r1, c0:c1]  # [h, w]
    px, py, pz = _sample_points(depth[rows, cols], camera, pose, rows, cols)
    found, inverse, counts = group_ids(ids[ok])
    sums = np.stack([np.bincount(inverse, weights=p[ok]) for p in (px, py, pz)], axis=1)  # [I, 3]
    classes = np.zeros(len(found), dtype=np.int64)
    classes[inverse] = class_ids[rows, cols][ok]

    # One [h, w] array per coordinate: reductions over a 3-long last axis cost more than the arithmetic.
    rx, ry, rz = px[:-1, 1:] - px[:-1, :-1], py[:-1, 1:] - py[:-1, :-1], pz[:-1, 1:] - pz[:-1, :-1]  # right
    dx, dy, dz = px[1:, :-1] - px[:-1, :-1], py[1:, :-1] - py[:-1, :-1], pz[1:, :-1] - pz[:-1, :-1]  # down
    nx, ny, nz = dy * rz - dz * ry, dz * rx - dx * rz, dx * ry - dy * rx  # down x right, [h-1, w-1]
    here = ids[:-1, :-1]
    valid = (
        ok[:-1, :-1]
        & ok[:-1, 1:]
        & ok[1:, :-1]
        & (ids[:-1, 1:] == here)
        & (ids[1:, :-1] == here)
        & (np.sqrt(rx * rx + ry * ry + rz * rz) <= cfg.sighting_edge_m)
        & (np.sqrt(dx * dx + dy * dy + dz * dz) <= cfg.sighting_edge_m)
    )
    length = np.sqrt(nx * nx + ny * ny + nz * nz)
    valid &= (length > 0) & (np.abs(ny) <= cfg.sighting_upright * length)
    eye_x, eye_y, eye_z = camera_position(camera, pose)
    toward = nx * (eye_x - px[:-1, :-1]) + ny * (eye_y - py[:-1, :-1]) + nz * (eye_z - pz[:-1, :-1])
    flip = np.where(toward < 0, -1.0, 1.0)  # [h-1, w-1]: face the camera
    bearing = np.degrees(np.arctan2(nx * flip, nz * flip))
    side = np.round(bearing / 90.0).astype(np.int64) % 4  # 0: 0°, 1: 90°, 2: 180°, 3: -90°
    index = np.searchsorted(found, here[valid])  # every valid sample's instance is in ``found``
    votes = np.bincount(index * 4 + side[valid], minlength=4 * len(found)).reshape(len(found), 4)

    return [
        Seen(
            kinds[int(classes[k])],
            int(found[k]),
            int(counts[k]) * S * S,
            (float(sums[k, 0] / counts[k]), float(sums[k, 1] / counts[k]), float(sums[k, 2] / counts[k])),
            (int(votes[k, 0]), int(votes[k, 1]), int(votes[k, 2]), int(votes[k, 3])),
        )
        for k in range(len(found))
    ]


def _sample_points(
    depth: np.ndarray, camera: Camera, pose: Pose, rows: slice, cols: slice
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """float64 [h, w] world x, y, z of the pixels ``depth`` holds (``full[rows, cols]``): ``pixel_points``
    for a grid of samples, from the separable ray table rather than gathered [N, 3] rays."""
    x_over_z, y_over_z = pixel_ray_slopes(camera)
    across, down = x_over_z[cols][None, :] * depth, y_over_z[rows][:, None] * depth  # float32, camera frame
    local = np.stack([across, down, depth], axis=-1).reshape(-1, 3)  # [h * w, 3]
    world = local @ camera_to_world(pose).T + camera_position(camera, pose)  # [h * w, 3], as pixel_points
    x, y, z = world.T.reshape(3, *depth.shape)
    return x, y, z


def facing(sighting: Sighting) -> float | None:
    """The direction the instance's face looks toward, by the votes of every view of it (None: no votes)."""
    if not any(sighting.faces):
        return None
    return DIRECTIONS[int(np.argmax(sighting.faces))]


def note(sightings: list[Sighting], seen: list[Seen], cfg: SearchConfig) -> None:
    """Remember the container instances of this frame; a fuller view moves the point, votes add up."""
    for instance in seen:
        if instance.pixels < cfg.sighting_min_pixels:
            continue
        known = find(sightings, instance.object_type, instance.point, instance.instance_id, cfg)
        if known is None:
            known = Sighting(instance.object_type, instance.point, instance.instance_id, instance.pixels)
            sightings.append(known)
        elif instance.pixels > known.pixels:
            known.point, known.pixels, known.instance_id = (
                instance.point,
                instance.pixels,
                instance.instance_id,
            )
        known.faces = [a + b for a, b in zip(known.faces, instance.votes, strict=True)]


def note_view(sightings: list[Sighting], view: SessionMapView, ontology: Ontology, cfg: SearchConfig) -> None:
    """Remember the container instances (``Ontology.enclosing`` types) in this step's frame: the doors a
    search may open."""
    percept, classes = view.percept, view.map.classes
    kinds = {classes.id_of(kind): kind for kind in ontology.enclosing if kind in classes.types}
    seen = observe(
        percept.class_ids, percept.instances, percept.depth, view.usable, view.camera, view.pose, kinds, cfg
    )
    note(sightings, seen, cfg)


def mark_searched(
    sightings: list[Sighting],
    object_type: str,
    point: Point,
    instance_id: int | None,
    target: str,
    cfg: SearchConfig,
) -> None:
    """Record that the instance at ``point`` was opened (or given up on) while looking for ``target``; every
    sighting that may be it (a fridge seen as two before its views merged) is done with."""
    for known in sightings:
        if same_instance(known, object_type, point, instance_id, cfg) and target not in known.searched_for:
            known.searched_for.append(target)


def mark_visited(sightings: list[Sighting], visit: ContainerVisit, target: str, cfg: SearchConfig) -> None:
    """Record that ``visit``'s container was opened (or given up on) for ``target``: both the sighting the
    visit set out for (at ``visit.target``) and whatever sighting lies where its door was clicked. The click
    lands on the door, not at the sighting's centroid, and with a learned segmenter's per-frame ids nothing
    else ties the two: the sighting left unmarked would be opened again and again."""
    for point in dict.fromkeys(p for p in (visit.target, visit.opened_at) if p is not None):
        mark_searched(sightings, visit.object_type, point, visit.instance_id, target, cfg)
