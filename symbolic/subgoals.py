"""Subgoals ``(action, object type)``: the text grammar of DESIGN.md §5 and the actions-to-subgoals rule.

The JARVIS seed (Sec. "Language Planning", Alg. 2 lines 47-55) turns an action sequence into subgoals:
an interaction on object O becomes ``Action O`` and a run of navigation actions becomes ``Navigate`` plus
the object of the next interaction. TEACh's ``history_subgoals``/``future_subgoals`` were made the same way
and are stored as flat word lists (``["Navigate", "Knife", "Pickup", "Knife"]``).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum

from symbolic.ontology import Ontology, Purpose
from symbolic.thor import MOTION_ACTIONS


class SubgoalAction(StrEnum):
    """The nine subgoal actions: Navigate plus TEACh's eight object interactions."""

    NAVIGATE = "Navigate"
    PICKUP = "Pickup"
    PLACE = "Place"
    OPEN = "Open"
    CLOSE = "Close"
    TOGGLE_ON = "ToggleOn"
    TOGGLE_OFF = "ToggleOff"
    SLICE = "Slice"
    POUR = "Pour"


INTERACTIONS: frozenset[SubgoalAction] = frozenset(SubgoalAction) - {SubgoalAction.NAVIGATE}
"""Subgoal actions that act on an object (all but Navigate)."""


@dataclass(frozen=True, order=True)
class Subgoal:
    """One step of a plan, e.g. ``Subgoal(SubgoalAction.SLICE, "Bread")``; objects are canonical types."""

    action: SubgoalAction
    obj: str

    def __str__(self) -> str:
        return f"{self.action.value} {self.obj}"


class SubgoalSyntaxError(ValueError):
    """A plan that does not parse; the message says which item and what was expected there."""


ACTION_NAME_FOR_SUBGOAL: dict[SubgoalAction, str] = {
    SubgoalAction.PICKUP: "Pickup",
    SubgoalAction.PLACE: "Place",
    SubgoalAction.OPEN: "Open",
    SubgoalAction.CLOSE: "Close",
    SubgoalAction.TOGGLE_ON: "ToggleOn",
    SubgoalAction.TOGGLE_OFF: "ToggleOff",
    SubgoalAction.SLICE: "Slice",
    SubgoalAction.POUR: "Pour",
}
"""TEACh driver action that executes each interaction subgoal (Navigate is carried out by motion actions)."""

_SUBGOAL_FOR_TEACH_ACTION = {name: action for action, name in ACTION_NAME_FOR_SUBGOAL.items()}

_SUBGOAL_FOR_ALFRED_ACTION: dict[str, SubgoalAction] = {
    "PickupObject": SubgoalAction.PICKUP,
    "PutObject": SubgoalAction.PLACE,
    "OpenObject": SubgoalAction.OPEN,
    "CloseObject": SubgoalAction.CLOSE,
    "ToggleObjectOn": SubgoalAction.TOGGLE_ON,
    "ToggleObjectOff": SubgoalAction.TOGGLE_OFF,
    "SliceObject": SubgoalAction.SLICE,
}
"""ALFRED ``api_action.action`` of each interaction (ALFRED has no Pour)."""

ALFRED_NAVIGATION_ACTIONS: frozenset[str] = frozenset(
    {"MoveAhead", "MoveBack", "MoveLeft", "MoveRight", "RotateLeft", "RotateRight", "LookUp", "LookDown"}
)
"""ALFRED ``api_action`` names that move the body or the camera."""

_ACTION_ALIASES: dict[str, SubgoalAction] = {
    **{action.value.lower(): action for action in SubgoalAction},
    "goto": SubgoalAction.NAVIGATE,
    "goto location": SubgoalAction.NAVIGATE,
    "gotolocation": SubgoalAction.NAVIGATE,
    "go": SubgoalAction.NAVIGATE,
    "moveto": SubgoalAction.NAVIGATE,
    "find": SubgoalAction.NAVIGATE,
    "pickupobject": SubgoalAction.PICKUP,
    "pick": SubgoalAction.PICKUP,
    "pickup": SubgoalAction.PICKUP,
    "take": SubgoalAction.PICKUP,
    "grab": SubgoalAction.PICKUP,
    "get": SubgoalAction.PICKUP,
    "put": SubgoalAction.PLACE,
    "putobject": SubgoalAction.PLACE,
    "putdown": SubgoalAction.PLACE,
    "openobject": SubgoalAction.OPEN,
    "closeobject": SubgoalAction.CLOSE,
    "turnon": SubgoalAction.TOGGLE_ON,
    "switchon": SubgoalAction.TOGGLE_ON,
    "toggleobjecton": SubgoalAction.TOGGLE_ON,
    "turnoff": SubgoalAction.TOGGLE_OFF,
    "switchoff": SubgoalAction.TOGGLE_OFF,
    "toggleobjectoff": SubgoalAction.TOGGLE_OFF,
    "cut": SubgoalAction.SLICE,
    "sliceobject": SubgoalAction.SLICE,
    "pourobject": SubgoalAction.POUR,
}
"""Action spellings accepted by ``parse_subgoals``, keyed by lower-case words joined without spaces."""

