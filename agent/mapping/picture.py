"""A top-down picture of a session's semantic map (``GET /v1/sessions/{id}/map.png``).

Drawn the way the JARVIS seed's figures show its map (seed 002, "Semantic map in progress"): known floor
light, obstacles dark, unexplored grey, each object class in its own colour, the agent as an arrow, the
planned path as a line and the current target ringed, with a legend naming every class shown. North (+z)
is up and east (+x) right, so the picture reads like a floor plan.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from agent.classes import UNOBSERVED_ID, load_class_index
from agent.geometry import Pose
from agent.mapping.semantic_map import UNKNOWN_SURFACE_ID, SemanticMap

_GOLDEN_ANGLE_DEG = 137.508


@dataclass(frozen=True)
class PictureStyle:
    """Colours (BGR, as cv2 draws) and sizes (pixels) of the map picture."""

    scale: int = 3  # pixels per 5 cm cell
    unexplored: tuple[int, int, int] = (150, 150, 150)
    free: tuple[int, int, int] = (238, 238, 238)
    visited: tuple[int, int, int] = (245, 225, 200)
    obstacle: tuple[int, int, int] = (70, 70, 70)
    collision: tuple[int, int, int] = (40, 40, 220)
    path: tuple[int, int, int] = (220, 120, 0)
    agent: tuple[int, int, int] = (0, 150, 0)
    target: tuple[int, int, int] = (255, 0, 255)
    legend_width: int = 190
    legend_row: int = 16


def class_colour(object_type: str) -> tuple[int, int, int]:
    """A stable BGR colour per type: hues a golden angle apart in class-id order, so neighbours differ."""
    class_id = load_class_index().id_of(object_type)
    hue = int(class_id * _GOLDEN_ANGLE_DEG) % 360 // 2  # cv2 hue runs 0..179
    saturation, value = (230, 235) if class_id % 2 else (160, 190)
    hsv = np.array([[[hue, saturation, value]]], dtype=np.uint8)
    b, g, r = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
    return int(b), int(g), int(r)


def render_map_png(
    semantic_map: SemanticMap,
    *,
    agent_pose: Pose | None = None,
    path_cells: Sequence[tuple[int, int]] | np.ndarray | None = None,
    target_type: str | None = None,
    legend: bool = True,
    style: PictureStyle = PictureStyle(),
) -> bytes:
    """PNG bytes of the map; ``path_cells`` are (i, j) cells of the map's current frame."""
    image, shown = _map_layers(semantic_map, target_type, style)
    X, Z = semantic_map.shape
    s = style.scale

    def pixel(i: float, j: float) -> tuple[int, int]:
        """Image (col, row) of the centre of cell (i, j): x to the right, z up."""
        return int((i + 0.5) * s), int((Z - 1 - j + 0.5) * s)

    if path_cells is not None and len(path_cells) > 1:
        points = np.array([pixel(i, j) for i, j in path_cells], dtype=np.int32)
        cv2.polylines(image, [points], isClosed=False, color=style.path, thickness=max(1, s // 2 + 1))
    if target_type is not None:  # a ring around every separate instance of the target
        target = semantic_map.presence(target_type).astype(np.uint8)
        count, labels = cv2.connectedComponents(target, connectivity=8)
        for label in range(1, count):
            ii, jj = np.nonzero(labels == label)
            radius = int(max(np.ptp(ii), np.ptp(jj)) * s / 2 + 4 * s)
            cv2.circle(image, pixel(float(ii.mean()), float(jj.mean())), radius, style.target, thickness=2)
    if agent_pose is not None:
        i, j = semantic_map.world_to_cell(agent_pose.x, agent_pose.z)
        fx, fz = agent_pose.forward()
        length = 0.35 / semantic_map.config.cell_m  # the arrow is 35 cm long
        tail = pixel(i, j)
        head = pixel(i + fx * length, j + fz * length)
        cv2.arrowedLine(image, tail, head, style.agent, thickness=max(2, s), tipLength=0.4)
    if legend:
        panel = _legend_panel(image.shape[0], shown, target_type, style)
        if panel.shape[0] > image.shape[0]:  # more classes than the map is tall: extend the map downwards
            pad = np.full((panel.shape[0] - image.shape[0], *image.shape[1:]), 255, dtype=np.uint8)
            image = np.vstack([image, pad])
        image = np.hstack([image, panel])
    ok, png = cv2.imencode(".png", image)
    assert ok, "cv2 failed to encode the map picture"
    return png.tobytes()


def _map_layers(
    semantic_map: SemanticMap, target_type: str | None, style: PictureStyle
) -> tuple[np.ndarray, list[str]]:
    """BGR [Z*s, X*s, 3] picture of the 2D layers, and the object types drawn in it (for the legend)."""
    X, Z = semantic_map.shape
    image = np.empty((X, Z, 3), dtype=np.uint8)  # built as [i, j], flipped to rows/cols at the end
    image[:] = style.unexplored
    image[semantic_map.free()] = style.free
    image[semantic_map.visited() & semantic_map.free()] = style.visited
    image[semantic_map.obstacles()] = style.obstacle
    top = _top_class(semantic_map)
    shown: list[str] = []
    classes = semantic_map.classes
    for class_id in np.unique(top):
        if class_id in (0, UNKNOWN_SURFACE_ID) or classes.priority[class_id] <= 1:  # empty or structure
            continue
        name = classes.type_of(int(class_id))
        image[top == class_id] = class_colour(name)
        shown.append(name)
    if target_type is not None:
        image[semantic_map.presence(target_type)] = style.target
    image[semantic_map.collisions()] = style.collision
    s = style.scale
    picture = np.ascontiguousarray(np.flip(image.transpose(1, 0, 2), axis=0))  # [Z, X, 3], +z up
    return np.repeat(np.repeat(picture, s, axis=0), s, axis=1), sorted(shown)


def _top_class(semantic_map: SemanticMap) -> np.ndarray:
    """uint8 [X, Z]: per cell, the class a viewer most wants to see (the highest-priority one present)."""
    voxels = semantic_map.voxels
    priority = semantic_map.classes.priority.astype(np.uint16)
    priority[[0, UNOBSERVED_ID]] = 0
    codes = (priority[voxels] << 8) | voxels.astype(np.uint16)  # [X, Z, B]
    codes[voxels == UNOBSERVED_ID] = 0
    return (codes.max(axis=2) & 0xFF).astype(np.uint8)


def _legend_panel(height: int, shown: list[str], target_type: str | None, style: PictureStyle) -> np.ndarray:
    """White panel listing the layer colours and every class drawn (at least ``height`` pixels tall)."""
    entries: list[tuple[str, tuple[int, int, int]]] = [
        ("free floor", style.free),
        ("obstacle", style.obstacle),
        ("unexplored", style.unexplored),
        ("collision", style.collision),
        ("agent", style.agent),
        ("path", style.path),
    ]
    if target_type is not None:
        entries.append((f"target: {target_type}", style.target))
    entries += [(name, class_colour(name)) for name in shown]
    row = style.legend_row
    panel = np.full((max(height, 8 + len(entries) * row), style.legend_width, 3), 255, dtype=np.uint8)
    for k, (label, colour) in enumerate(entries):
        y = 4 + k * row
        cv2.rectangle(panel, (6, y), (6 + row - 4, y + row - 4), colour, thickness=-1)
        cv2.rectangle(panel, (6, y), (6 + row - 4, y + row - 4), (0, 0, 0), thickness=1)
        cv2.putText(
            panel, label, (row + 8, y + row - 5), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1, cv2.LINE_AA
        )
    return panel
