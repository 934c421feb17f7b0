"""What AI2-THOR's rooms are made of: object sizes, how receptacles hold things, what each room kind holds.

The numbers live in ``catalog.json`` beside this module (its ``source`` field says where they come from:
typical extents of AI2-THOR's assets, rounded; room contents after ALFRED's scene lists). The world
generator reads it to build rooms, and the world checks (``harness.world.invariants``) read it to know whether
a child should rest on, lie inside or hang below its receptacle. Affordances and which receptacle accepts
which object are not here: they are the shared ontology's (``symbolic.ontology``).
"""

from __future__ import annotations

import functools
import json
import random
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from typing import Any, Literal

Span = tuple[float, float]
"""A closed range [lo, hi] in metres (or square metres), sampled uniformly by the generator."""

Extent = float | Span
"""One dimension of a catalog size: fixed, or a range to draw from."""

Placement = Literal["on", "inside", "hanging"]
"""How a receptacle holds its children: on its top surface, within its inner volume, or hanging below it."""

SIZE_STEP_M = 0.05
"""Sizes drawn from a range are rounded to this, so furniture lines up with the 0.25 m floor grid often."""


@dataclass(frozen=True)
class CounterRunSpec:
    """One room's kitchen-style counter runs (base units under a top, sink and stove units in the run)."""

    length_m: Span
    sinks: int
    """Sink units in the first run."""
    stoves: int
    """Stove units in the first run (a second run takes the stove if the first is too short)."""
    burners: tuple[int, int]
    """StoveBurners per stove unit, drawn from [lo, hi] (AI2-THOR kitchens have 2 to 4)."""
    drawer_p: float
    """Chance that a plain base unit is a Drawer over a shorter Cabinet instead of a full Cabinet."""
    upper_cabinet_p: float
    """Chance of a wall Cabinet above each base unit (never above a stove: that is the hood's place)."""


@dataclass(frozen=True)
class FurnitureSpec:
    """One kind of furniture a room may hold, and the rule that places it (``place`` names a strategy)."""

    object_type: str
    place: str
    count: tuple[int, int]
    p: float
    """Chance the room has any; then the number is drawn from ``count``."""
    of: tuple[str, ...] = ()
    """Host types for relative strategies (beside, on, front_of, around, above)."""
    bottom_m: Span | None = None
    """Mounting height of the bottom for wall-mounted pieces."""
    gap_m: Span | None = None
    """Distance to the host for front_of."""
    levels: tuple[int, int] | None = None
    """Number of Shelf slabs for shelf_stack."""
    spacing_m: float | None = None
    """Vertical distance between shelf slabs."""
    drawers: tuple[int, int] | None = None
    """Number of Drawers stacked in a dresser."""
    drawer_height_m: float | None = None
    run: CounterRunSpec | None = None
    makes: tuple[str, ...] = ()
    """Every type the entry builds: its own, and what its assembly adds (a counter run makes sinks and
    drawers; the catalog's ``assemblies``)."""


@dataclass(frozen=True)
class ObjectSpec:
    """One kind of small object a room holds and the receptacle types it usually starts in (with weights)."""

    object_type: str
    count: tuple[int, int]
    min_count: int
    """At least this many exist in every world of the room kind (the task-relevant objects)."""
    where: tuple[tuple[str, float], ...]


@dataclass(frozen=True)
class RoomSpec:
    """Everything the generator needs to know about one of AI2-THOR's four room kinds."""

    kind: str
    area_m2: Span
    wall_height_m: Span
    furniture: tuple[FurnitureSpec, ...]
    objects: tuple[ObjectSpec, ...]

    @property
    def furniture_types(self) -> frozenset[str]:
        """Every type the room's furniture entries build, assemblies included."""
        return frozenset(t for entry in self.furniture for t in entry.makes)


@dataclass(frozen=True)
class CounterSpec:
    """Dimensions shared by every counter run (kitchen counters and bathroom vanities)."""

    top_m: float
    unit_widths_m: tuple[float, ...]
    sink_width_m: float
    stove_width_m: float
    drawer_height_m: float
    sink_cabinet_height_m: float
    upper_cabinet_bottom_m: float
    upper_cabinet_height_m: float
    upper_cabinet_depth_m: float
    burner_offsets_m: tuple[tuple[float, float], ...]
    """(along the run from the stove unit's centre, from the wall) of each burner site."""


def _span(value: Any) -> Span:
    lo, hi = (float(v) for v in value)
    if lo > hi:
        raise ValueError(f"range {value!r} has lo > hi")
    return (lo, hi)