_FILLER_WORDS = frozenset({"to", "into", "in", "on", "onto", "at", "up", "down", "it", "the", "a", "an"})
_MAX_ACTION_WORDS = 3
_ITEM_SEPARATORS = re.compile(r"[,;\n]+")


def _action_at(words: Sequence[str], start: int) -> tuple[SubgoalAction, int] | None:
    """The action spelled by the words at ``start`` (longest match) and how many words it takes."""
    for length in range(min(_MAX_ACTION_WORDS, len(words) - start), 0, -1):
        key = "".join(words[start : start + length]).lower()
        if key in _ACTION_ALIASES:
            return _ACTION_ALIASES[key], length
    return None


def _action_of(text: str, where: str) -> SubgoalAction:
    words = text.split()
    found = _action_at(words, 0) if words else None
    if found is None or found[1] != len(words):
        raise SubgoalSyntaxError(f"{where}: expected an action ({', '.join(SubgoalAction)}), got {text!r}")
    return found[0]


def _resolve(ontology: Ontology, action: SubgoalAction, obj: object, where: str) -> Subgoal:
    if not isinstance(obj, str) or not obj.strip():
        raise SubgoalSyntaxError(f"{where}: expected an object type after {action.value}, got {obj!r}")
    words = obj.split()
    while words and words[0].lower() in _FILLER_WORDS:
        words = words[1:]
    if not words:
        raise SubgoalSyntaxError(f"{where}: expected an object type after {action.value}, got {obj!r}")
    purpose: Purpose = "place" if action is SubgoalAction.PLACE else "any"
    return Subgoal(action, ontology.resolve(" ".join(words), purpose))


def _parse_text_item(item: str, where: str, ontology: Ontology) -> list[Subgoal]:
    """One comma-separated item; several subgoals may share it ("Navigate Knife Pickup Knife")."""
    words = item.split()
    first = _action_at(words, 0)
    if first is None:
        raise SubgoalSyntaxError(f"{where}: expected an action ({', '.join(SubgoalAction)}), got {item!r}")
    subgoals: list[Subgoal] = []
    action, start = first[0], first[1]
    cursor = start
    while cursor <= len(words):
        nxt = _action_at(words, cursor) if cursor > start and cursor < len(words) else None
        if nxt is not None or cursor == len(words):
            subgoals.append(_resolve(ontology, action, " ".join(words[start:cursor]), where))
            if nxt is None:
                break
            action, start = nxt[0], cursor + nxt[1]
            cursor = start
        else:
            cursor += 1
    return subgoals


def _parse_text(source: str, ontology: Ontology) -> list[Subgoal]:
    items = [item.strip() for item in _ITEM_SEPARATORS.split(source)]
    subgoals: list[Subgoal] = []
    for number, item in enumerate(items, start=1):
        if item:
            subgoals += _parse_text_item(item, f"subgoal {number} ({item!r})", ontology)
    return subgoals


def _is_bare_action(item: object) -> bool:
    if not isinstance(item, str):
        return False
    words = item.split()
    found = _action_at(words, 0) if words else None
    return found is not None and found[1] == len(words)


def _parse_word_list(words: Sequence[str], ontology: Ontology) -> list[Subgoal]:
    """TEACh's flat history_subgoals form: action, object, action, object, ..."""
    if len(words) % 2:
        raise SubgoalSyntaxError(
            f"word {len(words) - 1} ({words[-1]!r}): a flat subgoal list alternates action and object, "
            f"but it has an odd number ({len(words)}) of words"
        )
    return [
        _resolve(ontology, _action_of(words[i], f"word {i}"), words[i + 1], f"word {i + 1}")
        for i in range(0, len(words), 2)
    ]


def _parse_entry(entry: object, where: str, ontology: Ontology) -> list[Subgoal]:
    if isinstance(entry, Subgoal):
        return [_resolve(ontology, entry.action, entry.obj, where)]
    if isinstance(entry, str):
        return _parse_text_item(entry, where, ontology)
    if isinstance(entry, Mapping):
        action = entry.get("action")
        obj = entry.get("object", entry.get("obj"))
        if not isinstance(action, str):
            raise SubgoalSyntaxError(f"{where}: expected a mapping with 'action' and 'object', got {entry!r}")
        return [_resolve(ontology, _action_of(action, where), obj, where)]
    if isinstance(entry, Sequence) and len(entry) == 2 and isinstance(entry[0], str):
        return [_resolve(ontology, _action_of(entry[0], where), entry[1], where)]
    raise SubgoalSyntaxError(
        f"{where}: expected 'Action Object', {{'action': .., 'object': ..}} or [action, object], "
        f"got {entry!r}"
    )


