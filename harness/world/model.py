"""The harness's world state: one room, typed boxes with AI2-THOR's object states, and the agent.

Everything that changes during an episode lives here, so a world can be copied, compared and
serialised. Geometry is deliberately simple: the room is a set of 0.25 m floor cells (any shape,
walls on the boundary) and every object is an axis-aligned box. Static affordances (pickupable,
openable, ...) are not stored per object; they come from the shared ontology by type.

Frames follow AI2-THOR: x and z horizontal, y up; yaw 0 faces +z and 90 faces +x; camera
horizon is positive when looking down.
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from symbolic.thor import CAMERA_HEIGHT_M, GRID_STEP_M

RoomKind = Literal["kitchen", "living_room", "bedroom", "bathroom"]
Liquid = Literal["water", "coffee", "wine"]

STRUCTURE_IDS: dict[str, int] = {"Floor": 1, "Wall": 2, "Ceiling": 3}
"""Instance ids the renderer gives the room's structure; objects get ids from FIRST_OBJECT_ID."""
FIRST_OBJECT_ID = 4


@dataclass
class Room:
    """Floor cells of GRID_STEP_M; walls stand on every edge between a floor cell and a non-floor one."""

    kind: RoomKind
    floor: np.ndarray
    """bool [NX, NZ]: True where the cell is inside the room."""
    origin: tuple[float, float]
    """World (x, z) of the min corner of cell (0, 0)."""
    wall_height: float = 2.6

    def __post_init__(self) -> None:
        assert self.floor.dtype == bool and self.floor.ndim == 2, (
            f"floor must be 2D bool, got {self.floor.dtype}"
        )

    @property
    def shape(self) -> tuple[int, int]:
        NX, NZ = self.floor.shape
        return NX, NZ

    def cell_center(self, ix: int, iz: int) -> tuple[float, float]:
        """World (x, z) of a cell's centre; agent positions are cell centres."""
        return (self.origin[0] + (ix + 0.5) * GRID_STEP_M, self.origin[1] + (iz + 0.5) * GRID_STEP_M)

    def cell_of(self, x: float, z: float) -> tuple[int, int]:
        """The cell containing world point (x, z) (may be outside the grid)."""
        return (
            int(math.floor((x - self.origin[0]) / GRID_STEP_M)),
            int(math.floor((z - self.origin[1]) / GRID_STEP_M)),
        )

    def contains(self, x: float, z: float) -> bool:
        ix, iz = self.cell_of(x, z)
        NX, NZ = self.shape
        return 0 <= ix < NX and 0 <= iz < NZ and bool(self.floor[ix, iz])

    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, z_min, x_max, z_max) of the whole grid in metres."""
        NX, NZ = self.shape
        return (
            self.origin[0],
            self.origin[1],
            self.origin[0] + NX * GRID_STEP_M,
            self.origin[1] + NZ * GRID_STEP_M,
        )


@dataclass
class WorldObject:
    """One object: a typed axis-aligned box with AI2-THOR's mutable states."""

    object_id: str
    """AI2-THOR style id, ``Type|+x.xx|+y.yy|+z.zz``; slices append ``|BreadSliced_1``."""
    object_type: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    """Full extents along x, y, z in metres."""
    facing: int = 0
    """Yaw (0/90/180/270) the object's front faces; a door opens on this side."""
    is_open: bool = False
    is_toggled: bool = False
    is_sliced: bool = False
    is_cooked: bool = False
    is_boiled: bool = False
    is_dirty: bool = False
    is_broken: bool = False
    is_cooled: bool = False
    """Chilled in a closed fridge (ALFRED's cooled-objects set)."""
    is_heated: bool = False
    """Warmed in a heat source that was on (ALFRED's heated-objects set; heatable need not be cookable)."""
    is_cleaned: bool = False
    """Washed under a running faucet at least once (ALFRED's cleaned-objects set)."""
    liquid: Liquid | None = None
    """Liquid it holds, if any (isFilledWithLiquid / simbotIsFilledWithCoffee)."""
    parent_id: str | None = None
    """The receptacle it rests in or on; None for furniture on the floor or a held object."""
    controls: str | None = None
    """For a StoveKnob, the StoveBurner it switches; for a Faucet, the SinkBasin it runs into."""
    picked_up: bool = False
    """Set once the object has been held (TEACh's simbotPickedUp)."""

    @property
    def is_filled(self) -> bool:
        return self.liquid is not None

    @property
    def min_corner(self) -> tuple[float, float, float]:
        return tuple(c - s / 2 for c, s in zip(self.center, self.size, strict=True))  # type: ignore[return-value]

    @property
    def max_corner(self) -> tuple[float, float, float]:
        return tuple(c + s / 2 for c, s in zip(self.center, self.size, strict=True))  # type: ignore[return-value]

    @property
    def top(self) -> float:
        return self.center[1] + self.size[1] / 2

    @property
    def bottom(self) -> float:
        return self.center[1] - self.size[1] / 2