def _int_span(value: Any) -> tuple[int, int]:
    lo, hi = (int(v) for v in value)
    if not 0 <= lo <= hi:
        raise ValueError(f"count range {value!r} must satisfy 0 <= lo <= hi")
    return (lo, hi)


def _extent(value: Any) -> Extent:
    return _span(value) if isinstance(value, list) else float(value)


def _draw(extent: Extent, rng: random.Random) -> float:
    if isinstance(extent, float):
        return extent
    lo, hi = extent
    steps = int(round((hi - lo) / SIZE_STEP_M))
    return round(lo + SIZE_STEP_M * rng.randint(0, steps), 4)


def _mid(extent: Extent) -> float:
    return extent if isinstance(extent, float) else (extent[0] + extent[1]) / 2


def _furniture(entry: Mapping[str, Any], assemblies: Mapping[str, Any]) -> FurnitureSpec:
    run = entry.get("run")
    return FurnitureSpec(
        object_type=entry["type"],
        place=entry["place"],
        count=_int_span(entry["count"]),
        p=float(entry["p"]),
        of=tuple(entry.get("of", ())),
        bottom_m=_span(entry["bottom_m"]) if "bottom_m" in entry else None,
        gap_m=_span(entry["gap_m"]) if "gap_m" in entry else None,
        levels=_int_span(entry["levels"]) if "levels" in entry else None,
        spacing_m=float(entry["spacing_m"]) if "spacing_m" in entry else None,
        drawers=_int_span(entry["drawers"]) if "drawers" in entry else None,
        drawer_height_m=float(entry["drawer_height_m"]) if "drawer_height_m" in entry else None,
        run=None
        if run is None
        else CounterRunSpec(
            length_m=_span(run["length_m"]),
            sinks=int(run["sinks"]),
            stoves=int(run["stoves"]),
            burners=_int_span(run["burners"]),
            drawer_p=float(run["drawer_p"]),
            upper_cabinet_p=float(run["upper_cabinet_p"]),
        ),
        makes=(entry["type"], *assemblies.get(entry["place"], ())),
    )


def _object(entry: Mapping[str, Any]) -> ObjectSpec:
    count = _int_span(entry["count"])
    min_count = int(entry.get("min", 0))
    if min_count > count[1]:
        raise ValueError(f"object {entry['type']!r}: min {min_count} exceeds count {count}")
    return ObjectSpec(
        object_type=entry["type"],
        count=count,
        min_count=min_count,
        where=tuple((str(k), float(v)) for k, v in entry["in"].items()),
    )


