"""TEACh's task definitions: loading them, naming task instances, and writing parameters into them.

A task definition (TEACh ``task_definitions/*.json``) is a set of *components* and *relations*. A
component either selects objects (a determiner ``a``/``all``/``N``/``#k``, a ``primary_condition`` that
picks candidates, and property conditions) or names a sub-task with parameters and a determiner saying
how many instances are needed. A relation (only ``parentReceptacles`` in the benchmark) asks head
components' objects to sit in a tail component's object. Parameters ``#k`` are written in the way
TEACh's ``Task_THOR.write_task_params`` does (alexa/teach, ``src/teach/dataset/task_THOR.py``).
"""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.tasks.progress import ConditionValue
from symbolic.data_dir import default_data_dir

BENCHMARK_TASKS: tuple[str, ...] = (
    "Water Plant",
    "Coffee",
    "Clean All X",
    "Put All X On Y",
    "Boil X",
    "Plate Of Toast",
    "N Slices Of X In Y",
    "Put All X In One Y",
    "N Cooked Slices Of X In Y",
    "Sandwich",
    "Salad",
    "Breakfast",
)
"""The 12 task types of the TEACh benchmark (EDH, TfD and TATC instances are cut from games of these)."""

PACKAGED_DEFINITIONS = Path(__file__).with_name("teach_tasks.json")
"""Our restatement of the benchmark definitions, used when the shared data directory is absent."""


@dataclass(frozen=True)
class ObjectComponent:
    """Objects a task needs: ``determiner`` of them satisfying ``conditions`` (read-only mappings)."""

    determiner: str
    primary_condition: str
    instance_shareable: bool
    """True when one object may serve every instance (the Sink that every Clean X uses)."""
    conditions: Mapping[str, ConditionValue]
    condition_failure_descs: Mapping[str, str]


@dataclass(frozen=True)
class SubtaskComponent:
    """``determiner`` instances of another task, e.g. "#0" x Sliced X(Tomato)."""

    determiner: str
    task_name: str
    task_params: tuple[str, ...]


Component = ObjectComponent | SubtaskComponent


@dataclass(frozen=True)
class Relation:
    """Head components' objects must have a tail component's object in ``property`` (parentReceptacles)."""

    property: str
    head_entities: tuple[str, ...]
    head_determiners: tuple[str, ...]
    tail_entity: str
    tail_determiner: str
    failure_desc: str


@dataclass(frozen=True)
class TaskDefinition:
    """One TEACh task definition with ``#k`` parameters still unfilled."""

    task_id: int
    task_name: str
    task_nparams: int
    task_anchor_object: str | None
    """The component whose objects stand for the whole task when a parent task relates it (the plate)."""
    desc: str
    components: Mapping[str, Component]
    relations: tuple[Relation, ...]
    param_notes: Mapping[str, str] = field(default_factory=dict)
    """TEACh's ``comments_task_params``: what each ``#k`` means (Breakfast, Sandwich, Salad)."""


_TEACH_KEYS = {
    "determiner": "determiner",
    "task_name": "task_name",
    "task_params": "task_params",
    "primary_condition": "primary_condition",
    "instance_shareable": "instance_shareable",
    "conditions": "conditions",
    "condition_failure_descs": "condition_failure_descs",
}
"""A component's fields -> their keys in TEACh's ``task_definitions/*.json``."""
_COMPACT_KEYS = {
    **_TEACH_KEYS,
    "determiner": "det",
    "task_name": "task",
    "task_params": "params",
    "primary_condition": "primary",
    "instance_shareable": "shareable",
    "condition_failure_descs": "failure",
}
"""... and in our compact restatement ``teach_tasks.json``."""
_TEACH_TASK_KEYS = {
    "task_id": "task_id",
    "task_name": "task_name",
    "task_nparams": "task_nparams",
    "task_anchor_object": "task_anchor_object",
    "param_notes": "comments_task_params",
}
"""A task's own fields -> their keys in TEACh's ``task_definitions/*.json`` ..."""
_COMPACT_TASK_KEYS = {
    "task_id": "id",
    "task_name": "name",
    "task_nparams": "nparams",
    "task_anchor_object": "anchor",
    "param_notes": "param_notes",
}
"""... and in ``teach_tasks.json``."""