@dataclass
class AgentState:
    """The driver's body and hand. (x, z) is a floor cell centre; yaw is a multiple of 90."""

    x: float
    z: float
    yaw: int = 0
    horizon: float = 0.0
    held: str | None = None
    camera_height: float = CAMERA_HEIGHT_M

    def pose(self) -> dict[str, float]:
        return {
            "x": self.x,
            "y": self.camera_height,
            "z": self.z,
            "yaw": float(self.yaw),
            "horizon": self.horizon,
        }


@dataclass
class World:
    """A whole episode's state; ``copy()`` before trying something speculative."""

    name: str
    room: Room
    objects: dict[str, WorldObject]
    agent: AgentState
    seed: int = 0
    instance_ids: dict[str, int] = field(default_factory=dict)
    """object_id -> segmentation id; stable for the world's lifetime (new slices get new ids)."""

    def __post_init__(self) -> None:
        for oid in self.objects:
            self.register(oid)

    def register(self, object_id: str) -> int:
        """Give an object a segmentation id (idempotent)."""
        if object_id not in self.instance_ids:
            self.instance_ids[object_id] = FIRST_OBJECT_ID + len(self.instance_ids)
        return self.instance_ids[object_id]

    def add(self, obj: WorldObject) -> None:
        assert obj.object_id not in self.objects, f"duplicate object id {obj.object_id}"
        self.objects[obj.object_id] = obj
        self.register(obj.object_id)

    def remove(self, object_id: str) -> None:
        del self.objects[object_id]

    def copy(self) -> World:
        return copy.deepcopy(self)

    def children(self, receptacle_id: str) -> list[WorldObject]:
        """Objects resting directly in or on a receptacle."""
        return [o for o in self.objects.values() if o.parent_id == receptacle_id]

    def parent_chain(self, object_id: str) -> list[str]:
        """Receptacles an object is in, innermost first (AI2-THOR's parentReceptacles)."""
        chain: list[str] = []
        current = self.objects[object_id].parent_id
        while current is not None and current not in chain:
            chain.append(current)
            current = self.objects[current].parent_id if current in self.objects else None
        return chain

    def of_type(self, object_type: str) -> list[WorldObject]:
        return [o for o in self.objects.values() if o.object_type == object_type]

    def held_object(self) -> WorldObject | None:
        return self.objects.get(self.agent.held) if self.agent.held else None

    def metadata(self) -> list[dict[str, Any]]:
        """Objects as AI2-THOR/TEACh metadata dicts (field names as the simulators report them)."""
        out = []
        for o in self.objects.values():
            x, y, z = o.center
            out.append(
                {
                    "objectId": o.object_id,
                    "objectType": o.object_type,
                    "position": {"x": x, "y": y, "z": z},
                    "axisAlignedBoundingBox": {"size": dict(zip("xyz", o.size, strict=True))},
                    "isOpen": o.is_open,
                    "isToggled": o.is_toggled,
                    "isSliced": o.is_sliced,
                    "isCooked": o.is_cooked,
                    "isDirty": o.is_dirty,
                    "isBroken": o.is_broken,
                    "isFilledWithLiquid": o.is_filled,
                    "fillLiquid": o.liquid,
                    "isPickedUp": self.agent.held == o.object_id,
                    "parentReceptacles": self.parent_chain(o.object_id) or None,
                    "receptacleObjectIds": [c.object_id for c in self.children(o.object_id)] or None,
                    "simbotIsCooked": o.is_cooked,
                    "simbotIsBoiled": o.is_boiled,
                    "simbotIsFilledWithCoffee": o.liquid == "coffee",
                    "simbotIsFilledWithWater": o.liquid == "water",
                    "simbotPickedUp": o.picked_up,
                    "isCooled": o.is_cooled,
                    "isCleaned": o.is_cleaned,
                    "isHeated": o.is_heated,
                }
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready snapshot (game files' initial_state / final_state carry it)."""
        return {
            "name": self.name,
            "seed": self.seed,
            "room": {
                "kind": self.room.kind,
                "origin": list(self.room.origin),
                "wall_height": self.room.wall_height,
                "floor": self.room.floor.astype(np.uint8).tolist(),
            },
            "agent": asdict(self.agent),
            "objects": [asdict(o) for o in self.objects.values()],
            "instance_ids": dict(self.instance_ids),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> World:
        room = Room(
            kind=data["room"]["kind"],
            floor=np.asarray(data["room"]["floor"], dtype=np.uint8).astype(bool),
            origin=(float(data["room"]["origin"][0]), float(data["room"]["origin"][1])),
            wall_height=data["room"]["wall_height"],
        )
        objects = {}
        for o in data["objects"]:
            o = dict(o)
            o["center"] = tuple(o["center"])
            o["size"] = tuple(o["size"])
            objects[o["object_id"]] = WorldObject(**o)
        world = cls(
            name=data["name"],
            room=room,
            objects=objects,
            agent=AgentState(**data["agent"]),
            seed=data.get("seed", 0),
            instance_ids=dict(data.get("instance_ids", {})),
        )
        return world


def make_object_id(object_type: str, center: tuple[float, float, float]) -> str:
    """AI2-THOR's id format: type and position to two decimals with explicit signs."""
    return object_type + "".join(f"|{c:+06.2f}" for c in center)
