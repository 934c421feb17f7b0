"""Object types of AI2-THOR as ALFRED and TEACh use them: affordances, compatibility, and names people use.

The facts live in ``ontology.json`` beside this module (its ``sources`` field names where each comes
from: ALFRED's ``object_facts.json``, AI2-THOR's "Object Types" table, TEACh's object classes). Beliefs
and plans are per object *type*, as in the JARVIS seed's symbolic level, so this is the one table that the
repair rules, the harness's action semantics and the world generator all consult.
"""

from __future__ import annotations

import difflib
import functools
import json
import re
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from typing import Any, Literal, get_args

Purpose = Literal["any", "place"]

SurfacePurpose = Literal["put_down", "spare", "spread_out", "lamp_hosts"]
"""What a list of open surfaces is for (each list's ``why`` in ontology.json says why it differs)."""

AFFORDANCES: tuple[str, ...] = (
    "pickupable",
    "receptacle",
    "movable_receptacle",
    "openable",
    "toggleable",
    "sliceable",
    "cookable",
    "dirtyable",
    "fillable",
    "breakable",
    "heatable",
    "coolable",
    "cleanable",
)
"""Boolean fields of ObjectTypeInfo: the flags a type's ``affordances`` in ontology.json may name."""

_ARTICLES = frozenset({"the", "a", "an", "some", "that", "this", "those", "these", "my", "your", "any"})
_SLICE_PATTERNS = (
    re.compile(r"^(?:slice|slices|piece|pieces|bit|bits) of (?P<x>.+)$"),
    re.compile(r"^sliced (?P<x>.+)$"),
    re.compile(r"^(?P<x>.+) (?:slice|slices|sliced)$"),
)
_MAX_SUGGESTIONS = 5


class UnknownObjectType(ValueError):
    """A name that is no object type; ``suggestions`` holds the closest types so a user can fix it."""

    def __init__(self, name: str, suggestions: tuple[str, ...]) -> None:
        self.name = name
        self.suggestions = suggestions
        hint = f"; closest: {', '.join(suggestions)}" if suggestions else ""
        super().__init__(f"unknown object type {name!r}{hint}")


@dataclass(frozen=True)
class ObjectTypeInfo:
    """Static facts about one AI2-THOR object type (states such as open or sliced live in beliefs/worlds)."""

    name: str
    pickupable: bool
    receptacle: bool
    movable_receptacle: bool
    openable: bool
    toggleable: bool
    sliceable: bool
    cookable: bool
    dirtyable: bool
    fillable: bool
    breakable: bool
    heatable: bool
    coolable: bool
    cleanable: bool
    sliced_into: str | None
    """What Slice makes of it: Bread -> BreadSliced, Egg -> EggCracked."""
    sliced_from: str | None
    """The whole object a slice came from: BreadSliced -> Bread."""
    classes: tuple[str, ...]
    """TEACh's simbotObjectClass values: the type itself plus its custom_object_classes.json classes."""
    structural: bool
    """Floor, Wall, Ceiling, Window, Door: segmented by the renderer, never an interaction target."""


def _key(text: str) -> str:
    """Case-, space- and separator-insensitive key: 'Coffee machine', 'coffee_machine' -> 'coffeemachine'."""
    return re.sub(r"[^a-z0-9]", "", text.lower())


def _words(text: str) -> str:
    """Lower-case words without punctuation or leading articles: 'The Coffee-Mug!' -> 'coffee mug'."""
    spaced = re.sub(r"([a-z])([A-Z])", r"\1 \2", text.strip())
    words = re.sub(r"[^a-z0-9]+", " ", spaced.lower()).split()
    while words and words[0] in _ARTICLES:
        words = words[1:]
    return " ".join(words)


def _singulars(phrase: str) -> list[str]:
    """The phrase and its likely singular forms (last word only): knives -> knife, potatoes -> potato."""
    head, _, last = phrase.rpartition(" ")
    prefix = f"{head} " if head else ""
    forms = [last]
    if last.endswith("ves"):
        forms += [last[:-3] + "f", last[:-3] + "fe"]
    if last.endswith("ies"):
        forms.append(last[:-3] + "y")
    if last.endswith("es"):
        forms.append(last[:-2])
    if last.endswith("s") and not last.endswith("ss"):
        forms.append(last[:-1])
    return [prefix + form for form in forms]