def _component(comp: Mapping[str, Any], keys: Mapping[str, str]) -> Component:
    """A sub-task component (it names a task) or an object component, read with either file's keys."""
    if keys["task_name"] in comp:
        return SubtaskComponent(
            determiner=comp[keys["determiner"]],
            task_name=comp[keys["task_name"]],
            task_params=tuple(comp[keys["task_params"]]),
        )
    return ObjectComponent(
        determiner=comp[keys["determiner"]],
        primary_condition=comp[keys["primary_condition"]],
        instance_shareable=comp[keys["instance_shareable"]],
        conditions=dict(comp[keys["conditions"]]),
        condition_failure_descs=dict(comp[keys["condition_failure_descs"]]),
    )


def definition_from_teach(data: Mapping[str, Any]) -> TaskDefinition:
    """Parse one of TEACh's ``task_definitions/*.json`` files."""
    components = {key: _component(comp, _TEACH_KEYS) for key, comp in data["components"].items()}
    relations = []
    for rel in data["relations"]:
        if len(rel["tail_entity_list"]) != 1:
            raise ValueError(f"task {data['task_name']!r}: TEACh relations have exactly one tail entity")
        relations.append(
            Relation(
                property=rel["property"],
                head_entities=tuple(rel["head_entity_list"]),
                head_determiners=tuple(rel["head_determiner_list"]),
                tail_entity=rel["tail_entity_list"][0],
                tail_determiner=rel["tail_determiner_list"][0],
                failure_desc=rel["failure_desc"],
            )
        )
    return _definition(data, _TEACH_TASK_KEYS, components, relations)


def definition_from_compact(data: Mapping[str, Any]) -> TaskDefinition:
    """Parse one task of our compact restatement ``teach_tasks.json`` (its ``format`` field says the keys)."""
    components = {key: _component(comp, _COMPACT_KEYS) for key, comp in data["components"].items()}
    relations = tuple(
        Relation(
            property=rel["property"],
            head_entities=tuple(entity for entity, _ in rel["heads"]),
            head_determiners=tuple(det for _, det in rel["heads"]),
            tail_entity=rel["tail"][0],
            tail_determiner=rel["tail"][1],
            failure_desc=rel["failure"],
        )
        for rel in data["relations"]
    )
    return _definition(data, _COMPACT_TASK_KEYS, components, relations)


def _definition(
    data: Mapping[str, Any],
    keys: Mapping[str, str],
    components: Mapping[str, Component],
    relations: Sequence[Relation],
) -> TaskDefinition:
    """The definition of a task read with either file's keys (components and relations already parsed)."""
    return TaskDefinition(
        task_id=int(data[keys["task_id"]]),
        task_name=data[keys["task_name"]],
        task_nparams=int(data[keys["task_nparams"]]),
        task_anchor_object=data[keys["task_anchor_object"]],
        desc=data["desc"],
        components=components,
        relations=tuple(relations),
        param_notes=dict(data.get(keys["param_notes"], {})),
    )


@functools.cache
def _definitions_in(directory: Path | None) -> tuple[TaskDefinition, ...]:
    """All definitions of a TEACh ``task_definitions`` folder, or of our restatement when ``None``."""
    if directory is None:
        tasks = json.loads(PACKAGED_DEFINITIONS.read_text(encoding="utf-8"))["tasks"]
        definitions = tuple(definition_from_compact(t) for t in tasks)
    else:
        files = sorted(directory.glob("*.json"))
        definitions = tuple(definition_from_teach(json.loads(f.read_text(encoding="utf-8"))) for f in files)
    _check_resolvable(definitions)
    return definitions


def _check_resolvable(definitions: Sequence[TaskDefinition]) -> None:
    """TEACh refuses task files whose sub-tasks are undefined; so do we, naming them."""
    names = {d.task_name for d in definitions}
    missing = sorted(
        f"{c.task_name!r} (in {d.task_name!r})"
        for d in definitions
        for c in d.components.values()
        if isinstance(c, SubtaskComponent) and c.task_name not in names
    )
    if missing:
        raise ValueError(f"undefined sub-tasks: {', '.join(missing)}; known tasks: {sorted(names)}")


