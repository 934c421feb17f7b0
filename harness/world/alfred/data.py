"""ALFRED's trajectories and AI2-THOR's floor plans as read from the shared data directory (never copied).

``alfred/train.jsonl.gz`` and ``alfred/valid_seen.jsonl.gz`` hold one ``traj_data.json`` per line with the
original field names; ``alfred/layouts/`` holds, per AI2-THOR floor plan, the agent's reachable (x, z)
points on the 0.25 m grid, the object types present, and the receptacles' object ids (which encode their
positions, ``Type|x|y|z``) with the pose ALFRED's planner interacts with each from
(``../shared/data/README.md``). Trajectories are streamed, never held all at once (train is ~100 MB of
JSON); the lookup index and the floor plans are cached per data directory.
"""

from __future__ import annotations

import functools
import gzip
import json
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from harness.world.model import RoomKind
from symbolic.data_dir import require_data_dir
from symbolic.thor import GRID_STEP_M

ALFRED_SPLITS: tuple[str, ...] = ("train", "valid_seen")
"""The splits the data directory holds (valid_unseen is not included)."""

_ROOM_KIND_BY_HUNDRED: dict[int, RoomKind] = {0: "kitchen", 2: "living_room", 3: "bedroom", 4: "bathroom"}
"""AI2-THOR's numbering: FloorPlan1-30 kitchens, 201-230 living rooms, 301-330 bedrooms, 401-430 bathrooms."""

_KEY_PATTERNS = (re.compile(r'"task_id":\s*"([^"]+)"'), re.compile(r'"root":\s*"([^"]+)"'))


@dataclass(frozen=True)
class InteractionPose:
    """Where ALFRED's planner stands to act on a receptacle: a reachable point, a yaw and a camera horizon."""

    x: float
    z: float
    rotation: int
    horizon: float


@dataclass(frozen=True)
class ReceptacleSpot:
    """One receptacle of a floor plan: AI2-THOR's object id and the position that id encodes."""

    object_id: str
    object_type: str
    """The object's type: the id's last field for a basin (``Sink|x|y|z|SinkBasin`` is a SinkBasin)."""
    fixture_type: str
    """The id's first field: the fixture a basin belongs to (Sink, Bathtub), else the object's own type."""
    position: tuple[float, float, float]
    pose: InteractionPose


@dataclass(frozen=True)
class FloorPlan:
    """An AI2-THOR floor plan as ALFRED's ``layouts/`` describe it."""

    name: str
    scene_num: int
    reachable: np.ndarray
    """float [N, 2]: reachable (x, z) points, multiples of GRID_STEP_M."""
    receptacles: tuple[ReceptacleSpot, ...]
    object_types: frozenset[str]

    @property
    def kind(self) -> RoomKind:
        return room_kind(self.scene_num)


@dataclass(frozen=True)
class ObjectPose:
    """One entry of ``scene.object_poses``: an object instance and where ALFRED put it."""

    object_name: str
    object_type: str
    position: tuple[float, float, float]
    yaw: float


@dataclass(frozen=True)
class AlfredScene:
    """The ``scene`` block of a trajectory: floor plan, start pose and the initial object states."""

    floor_plan: str
    scene_num: int
    start: tuple[float, float, int, float]
    """Agent (x, z, rotation, horizon) from ``init_action``."""
    object_poses: tuple[ObjectPose, ...]
    toggles: tuple[tuple[str, bool], ...]
    """(objectType, isOn) pairs from ``object_toggles``."""
    dirty_and_empty: bool
    random_seed: int
    """The seed ALFRED's scene randomisation used (kept as the world's seed)."""
    planned: tuple[tuple[str, tuple[float, float, float]], ...] = ()
    """(type, position) of every object and receptacle the expert plan acts on (``plan.high_pddl``'s
    ``coordinateObjectId`` / ``coordinateReceptacleObjectId``): where fixtures without an id in the floor
    plan (lamps, coffee machines, garbage cans, toilets...) really stand."""