class Catalog:
    """Lookup over ``catalog.json``; build one with ``load_catalog()``."""

    def __init__(self, data: Mapping[str, Any]) -> None:
        self._sizes: dict[str, tuple[Extent, Extent, Extent]] = {
            name: (_extent(w), _extent(h), _extent(d)) for name, (w, h, d) in data["sizes"].items()
        }
        self._alfred_only_sizes: dict[str, tuple[float, float, float]] = {
            name: (float(w), float(h), float(d)) for name, (w, h, d) in data["alfred_only_sizes"].items()
        }
        self._alfred_mount_bottom: dict[str, float] = {
            name: float(v) for name, v in data["alfred_mount_bottom_m"].items()
        }
        receptacles = data["receptacles"]
        self._placement: dict[str, Placement] = {t: "inside" for t in receptacles["inside"]}
        self._placement.update({t: "hanging" for t in receptacles["hanging"]})
        self._single_slot = frozenset(receptacles["single_slot"])
        self._wall_thickness: dict[str, float] = {
            k: float(v) for k, v in receptacles["wall_thickness_m"].items()
        }
        self._shelf_spacing: dict[str, float] = {
            k: float(v) for k, v in receptacles["shelf_spacing_m"].items()
        }
        self._side_attached = frozenset(data["side_attached"])
        self._wall_mountable = frozenset(data["wall_mountable"])
        c = data["counter"]
        self.counter = CounterSpec(
            top_m=float(c["top_m"]),
            unit_widths_m=tuple(float(w) for w in c["unit_widths_m"]),
            sink_width_m=float(c["sink_width_m"]),
            stove_width_m=float(c["stove_width_m"]),
            drawer_height_m=float(c["drawer_height_m"]),
            sink_cabinet_height_m=float(c["sink_cabinet_height_m"]),
            upper_cabinet_bottom_m=float(c["upper_cabinet_bottom_m"]),
            upper_cabinet_height_m=float(c["upper_cabinet_height_m"]),
            upper_cabinet_depth_m=float(c["upper_cabinet_depth_m"]),
            burner_offsets_m=tuple((float(a), float(b)) for a, b in c["burner_offsets_m"]),
        )
        self._rooms: dict[str, RoomSpec] = {
            kind: RoomSpec(
                kind=kind,
                area_m2=_span(room["area_m2"]),
                wall_height_m=_span(room["wall_height_m"]),
                furniture=tuple(_furniture(e, data["assemblies"]) for e in room["furniture"]),
                objects=tuple(_object(e) for e in room["objects"]),
            )
            for kind, room in data["rooms"].items()
        }
        self.kinds: tuple[str, ...] = tuple(self._rooms)
        self._check_sizes()

    def _check_sizes(self) -> None:
        """Every type a room names must have a size, so a missing entry fails at load, not mid-generation."""
        for room in self._rooms.values():
            named = [f.object_type for f in room.furniture] + [o.object_type for o in room.objects]
            for object_type in named:
                if object_type not in self._sizes:
                    raise ValueError(f"catalog room {room.kind!r} names {object_type!r}, which has no size")

    @property
    def sized_types(self) -> tuple[str, ...]:
        return tuple(sorted(self._sizes))

    def has_size(self, object_type: str) -> bool:
        return object_type in self._sizes

    def _size_entry(self, object_type: str) -> tuple[Extent, Extent, Extent]:
        entry = self._sizes.get(object_type)
        if entry is None:
            raise KeyError(
                f"no size for {object_type!r} in the catalog; known: {', '.join(self.sized_types)}"
            )
        return entry

    def draw_size(self, object_type: str, rng: random.Random) -> tuple[float, float, float]:
        """(width, height, depth) of one instance; ranged dimensions are drawn in SIZE_STEP_M steps."""
        w, h, d = self._size_entry(object_type)
        return (_draw(w, rng), _draw(h, rng), _draw(d, rng))

    def nominal_size(self, object_type: str) -> tuple[float, float, float]:
        """(width, height, depth) at the middle of every range: for feasibility estimates."""
        w, h, d = self._size_entry(object_type)
        return (_mid(w), _mid(h), _mid(d))

    def scene_size(self, object_type: str) -> tuple[float, float, float]:
        """``nominal_size``, or for the few types only ALFRED's scenes hold, the catalog's size for those."""
        if not self.has_size(object_type) and object_type in self._alfred_only_sizes:
            return self._alfred_only_sizes[object_type]
        return self.nominal_size(object_type)

    def alfred_mount_bottom(self, object_type: str) -> float:
        """Height of a wall fixture's bottom in a rebuilt ALFRED room (its data does not place them)."""
        return self._alfred_mount_bottom.get(object_type, self._alfred_mount_bottom["default"])

    def room(self, kind: str) -> RoomSpec:
        spec = self._rooms.get(kind)
        if spec is None:
            raise KeyError(f"unknown room kind {kind!r}; known: {', '.join(self.kinds)}")
        return spec

    def placement(self, receptacle_type: str) -> Placement:
        """How ``receptacle_type`` holds what is put in it (AI2-THOR: a Fridge's contents are inside it, a
        CounterTop's on it, a TowelHolder's towel hangs below the bar)."""
        return self._placement.get(receptacle_type, "on")

    def single_slot(self, receptacle_type: str) -> bool:
        """Receptacles with one place only (a burner takes one pan, a coffee machine one mug)."""
        return receptacle_type in self._single_slot

    def wall_thickness(self, receptacle_type: str) -> float:
        """Thickness of an inside-receptacle's walls and floor: its inner volume is the box shrunk by it."""
        return self._wall_thickness.get(receptacle_type, self._wall_thickness["default"])

    def shelf_spacing(self, receptacle_type: str) -> float | None:
        """Height between inner shelves (fridges and cabinets have them), or None for a single floor."""
        return self._shelf_spacing.get(receptacle_type)

    def side_attached(self, object_type: str) -> bool:
        """Fixtures held up by the side of the furniture they touch rather than by what is under them."""
        return object_type in self._side_attached

    def wall_mountable(self, object_type: str) -> bool:
        """Types AI2-THOR scenes hang on walls (wall cabinets, shelves, mirrors, switches, towel holders)."""
        return object_type in self._wall_mountable


@functools.cache
def load_catalog() -> Catalog:
    """The project's catalog, read once from the package data file ``harness/world/catalog.json``."""
    text = resources.files("harness.world").joinpath("catalog.json").read_text(encoding="utf-8")
    return Catalog(json.loads(text))