def _index_definitions(definitions: Iterable[TaskDefinition]) -> dict[str, TaskDefinition]:
    indexed: dict[str, TaskDefinition] = {}
    for definition in definitions:
        indexed[definition.task_name] = definition
        indexed[str(definition.task_id)] = definition
    return indexed


def load_task_definitions(data_dir: Path | None = None) -> dict[str, TaskDefinition]:
    """TEACh's definitions keyed by name *and* by ``str(task_id)``.

    Read from ``<data_dir>/teach/task_definitions`` when that folder exists (default data dir:
    ``symbolic.data_dir``), else from our packaged restatement of the 12 benchmark tasks and their
    components, so a fresh checkout still checks goals.
    """
    folder = (data_dir or default_data_dir()) / "teach" / "task_definitions"
    return _index_definitions(_definitions_in(folder if folder.is_dir() else None))


def load_packaged_task_definitions() -> dict[str, TaskDefinition]:
    """Our restatement only (``teach_tasks.json``), whatever the data directory holds."""
    return _index_definitions(_definitions_in(None))


def get_definition(name_or_id: str | int, definitions: Mapping[str, TaskDefinition]) -> TaskDefinition:
    """A definition by name or id; an unknown one is an error listing the known names."""
    try:
        return definitions[str(name_or_id)]
    except KeyError:
        known = sorted({d.task_name for d in definitions.values()})
        raise KeyError(f"unknown TEACh task {name_or_id!r}; known tasks: {known}") from None


@dataclass(frozen=True)
class TaskInstance:
    """A task with its parameters, as a TEACh game's ``tasks[0]`` names it."""

    task_name: str
    task_id: int
    params: tuple[str, ...] = ()

    def describe(self, definitions: Mapping[str, TaskDefinition] | None = None) -> str:
        """The definition's ``desc`` with parameters filled: "Serve 2 slice(s) of Tomato on a Plate."."""
        return bind_task(self, definitions).desc

    def to_game_task(self, definitions: Mapping[str, TaskDefinition] | None = None) -> dict[str, Any]:
        """The game file's ``tasks[0]`` fields (without ``episodes`` content), parameters written in."""
        return _bound_to_teach_dict(bind_task(self, definitions))

    @classmethod
    def from_game_task(cls, task: Mapping[str, Any]) -> TaskInstance:
        """Read ``tasks[0]`` of a TEACh game file (or a TfD instance's task)."""
        return cls(
            task_name=task["task_name"], task_id=int(task["task_id"]), params=tuple(task["task_params"])
        )


def _check_param_count(definition: TaskDefinition, params: Sequence[str]) -> None:
    if len(params) != definition.task_nparams:
        raise ValueError(
            f"task {definition.task_name!r} takes {definition.task_nparams} params, "
            f"got {len(params)}: {list(params)}"
        )


def make_task_instance(
    name_or_id: str | int, params: Sequence[str] = (), definitions: Mapping[str, TaskDefinition] | None = None
) -> TaskInstance:
    """A validated instance: the task exists and gets exactly ``task_nparams`` parameters."""
    definition = get_definition(name_or_id, definitions or load_task_definitions())
    _check_param_count(definition, params)
    return TaskInstance(definition.task_name, definition.task_id, tuple(str(p) for p in params))


@dataclass(frozen=True)
class BoundObjects:
    """An object component of a bound task, under its (filled) component key."""

    key: str
    component: ObjectComponent

    @property
    def determiner(self) -> str:
        return self.component.determiner


@dataclass(frozen=True)
class BoundSubtask:
    """A sub-task component of a bound task: ``determiner`` instances of ``task``."""

    key: str
    determiner: str
    task: BoundTask


@dataclass(frozen=True)
class BoundTask:
    """A definition with every ``#k`` replaced, sub-tasks bound recursively (TEACh's write_task_params)."""

    definition: TaskDefinition
    params: tuple[str, ...]
    desc: str
    anchor: str | None
    components: tuple[BoundObjects | BoundSubtask, ...]
    relations: tuple[Relation, ...]