class Ontology:
    """Lookup over the object-type table; build one with ``load_ontology()``."""

    def __init__(self, data: Mapping[str, Any]) -> None:
        sliced_into: dict[str, str] = dict(data["sliced_into"])
        sliced_from = {piece: whole for whole, piece in sliced_into.items()}
        structural = frozenset(data["structural"])
        self._info: dict[str, ObjectTypeInfo] = {}
        for name, entry in data["types"].items():
            flags = set(entry["affordances"])
            unknown_flags = flags - set(AFFORDANCES)
            if unknown_flags:
                raise ValueError(f"type {name!r} has unknown affordances {sorted(unknown_flags)}")
            self._info[name] = ObjectTypeInfo(
                name=name,
                **{flag: flag in flags for flag in AFFORDANCES},
                sliced_into=sliced_into.get(name),
                sliced_from=sliced_from.get(name),
                classes=tuple(dict.fromkeys([name, *entry["classes"]])),
                structural=name in structural,
            )
        self.types: tuple[str, ...] = tuple(sorted(self._info))
        self._accepts: dict[str, frozenset[str]] = {
            receptacle: frozenset(objects) for receptacle, objects in data["accepts"].items()
        }
        self._receptacles_for: dict[str, tuple[str, ...]] = {
            obj: tuple(sorted(r for r, objs in self._accepts.items() if obj in objs)) for obj in self.types
        }
        self.slicing_tools: tuple[str, ...] = tuple(data["slicing_tools"])
        """Types that Slice needs in hand (Knife first: it is what repair fetches)."""
        self.one_word_kinds: dict[str, tuple[str, ...]] = {
            word: tuple(kinds) for word, kinds in data["one_word_kinds"].items()
        }
        """Everyday word -> the types it names ("lamp" -> DeskLamp, FloorLamp), nearest kin first."""
        self.enclosing: frozenset[str] = frozenset(data["enclosing"])
        """Receptacles whose contents sit behind a door (Fridge, Microwave, Cabinet, Drawer, Safe, Box):
        putting in and taking out need them open."""
        self.initially_open: frozenset[str] = frozenset(data["initially_open"])
        """Containers that stand open until seen otherwise (AI2-THOR's boxes)."""
        self.controls: dict[str, tuple[str, ...]] = {k: tuple(v) for k, v in data["controls"].items()}
        """Controller -> what it switches: Faucet -> SinkBasin (water), StoveKnob -> StoveBurner."""
        self._surfaces: dict[str, tuple[str, ...]] = {
            purpose: tuple(entry["types"]) for purpose, entry in data["surfaces"].items()
        }
        self.pour_basins: frozenset[str] = frozenset(data["pour_basins"])
        """Where liquid may be poured out besides into a fillable object (a sink, a tub)."""
        self.water_carriers: tuple[str, ...] = tuple(data["water_carriers"])
        """Containers that carry water to a plant or a pour, preferred first."""
        self.appliance_vessels: dict[str, str] = dict(data["appliance_vessels"])
        """Appliance -> the one kind of vessel it works on (CoffeeMachine -> Mug)."""
        names = data["names"]
        self._any_names: dict[str, str] = {_key(k): v for k, v in names["any"].items()}
        self._place_names: dict[str, str] = {_key(k): v for k, v in names["place"].items()}
        self._place_types: dict[str, str] = dict(names["place_types"])
        self._canonical: dict[str, str] = {_key(t): t for t in self.types}
        self._check_consistency()

    def _check_consistency(self) -> None:
        """Fail at load time, naming the entry, if the table contradicts itself."""
        named = (
            [*self._any_names.values(), *self._place_names.values(), *self._place_types.values()]
            + [t for objs in self._accepts.values() for t in objs]
            + list(self._accepts)
            + list(self.slicing_tools)
            + [t for kinds in self.one_word_kinds.values() for t in kinds]
            + list(self.enclosing)
            + list(self.initially_open)
            + [t for controller, targets in self.controls.items() for t in (controller, *targets)]
            + [t for types in self._surfaces.values() for t in types]
            + [*self.pour_basins, *self.water_carriers]
            + [t for pair in self.appliance_vessels.items() for t in pair]
        )
        if set(self._surfaces) != set(get_args(SurfacePurpose)):
            raise ValueError(
                f"ontology.json 'surfaces' has {sorted(self._surfaces)}; expected {get_args(SurfacePurpose)}"
            )
        for t in named:
            if t not in self._info:
                raise ValueError(f"ontology.json names {t!r}, which is not in its 'types'")
        for name in self.enclosing:
            if not (self._info[name].openable and self._info[name].receptacle):
                raise ValueError(f"enclosing {name!r} must be an openable receptacle")
        for receptacle, objects in self._accepts.items():
            if not self._info[receptacle].receptacle:
                raise ValueError(f"{receptacle!r} accepts objects but is not marked receptacle")
            for obj in objects:
                if not self._info[obj].pickupable:
                    raise ValueError(f"{receptacle!r} accepts {obj!r}, which is not pickupable")

    def surfaces(self, purpose: SurfacePurpose) -> tuple[str, ...]:
        """The open surfaces used for ``purpose``, in the data's order (ontology.json says why each list
        differs): ``put_down`` frees the hand, ``spare`` takes things aside for a moment, ``spread_out`` are
        too long to reach at once, ``lamp_hosts`` may hold a desk lamp."""
        return self._surfaces[purpose]

    def get(self, object_type: str) -> ObjectTypeInfo:
        """Facts of an exact canonical type name; UnknownObjectType (with suggestions) otherwise."""
        info = self._info.get(object_type)
        if info is None:
            raise UnknownObjectType(object_type, self._suggest(object_type))
        return info

    def __contains__(self, object_type: object) -> bool:
        return object_type in self._info

    def resolve(self, name: str, purpose: Purpose = "any") -> str:
        """The canonical type a person means by ``name``.

        Tolerates case, separators, articles and plurals ("the Coffee Mugs" -> Mug), and the words people
        use ("fridge" -> Fridge, "stove" -> StoveBurner, "table" -> DiningTable, "toast" -> BreadSliced,
        "slice of tomato" -> TomatoSliced). With ``purpose="place"`` names of fixtures whose basin receives
        objects resolve to the basin ("sink" -> SinkBasin), because AI2-THOR puts objects in the SinkBasin;
        otherwise "sink" is the Sink itself.
        """
        if purpose == "any" and name in self._info:
            return name  # a canonical name (every segmentation legend entry, every step): no parsing
        phrase = _words(name)
        found = self._lookup(phrase, purpose) if phrase else None
        if found is None:
            raise UnknownObjectType(name, self._suggest(name))
        return self._place_types.get(found, found) if purpose == "place" else found

    def _lookup(self, phrase: str, purpose: Purpose) -> str | None:
        for form in _singulars(phrase):
            key = _key(form)
            if purpose == "place" and key in self._place_names:
                return self._place_names[key]
            if key in self._canonical:
                return self._canonical[key]
            if key in self._any_names:
                return self._any_names[key]
        for pattern in _SLICE_PATTERNS:
            match = pattern.match(phrase)
            if match:
                whole = self._lookup(match["x"], "any")
                if whole is not None:
                    return self._info[whole].sliced_into or (whole if self._info[whole].sliced_from else None)
        return None

    def _suggest(self, name: str) -> tuple[str, ...]:
        key = _key(name)
        vocabulary = {**self._any_names, **self._canonical}
        close = difflib.get_close_matches(key, list(vocabulary), n=3 * _MAX_SUGGESTIONS, cutoff=0.6)
        if len(key) >= 3:
            close += [k for k in vocabulary if (key in k or k in key) and k not in close]
        suggestions = dict.fromkeys(vocabulary[k] for k in close)
        return tuple(suggestions)[:_MAX_SUGGESTIONS]

    def accepts(self, receptacle: str, obj: str) -> bool:
        """Whether ``obj`` may be put in or on ``receptacle`` (both canonical types)."""
        self.get(receptacle)
        self.get(obj)
        return obj in self._accepts.get(receptacle, frozenset())

    def may_hold(self, receptacle: str, obj: str) -> bool:
        """Whether ``obj`` may lie in or on ``receptacle`` directly or inside a movable receptacle that it
        accepts: a potato in a bowl in a cabinet (a Cabinet does not accept a Potato itself)."""
        if self.accepts(receptacle, obj):
            return True
        return any(
            self.get(middle).pickupable and self.accepts(receptacle, middle)
            for middle in self.receptacles_for(obj)
        )

    def accepted_by(self, receptacle: str) -> tuple[str, ...]:
        """Every type ``receptacle`` accepts, sorted."""
        self.get(receptacle)
        return tuple(sorted(self._accepts.get(receptacle, frozenset())))

    def receptacles_for(self, obj: str) -> tuple[str, ...]:
        """Every receptacle type that accepts ``obj``, sorted."""
        self.get(obj)
        return self._receptacles_for[obj]

    def same_place(self, a: str, b: str) -> bool:
        """Whether reaching one of two types reaches the other: a Sink and its SinkBasin, a Faucet and the
        basin it runs into, a StoveKnob and its StoveBurner, a whole object and its slices."""
        if a == b:
            return True
        pairs = {(a, b), (b, a)}
        return any(
            (x in self.controls and y in self.controls[x])
            or self._place_types.get(x) == y
            or self._info[x].sliced_into == y
            for x, y in pairs
            if x in self._info
        )

    def kin(self, object_type: str) -> tuple[str, ...]:
        """The other types an everyday word for ``object_type`` also names, nearest first: where the word
        was "lamp" and the planner wrote DeskLamp, the room may hold only a FloorLamp."""
        kin = [k for kinds in self.one_word_kinds.values() if object_type in kinds for k in kinds]
        return tuple(k for k in dict.fromkeys(kin) if k != object_type)

    def has_class(self, object_type: str, cls: str) -> bool:
        """TEACh simbotObjectClass membership; a type is always a member of its own class."""
        return cls in self.get(object_type).classes

    def types_with_class(self, cls: str) -> tuple[str, ...]:
        """Every type whose simbotObjectClass includes ``cls`` (TEACh task parameters such as 'Tables')."""
        return tuple(t for t in self.types if cls in self._info[t].classes)


@functools.cache
def load_ontology() -> Ontology:
    """The project's ontology, read once from the package data file ``symbolic/ontology.json``."""
    text = resources.files(__package__ or "symbolic").joinpath("ontology.json").read_text(encoding="utf-8")
    return Ontology(json.loads(text))