def parse_subgoals(source: str | Sequence[object], ontology: Ontology) -> list[Subgoal]:
    """Parse a plan given in any of the forms people and models produce.

    Accepted: text ``"Navigate Knife, Pickup Knife"`` (items separated by commas, semicolons or newlines);
    TEACh flat word lists ``["Navigate", "Knife", "Pickup", "Knife"]``; lists of ``"Navigate Knife"``
    strings; lists of ``{"action": .., "object": ..}``; lists of ``[action, object]`` pairs. Actions are
    case-insensitive with aliases (PickUp, Put -> Place, TurnOn -> ToggleOn, Cut -> Slice, GoTo ->
    Navigate); objects go through ``ontology.resolve`` (Place uses purpose "place", so "sink" ->
    SinkBasin). Raises SubgoalSyntaxError (where, what was expected) or UnknownObjectType.
    """
    if isinstance(source, str):
        return _parse_text(source, ontology)
    entries = list(source)
    if entries and all(isinstance(e, str) for e in entries) and _is_bare_action(entries[0]):
        return _parse_word_list([str(e) for e in entries], ontology)
    subgoals: list[Subgoal] = []
    for index, entry in enumerate(entries):
        subgoals += _parse_entry(entry, f"item {index}", ontology)
    return subgoals


def format_subgoals(subgoals: Sequence[Subgoal]) -> str:
    """DESIGN.md §5 text form: ``"Navigate Knife, Pickup Knife"``."""
    return ", ".join(str(subgoal) for subgoal in subgoals)


def to_teach_words(subgoals: Sequence[Subgoal]) -> list[str]:
    """TEACh's flat ``history_subgoals`` form: ``["Navigate", "Knife", "Pickup", "Knife"]``."""
    return [word for subgoal in subgoals for word in (subgoal.action.value, subgoal.obj)]


def object_type_of_id(object_id: str) -> str:
    """AI2-THOR object id -> type: ``Knife|+1.00|+0.90|-0.50`` -> Knife.

    Pieces and basins carry their own type in a fifth segment: ``Bread|..|BreadSliced_1`` -> BreadSliced,
    ``Sink|..|SinkBasin`` -> SinkBasin.
    """
    parts = object_id.split("|")
    if len(parts) > 4 and parts[-1]:
        return parts[-1].split("_")[0]
    return parts[0]


def _coalesce(steps: Sequence[tuple[SubgoalAction | None, str | None]]) -> list[Subgoal]:
    """JARVIS Alg. 2 lines 47-55: ``(None, None)`` marks a navigation step, others are interactions."""
    subgoals: list[Subgoal] = []
    need_nav = False
    for action, obj in steps:
        if action is None:
            need_nav = True
            continue
        if obj is None:
            continue
        if need_nav:
            subgoals.append(Subgoal(SubgoalAction.NAVIGATE, obj))
        subgoals.append(Subgoal(action, obj))
        need_nav = False
    return subgoals


def subgoals_from_teach_actions(actions: Sequence[Mapping[str, object]]) -> list[Subgoal]:
    """Subgoals of TEACh ``driver_action_history``/``driver_actions_future`` entries.

    Motion actions (Forward, Turn, Look, Pan, Backward) form a run that becomes ``Navigate`` + the object of
    the next interaction; each interaction with an ``oid`` becomes ``Action Type``. Text, Stop and other
    actions are ignored, as are interactions without an object id.
    """
    steps: list[tuple[SubgoalAction | None, str | None]] = []
    for entry in actions:
        name = entry.get("action_name")
        if name in MOTION_ACTIONS:
            steps.append((None, None))
        elif isinstance(name, str) and name in _SUBGOAL_FOR_TEACH_ACTION:
            oid = entry.get("oid")
            obj = object_type_of_id(oid) if isinstance(oid, str) and oid else None
            steps.append((_SUBGOAL_FOR_TEACH_ACTION[name], obj))
    return _coalesce(steps)


def subgoals_from_alfred_low_actions(low_actions: Sequence[Mapping[str, object]]) -> list[Subgoal]:
    """Subgoals of ALFRED ``plan.low_actions`` (each entry's ``api_action``, or the api_action itself).

    MoveAhead/Rotate*/Look* are navigation; PutObject's target is its ``receptacleObjectId`` (``Place
    <receptacle type>``), the other interactions' is ``objectId``.
    """
    steps: list[tuple[SubgoalAction | None, str | None]] = []
    for entry in low_actions:
        api = entry.get("api_action", entry)
        if not isinstance(api, Mapping):
            raise SubgoalSyntaxError(f"expected an ALFRED low action with 'api_action', got {entry!r}")
        name = api.get("action")
        if name in ALFRED_NAVIGATION_ACTIONS:
            steps.append((None, None))
        elif isinstance(name, str) and name in _SUBGOAL_FOR_ALFRED_ACTION:
            action = _SUBGOAL_FOR_ALFRED_ACTION[name]
            key = "receptacleObjectId" if action is SubgoalAction.PLACE else "objectId"
            oid = api.get(key)
            steps.append((action, object_type_of_id(oid) if isinstance(oid, str) and oid else None))
    return _coalesce(steps)