def room_kind(scene_num: int) -> RoomKind:
    """The room kind of an AI2-THOR floor plan number; ValueError outside the four numbered ranges."""
    kind = _ROOM_KIND_BY_HUNDRED.get(scene_num // 100)
    if kind is None or not 1 <= scene_num % 100 <= 30:
        raise ValueError(
            f"scene number {scene_num} is not an AI2-THOR floor plan (1-30, 201-230, 301-330, 401-430)"
        )
    return kind


def alfred_dir(data_dir: Path | None = None) -> Path:
    return require_data_dir(data_dir) / "alfred"


def _split_path(split: str, data_dir: Path | None) -> Path:
    if split not in ALFRED_SPLITS:
        raise ValueError(f"unknown ALFRED split {split!r}; known: {', '.join(ALFRED_SPLITS)}")
    path = alfred_dir(data_dir) / f"{split}.jsonl.gz"
    if not path.is_file():
        raise FileNotFoundError(f"ALFRED split file {path} is missing")
    return path


def _lines(split: str, data_dir: Path | None) -> Iterator[str]:
    with gzip.open(_split_path(split, data_dir), "rt", encoding="utf-8") as lines:
        yield from lines


def load_alfred_trajectories(split: str, data_dir: Path | None = None) -> Iterator[dict[str, Any]]:
    """Every trajectory of a split, one ``traj_data`` dict at a time, in file order."""
    for line in _lines(split, data_dir):
        if line.strip():
            yield json.loads(line)


@functools.lru_cache(maxsize=4)
def _index(alfred: Path) -> dict[str, tuple[str, int]]:
    """task_id and root -> (split, line number); built once by scanning the keys without parsing lines."""
    index: dict[str, tuple[str, int]] = {}
    data_dir = alfred.parent
    for split in ALFRED_SPLITS:
        for number, line in enumerate(_lines(split, data_dir)):
            for pattern in _KEY_PATTERNS:
                found = pattern.search(line)
                if found:
                    index[found.group(1)] = (split, number)
    return index


def find_trajectory(key: str, data_dir: Path | None = None) -> dict[str, Any]:
    """The trajectory whose ``task_id`` ("trial_T2019...") or ``root`` ("valid_seen/<task>/trial_...") is
    ``key``; the first call scans both splits once to index them."""
    alfred = alfred_dir(data_dir).resolve()
    where = _index(alfred).get(key.strip().strip("/"))
    if where is None:
        raise KeyError(
            f"no ALFRED trajectory with task_id or root {key!r} in {', '.join(ALFRED_SPLITS)} under {alfred}"
        )
    split, number = where
    for i, line in enumerate(_lines(split, alfred.parent)):
        if i == number:
            traj: dict[str, Any] = json.loads(line)
            if key.strip().strip("/") not in (traj.get("task_id"), traj.get("root")):
                raise RuntimeError(f"index of {split} is stale: line {number} is not {key!r}")
            return traj
    raise RuntimeError(f"{split} ended before line {number}; the data changed while indexed")


def _parse_spot(object_id: str, pose: list[float]) -> ReceptacleSpot:
    fields = object_id.split("|")
    if len(fields) < 4:
        raise ValueError(f"receptacle id {object_id!r} does not encode a position (Type|x|y|z)")
    x, y, z = (float(v) for v in fields[1:4])
    object_type = fields[4] if len(fields) > 4 else fields[0]
    return ReceptacleSpot(
        object_id=object_id,
        object_type=object_type,
        fixture_type=fields[0],
        position=(x, y, z),
        pose=InteractionPose(float(pose[0]), float(pose[1]), int(round(pose[2])) % 360, float(pose[3])),
    )


def _scene_number(floor_plan: str) -> int:
    found = re.fullmatch(r"FloorPlan(\d+)", floor_plan)
    if found is None:
        raise ValueError(f"{floor_plan!r} is not an AI2-THOR floor plan name (FloorPlanN)")
    return int(found.group(1))


@functools.lru_cache(maxsize=128)
def _floor_plan(layouts: Path, name: str) -> FloorPlan:
    points = np.load(layouts / f"{name}-layout.npy").astype(np.float64).reshape(-1, 2)  # [N, 2]
    cells = points / GRID_STEP_M
    if np.abs(cells - np.round(cells)).max(initial=0.0) > 1e-6:
        raise ValueError(f"{name}: reachable points are not on the {GRID_STEP_M} m grid")
    openable = json.loads((layouts / f"{name}-openable.json").read_text(encoding="utf-8"))
    types = json.loads((layouts / f"{name}-objects.json").read_text(encoding="utf-8"))
    spots = tuple(_parse_spot(oid, pose) for oid, pose in sorted(openable.items()))
    points = np.round(cells) * GRID_STEP_M
    points.setflags(write=False)
    return FloorPlan(name, _scene_number(name), points, spots, frozenset(types))


def load_floor_plan(name: str, data_dir: Path | None = None) -> FloorPlan:
    """A floor plan's reachable grid, receptacles and object types (cached per data directory)."""
    layouts = (alfred_dir(data_dir) / "layouts").resolve()
    if not (layouts / f"{name}-layout.npy").is_file():
        raise FileNotFoundError(f"no layout for {name!r} under {layouts}")
    return _floor_plan(layouts, name)


def _planned(traj: Mapping[str, Any]) -> tuple[tuple[str, tuple[float, float, float]], ...]:
    """ALFRED writes plan coordinates in grid steps as [x, x, z, z, y, y]."""
    found: dict[tuple[str, tuple[float, float, float]], None] = {}
    for step in traj.get("plan", {}).get("high_pddl", ()):
        action = step.get("planner_action", {})
        for key in ("coordinateObjectId", "coordinateReceptacleObjectId"):
            entry = action.get(key)
            if entry and len(entry) == 2 and len(entry[1]) == 6:
                kind, c = entry
                x, y, z = (round(float(c[i]) * GRID_STEP_M, 4) for i in (0, 4, 2))
                found[(str(kind), (x, y, z))] = None
    return tuple(found)


def scene_of(traj: Mapping[str, Any]) -> AlfredScene:
    """The typed ``scene`` block of a trajectory (object type = objectName before its '_' suffix)."""
    scene = traj["scene"]
    start = scene["init_action"]
    poses = tuple(
        ObjectPose(
            object_name=p["objectName"],
            object_type=p["objectName"].split("_")[0],
            position=(float(p["position"]["x"]), float(p["position"]["y"]), float(p["position"]["z"])),
            yaw=float(p["rotation"]["y"]),
        )
        for p in scene["object_poses"]
    )
    return AlfredScene(
        floor_plan=scene["floor_plan"],
        scene_num=int(scene["scene_num"]),
        start=(
            float(start["x"]),
            float(start["z"]),
            int(round(start["rotation"])) % 360,
            float(start["horizon"]),
        ),
        object_poses=poses,
        toggles=tuple((t["objectType"], bool(t["isOn"])) for t in scene.get("object_toggles", ())),
        dirty_and_empty=bool(scene.get("dirty_and_empty", False)),
        random_seed=int(scene.get("random_seed", 0)),
        planned=_planned(traj),
    )
