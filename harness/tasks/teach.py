"""TEACh tasks in the harness: the 12 benchmark task types and their goal-condition check on a World.

The definitions and parameter binding live in ``teach_definitions``, TEACh's counting rules in
``teach_checker``; this module is what the rest of the harness uses: name a task, describe it, and count
its goal conditions in a world exactly as TEACh would count them in AI2-THOR. Our world does not store
two properties TEACh's checker reads; they come from the shared ontology: ``simbotObjectClass`` (the
type, its sink/bathtub alias and TEACh's custom_object_classes.json classes, as TEACh's simulator sets
it) and ``receptacle`` (AI2-THOR's static flag).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from harness.tasks.progress import GoalReport, ProblemKey, ProgressStep, SubgoalStatus
from harness.tasks.teach_checker import TYPE_ALIASES, ObjectMetadata, check_bound_task
from harness.tasks.teach_definitions import (
    BENCHMARK_TASKS,
    BoundTask,
    ObjectComponent,
    Relation,
    SubtaskComponent,
    TaskDefinition,
    TaskInstance,
    bind_task,
    get_definition,
    load_packaged_task_definitions,
    load_task_definitions,
    make_task_instance,
)
from harness.world.model import World
from symbolic.ontology import Ontology, UnknownObjectType, load_ontology

__all__ = [
    "BENCHMARK_TASKS",
    "BoundTask",
    "GoalReport",
    "ObjectComponent",
    "ProblemKey",
    "ProgressStep",
    "Relation",
    "SubgoalStatus",
    "SubtaskComponent",
    "TaskDefinition",
    "TaskInstance",
    "bind_task",
    "check_task",
    "check_task_metadata",
    "get_definition",
    "load_packaged_task_definitions",
    "load_task_definitions",
    "make_task_instance",
    "object_classes",
    "with_teach_properties",
]


def object_classes(object_type: str, ontology: Ontology) -> list[str]:
    """TEACh's simbotObjectClass: the type, its sink/bathtub alias, then its custom classes."""
    classes = [object_type]
    if object_type in TYPE_ALIASES:
        classes.append(TYPE_ALIASES[object_type])
    with contextlib.suppress(UnknownObjectType):
        classes += [c for c in ontology.get(object_type).classes if c not in classes]
    return classes


def with_teach_properties(objects: Iterable[ObjectMetadata], ontology: Ontology) -> list[dict[str, Any]]:
    """Copies of the objects with simbotObjectClass and receptacle added where absent."""
    out = []
    for obj in objects:
        full = dict(obj)
        if "simbotObjectClass" not in full:
            full["simbotObjectClass"] = object_classes(full["objectType"], ontology)
        if "receptacle" not in full:
            known = full["objectType"] in ontology
            full["receptacle"] = known and ontology.get(full["objectType"]).receptacle
        out.append(full)
    return out


def check_task_metadata(
    task: TaskInstance | BoundTask,
    objects: Sequence[ObjectMetadata],
    agent_position: tuple[float, float, float] | None = None,
    definitions: Mapping[str, TaskDefinition] | None = None,
) -> GoalReport:
    """Check a task on object metadata (a world's, or a real TEACh game state's objects).

    The objects must carry ``simbotObjectClass`` and ``receptacle`` (see ``with_teach_properties``).
    """
    bound = task if isinstance(task, BoundTask) else bind_task(task, definitions)
    return check_bound_task(bound, objects, agent_position)


def check_task(
    task: TaskInstance,
    world: World,
    definitions: Mapping[str, TaskDefinition] | None = None,
    ontology: Ontology | None = None,
) -> GoalReport:
    """Goal conditions of a TEACh task in a harness world, counted as TEACh counts them."""
    objects = with_teach_properties(world.metadata(), ontology or load_ontology())
    agent = world.agent
    return check_task_metadata(task, objects, (agent.x, agent.camera_height, agent.z), definitions)