def _fill(text: str, params: Sequence[str]) -> str:
    """Replace ``#k`` by params[k], highest k first so "#13" is not read as "#1" + "3" (as TEACh does)."""
    for idx in range(len(params) - 1, -1, -1):
        text = text.replace(f"#{idx}", params[idx])
    return text


def _fill_condition(value: ConditionValue, params: Sequence[str]) -> ConditionValue:
    """Filled values that become numeric are simulator property values, hence ints (TEACh's rule)."""
    if not isinstance(value, str):
        return value
    filled = _fill(value, params)
    return int(filled) if filled.isnumeric() else filled


def bind_task(task: TaskInstance, definitions: Mapping[str, TaskDefinition] | None = None) -> BoundTask:
    """Write a task instance's parameters into its definition and its sub-tasks."""
    definitions = definitions or load_task_definitions()
    return _bind(get_definition(task.task_name, definitions), task.params, definitions)


def _bind(
    definition: TaskDefinition, params: Sequence[str], definitions: Mapping[str, TaskDefinition]
) -> BoundTask:
    _check_param_count(definition, params)
    components: list[BoundObjects | BoundSubtask] = []
    for key, comp in definition.components.items():
        if isinstance(comp, SubtaskComponent):
            sub_params = tuple(_fill(p, params) for p in comp.task_params)
            sub = _bind(get_definition(comp.task_name, definitions), sub_params, definitions)
            components.append(BoundSubtask(_fill(key, params), _fill(comp.determiner, params), sub))
        else:
            bound = ObjectComponent(
                determiner=_fill(comp.determiner, params),
                primary_condition=_fill(comp.primary_condition, params),
                instance_shareable=comp.instance_shareable,
                conditions={_fill(k, params): _fill_condition(v, params) for k, v in comp.conditions.items()},
                condition_failure_descs={
                    _fill(k, params): _fill(v, params) for k, v in comp.condition_failure_descs.items()
                },
            )
            components.append(BoundObjects(_fill(key, params), bound))
    relations = tuple(
        Relation(
            property=rel.property,
            head_entities=tuple(_fill(e, params) for e in rel.head_entities),
            head_determiners=tuple(_fill(d, params) for d in rel.head_determiners),
            tail_entity=_fill(rel.tail_entity, params),
            tail_determiner=_fill(rel.tail_determiner, params),
            failure_desc=_fill(rel.failure_desc, params),
        )
        for rel in definition.relations
    )
    anchor = definition.task_anchor_object
    return BoundTask(
        definition=definition,
        params=tuple(params),
        desc=_fill(definition.desc, params),
        anchor=_fill(anchor, params) if anchor is not None else None,
        components=tuple(components),
        relations=relations,
    )


def _bound_to_teach_dict(task: BoundTask) -> dict[str, Any]:
    """TEACh's ``Task_THOR.to_dict`` layout for a bound task (sub-tasks nested under ``task``)."""
    components: dict[str, Any] = {}
    for comp in task.components:
        if isinstance(comp, BoundSubtask):
            components[comp.key] = {
                "determiner": comp.determiner,
                "task_name": comp.task.definition.task_name,
                "task_params": list(comp.task.params),
                "task": _bound_to_teach_dict(comp.task),
            }
        else:
            c = comp.component
            components[comp.key] = {
                "determiner": c.determiner,
                "primary_condition": c.primary_condition,
                "instance_shareable": c.instance_shareable,
                "conditions": dict(c.conditions),
                "condition_failure_descs": dict(c.condition_failure_descs),
            }
    return {
        "task_id": task.definition.task_id,
        "task_name": task.definition.task_name,
        "task_params": list(task.params),
        "task_nparams": task.definition.task_nparams,
        "task_anchor_object": task.anchor,
        "desc": task.desc,
        "components": components,
        "relations": [
            {
                "property": rel.property,
                "tail_entity_list": [rel.tail_entity],
                "tail_determiner_list": [rel.tail_determiner],
                "head_entity_list": list(rel.head_entities),
                "head_determiner_list": list(rel.head_determiners),
                "failure_desc": rel.failure_desc,
            }
            for rel in task.relations
        ],
        "comments": "",
        "episodes": [],
    }
