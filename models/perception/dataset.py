"""Perception frames on disk: the folder layout the networks train and evaluate on.

One folder per split; each frame NAME has three files (the same encodings the HTTP API accepts, so frames
saved from AI2-THOR with the usual tools fit without conversion)::

    ROOT/
      meta.json                  optional: {"camera": {...}, "task_classes": [...], ...}
      rgb/NAME.png               8-bit RGB (PNG or .jpg)
      depth/NAME.png             16-bit single-channel PNG, z-depth in millimetres (0 = no reading),
                                 or depth/NAME.npy, float32 [H, W] metres
      instances/NAME.png         16-bit single-channel PNG of instance ids (0 = nothing)
      instances/NAME.json        {"<id>": "<object type>"}: AI2-THOR types or any name the ontology resolves

``python -m harness.perception_data frames`` writes this layout from the harness. For AI2-THOR frames: save
``event.frame`` as rgb, ``event.depth_frame * 1000`` as a uint16 PNG, and number ``event.instance_masks``
into an id image with the legend of each id's ``objectType``. Types the ontology does not know are ignored
in the loss and the metrics (label IGNORE_LABEL) rather than refused, so a user's extra types cost nothing.

Labels are ontology class indices: 0 = nothing, k = the k-th of ``ontology.types`` (sorted), which are the
agent's ClassIndex ids too. Frames are resized to the network side once and cached beside the data.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from symbolic.ontology import Ontology, UnknownObjectType, load_ontology

NOTHING_CLASS = "Nothing"
"""Label 0: pixels that show no object (rays that hit nothing, or ids missing from the legend)."""
IGNORE_LABEL = 255
"""Label of pixels whose type the ontology does not know; losses and metrics skip them."""
RGB_SUFFIXES: tuple[str, ...] = (".png", ".jpg", ".jpeg")


def ontology_classes(ontology: Ontology | None = None) -> tuple[str, ...]:
    """Segmentation classes: NOTHING_CLASS then every ontology type in sorted order (ClassIndex's ids)."""
    ontology = ontology or load_ontology()
    return (NOTHING_CLASS, *ontology.types)


@dataclass(frozen=True)
class FrameArrays:
    """A split's frames at one square side, in memory (uint8 and uint16 keep 6000 frames under 0.6 GB)."""

    names: tuple[str, ...]
    rgb: np.ndarray  # uint8 [N, S, S, 3]
    depth_mm: np.ndarray  # uint16 [N, S, S] z-depth in millimetres, 0 = no reading
    labels: np.ndarray  # uint8 [N, S, S] class index, IGNORE_LABEL for unknown types
    classes: tuple[str, ...]  # label -> class name
    task_classes: tuple[str, ...]  # classes tasks name (from meta.json), for the metrics

    def __len__(self) -> int:
        return len(self.names)


def frame_names(root: Path) -> list[str]:
    """Names of complete frames (rgb, depth and instances all present), sorted; ValueError if none."""
    rgb_dir = root / "rgb"
    if not rgb_dir.is_dir():
        raise ValueError(f"{root} has no rgb/ folder; see models/perception/dataset.py for the layout")
    names = []
    for path in sorted(rgb_dir.iterdir()):
        if path.suffix.lower() not in RGB_SUFFIXES:
            continue
        name = path.stem
        has_depth = (root / "depth" / f"{name}.png").is_file() or (root / "depth" / f"{name}.npy").is_file()
        has_seg = (root / "instances" / f"{name}.png").is_file() and (
            root / "instances" / f"{name}.json"
        ).is_file()
        if has_depth and has_seg:
            names.append(name)
    if not names:
        raise ValueError(f"{root} holds no complete frame (rgb/NAME, depth/NAME, instances/NAME.png+json)")
    return names


def read_rgb(root: Path, name: str) -> np.ndarray:
    """uint8 [H, W, 3] RGB."""
    for suffix in RGB_SUFFIXES:
        path = root / "rgb" / f"{name}{suffix}"
        if path.is_file():
            image = cv2.imread(str(path), cv2.IMREAD_COLOR)
            if image is None:
                raise ValueError(f"{path} is not a readable image")
            return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    raise FileNotFoundError(f"no rgb image for {name!r} in {root / 'rgb'}")


def read_depth_m(root: Path, name: str) -> np.ndarray:
    """float32 [H, W] z-depth in metres (0 = no reading)."""
    npy = root / "depth" / f"{name}.npy"
    if npy.is_file():
        return np.load(npy).astype(np.float32)
    path = root / "depth" / f"{name}.png"
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None or image.dtype != np.uint16 or image.ndim != 2:
        raise ValueError(f"{path} must be a single-channel 16-bit PNG of millimetres")
    return image.astype(np.float32) * np.float32(0.001)


def read_instances(root: Path, name: str) -> tuple[np.ndarray, dict[int, str]]:
    """int32 [H, W] instance ids and their legend (id -> type name, as the frame's JSON says)."""
    path = root / "instances" / f"{name}.png"
    ids = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if ids is None or ids.ndim != 2:
        raise ValueError(f"{path} must be a single-channel PNG of instance ids")
    legend = json.loads((root / "instances" / f"{name}.json").read_text())
    return ids.astype(np.int32), {int(key): str(type_name) for key, type_name in legend.items()}


def read_labels(root: Path, name: str, index: dict[str, int], ontology: Ontology) -> np.ndarray:
    """uint8 [H, W] class labels from the instance ids and their legend (unknown types -> IGNORE_LABEL)."""
    ids, legend = read_instances(root, name)
    table = np.zeros(int(ids.max(initial=0)) + 1, dtype=np.uint8)  # ids without a legend entry: nothing
    for instance_id, type_name in legend.items():
        if instance_id >= len(table):
            continue
        try:
            table[instance_id] = index[ontology.resolve(type_name)]
        except UnknownObjectType:
            table[instance_id] = IGNORE_LABEL
    return table[ids.astype(np.int64)]


def resize_frame(
    rgb: np.ndarray, depth_m: np.ndarray, labels: np.ndarray, side: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """To side x side: RGB by area averaging (as the run-time downscale of a 900x900 frame), depth and
    labels by nearest neighbour (averaging would invent depths and classes across object edges)."""
    rgb = cv2.resize(rgb, (side, side), interpolation=cv2.INTER_AREA)
    depth = cv2.resize(depth_m, (side, side), interpolation=cv2.INTER_NEAREST)
    labels = cv2.resize(labels, (side, side), interpolation=cv2.INTER_NEAREST)
    return rgb, depth, labels


def _cache_path(root: Path, names: Sequence[str], side: int) -> Path:
    digest = hashlib.sha1("\n".join(names).encode()).hexdigest()[:12]
    return root / f".cache_{side}_{digest}.npz"


def load_frames(root: Path, side: int, *, limit: int | None = None, use_cache: bool = True) -> FrameArrays:
    """Every complete frame of ``root`` (the first ``limit``), resized to ``side``; cached as .npz."""
    ontology = load_ontology()
    classes = ontology_classes(ontology)
    index = {name: i for i, name in enumerate(classes)}
    names = frame_names(root)[:limit]
    meta_path = root / "meta.json"
    meta = json.loads(meta_path.read_text()) if meta_path.is_file() else {}
    task_classes = tuple(t for t in meta.get("task_classes", ()) if t in index)
    cache = _cache_path(root, names, side)
    if use_cache and cache.is_file():
        with np.load(cache) as data:
            return FrameArrays(
                tuple(names), data["rgb"], data["depth_mm"], data["labels"], classes, task_classes
            )
    N = len(names)
    rgb = np.empty((N, side, side, 3), dtype=np.uint8)
    depth_mm = np.empty((N, side, side), dtype=np.uint16)
    labels = np.empty((N, side, side), dtype=np.uint8)
    for i, name in enumerate(tqdm(names, desc=f"reading {root.name}", unit="frame", leave=False)):
        frame_rgb, frame_depth, frame_labels = resize_frame(
            read_rgb(root, name), read_depth_m(root, name), read_labels(root, name, index, ontology), side
        )
        rgb[i] = frame_rgb
        depth_mm[i] = np.clip(np.round(frame_depth * 1000.0), 0, 65535).astype(np.uint16)
        labels[i] = frame_labels
    if use_cache:
        np.savez(cache, rgb=rgb, depth_mm=depth_mm, labels=labels)
    return FrameArrays(tuple(names), rgb, depth_mm, labels, classes, task_classes)
