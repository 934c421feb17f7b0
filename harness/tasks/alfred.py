"""ALFRED's 7 task types and their goal conditions, counted as ALFRED's ``env/tasks.py`` counts them.

A task comes from a trajectory's ``task_type`` and ``pddl_params`` (object, parent receptacle, toggle
target, movable receptacle, and whether the object is to be sliced). Each task type's
``goal_conditions_met`` in askforalfred/alfred ``env/tasks.py`` is restated here on a harness World:

- objects are found as ALFRED finds them: the target name is a *substring of the object id* and the
  object has the static property (pickupable, receptacle, toggleable); so "Knife" also finds a
  ButterKnife and "Apple" finds apple slices, as in ALFRED; with ``object_sliced`` the name is
  "<Object>Sliced";
- "in a receptacle" follows the object's receptacle chain (AI2-THOR's parentReceptacles), so an apple in
  a bowl on the counter is on the counter;
- heated, cooled and cleaned are the world's ``is_heated``, ``is_cooled`` and ``is_cleaned`` (ALFRED's
  env keeps sets of objects heated in a microwave, chilled in the fridge and washed in the sink);
- "the lamp is visible" is approximated by the lamp being within AI2-THOR's visibility distance (1.5 m
  from the agent's vertical axis, ``harness.sim.reach``); the field of view is not checked.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from harness.tasks.progress import GoalReport, SubgoalStatus, human_failures
from harness.world.model import World, WorldObject
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import INTERACTION_DISTANCE_M

ALFRED_TASK_TYPES: tuple[str, ...] = (
    "pick_and_place_simple",
    "pick_two_obj_and_place",
    "look_at_obj_in_light",
    "pick_clean_then_place_in_recep",
    "pick_heat_then_place_in_recep",
    "pick_cool_then_place_in_recep",
    "pick_and_place_with_movable_recep",
)
"""ALFRED's task types (object_facts.json ``GOALS``)."""

_SLICED = "Sliced"


@dataclass(frozen=True)
class AlfredTask:
    """One ALFRED goal: its type and ``pddl_params`` (absent targets are None)."""

    task_type: str
    object_target: str
    parent_target: str | None = None
    toggle_target: str | None = None
    mrecep_target: str | None = None
    object_sliced: bool = False

    def __post_init__(self) -> None:
        if self.task_type not in ALFRED_TASK_TYPES:
            raise ValueError(f"unknown ALFRED task type {self.task_type!r}; known: {list(ALFRED_TASK_TYPES)}")
        needed = {
            "look_at_obj_in_light": ("toggle_target",),
            "pick_and_place_with_movable_recep": ("mrecep_target", "parent_target"),
        }.get(self.task_type, ("parent_target",))
        missing = [name for name in needed if not getattr(self, name)]
        if not self.object_target or missing:
            raise ValueError(f"{self.task_type} needs object_target and {list(needed)}; missing: {missing}")

    @property
    def target_name(self) -> str:
        """What ALFRED searches object ids for: "Apple", or "AppleSliced" when the apple is to be sliced."""
        return self.object_target + _SLICED if self.object_sliced else self.object_target

    def describe(self) -> str:
        """A one-sentence goal in the spirit of ALFRED's goal templates."""
        thing = f"slice of {self.object_target}" if self.object_sliced else self.object_target
        things = f"slices of {self.object_target}" if self.object_sliced else f"{self.object_target}s"
        parent, toggle, mrecep = self.parent_target, self.toggle_target, self.mrecep_target
        return {
            "pick_and_place_simple": f"Put a {thing} in a {parent}.",
            "pick_two_obj_and_place": f"Put two {things} in a {parent}.",
            "look_at_obj_in_light": f"Examine a {thing} under the {toggle}.",
            "pick_clean_then_place_in_recep": f"Put a clean {thing} in a {parent}.",
            "pick_heat_then_place_in_recep": f"Put a heated {thing} in a {parent}.",
            "pick_cool_then_place_in_recep": f"Put a cooled {thing} in a {parent}.",
            "pick_and_place_with_movable_recep": f"Put a {thing} in a {mrecep} and it in a {parent}.",
        }[self.task_type]


def alfred_task_from_pddl(pddl_params: Mapping[str, Any], task_type: str | None = None) -> AlfredTask:
    """An AlfredTask from a trajectory's ``pddl_params``; ``task_type`` comes from the trajectory.

    ``pddl_params`` may carry ``task_type`` itself; otherwise pass it (ALFRED stores it beside them).
    Empty strings, as ALFRED writes absent targets, become None.
    """
    kind = task_type or pddl_params.get("task_type")
    if not kind:
        raise ValueError("ALFRED task_type is neither given nor in pddl_params")

    def target(key: str) -> str | None:
        value = pddl_params.get(key)
        return str(value) if value else None

    return AlfredTask(
        task_type=str(kind),
        object_target=str(pddl_params.get("object_target") or ""),
        parent_target=target("parent_target"),
        toggle_target=target("toggle_target"),
        mrecep_target=target("mrecep_target"),
        object_sliced=bool(pddl_params.get("object_sliced", False)),
    )


def alfred_task_from_traj(traj: Mapping[str, Any]) -> AlfredTask:
    """An AlfredTask from a whole ``traj_data.json`` record."""
    return alfred_task_from_pddl(traj["pddl_params"], traj["task_type"])


@dataclass(frozen=True)
class _Condition:
    desc: str
    satisfied: int
    total: int = 1


class _Scene:
    """ALFRED's view of a world: objects by id substring and static property, containment, the hand."""

    def __init__(self, world: World, ontology: Ontology) -> None:
        self.world = world
        self.ontology = ontology

    def named(self, name: str, prop: str) -> list[WorldObject]:
        """ALFRED's get_objects_with_name_and_prop: ``name`` in the object id and the property set."""
        return [
            o
            for o in self.world.objects.values()
            if name in o.object_id
            and o.object_type in self.ontology
            and getattr(self.ontology.get(o.object_type), prop)
        ]

    def is_in(self, obj: WorldObject, receptacle: WorldObject) -> bool:
        return receptacle.object_id in self.world.parent_chain(obj.object_id)

    def held_id(self) -> str | None:
        return self.world.agent.held

    def reach_distance(self, obj: WorldObject) -> float:
        """Metres from the agent's vertical axis to the object's box, as AI2-THOR measures visibility
        (``harness.sim.reach``: a cylinder about the agent, not a sphere about the camera)."""
        agent = self.world.agent
        (x0, _, z0), (x1, _, z1) = obj.min_corner, obj.max_corner
        return math.hypot(max(x0 - agent.x, agent.x - x1, 0.0), max(z0 - agent.z, agent.z - z1, 0.0))


def _sliced_condition(task: AlfredTask, pickupables: list[WorldObject], needed: int) -> list[_Condition]:
    """Counted only for sliced targets: slices of the object exist (up to ``needed`` of them)."""
    if not task.object_sliced:
        return []
    slices = sum(_SLICED in p.object_id for p in pickupables)
    return [_Condition(f"The {task.object_target} needs to be sliced.", min(slices, needed), needed)]


def _placed_with_state(task: AlfredTask, scene: _Scene, state: str, word: str) -> list[_Condition]:
    """Heat/cool/clean tasks: in place, state reached, and both by the same object (3 conditions)."""
    assert task.parent_target is not None
    receptacles = scene.named(task.parent_target, "receptacle")
    pickupables = scene.named(task.target_name, "pickupable")
    in_place = {p.object_id for p in pickupables if any(scene.is_in(p, r) for r in receptacles)}
    changed = {p.object_id for p in pickupables if getattr(p, state)}
    thing = task.target_name
    return [
        *_sliced_condition(task, pickupables, 1),
        _Condition(f"A {thing} needs to be in a {task.parent_target}.", int(bool(in_place))),
        _Condition(f"A {thing} needs to be {word}.", int(bool(changed))),
        _Condition(
            f"The {thing} in the {task.parent_target} needs to be {word}.", int(bool(in_place & changed))
        ),
    ]


def _pick_and_place_simple(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    assert task.parent_target is not None
    receptacles = scene.named(task.parent_target, "receptacle")
    pickupables = scene.named(task.target_name, "pickupable")
    placed = any(scene.is_in(p, r) for p in pickupables for r in receptacles)
    return [
        *_sliced_condition(task, pickupables, 1),
        _Condition(f"A {task.target_name} needs to be in a {task.parent_target}.", int(placed)),
    ]


def _pick_two_obj_and_place(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    assert task.parent_target is not None
    receptacles = scene.named(task.parent_target, "receptacle")
    pickupables = scene.named(task.target_name, "pickupable")
    most_in_one = max((sum(scene.is_in(p, r) for p in pickupables) for r in receptacles), default=0)
    return [
        *_sliced_condition(task, pickupables, 2),
        _Condition(
            f"Two {task.target_name}s need to be in one {task.parent_target}.", min(most_in_one, 2), 2
        ),
    ]


def _look_at_obj_in_light(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    assert task.toggle_target is not None
    lamps = scene.named(task.toggle_target, "toggleable")
    pickupables = scene.named(task.target_name, "pickupable")
    holding = scene.held_id() in {p.object_id for p in pickupables}
    lit = any(t.is_toggled and scene.reach_distance(t) <= INTERACTION_DISTANCE_M for t in lamps)
    return [
        *_sliced_condition(task, pickupables, 1),
        _Condition(f"A {task.target_name} needs to be in hand.", int(holding)),
        _Condition(f"A {task.toggle_target} nearby needs to be on.", int(lit)),
    ]


def _pick_clean_then_place(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    return _placed_with_state(task, scene, "is_cleaned", "cleaned")


def _pick_heat_then_place(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    return _placed_with_state(task, scene, "is_heated", "heated")


def _pick_cool_then_place(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    return _placed_with_state(task, scene, "is_cooled", "cooled")


def _pick_and_place_with_movable_recep(task: AlfredTask, scene: _Scene) -> list[_Condition]:
    assert task.parent_target is not None and task.mrecep_target is not None
    receptacles = scene.named(task.parent_target, "receptacle")
    pickupables = scene.named(task.target_name, "pickupable")
    movables = scene.named(task.mrecep_target, "pickupable")
    in_movable = any(scene.is_in(p, m) for p in pickupables for m in movables)
    movable_placed = any(scene.is_in(m, r) for m in movables for r in receptacles)
    stacked = any(
        any(scene.is_in(p, m) for p in pickupables) and any(scene.is_in(m, r) for r in receptacles)
        for m in movables
    )
    thing, mrecep, parent = task.target_name, task.mrecep_target, task.parent_target
    return [
        *_sliced_condition(task, pickupables, 1),
        _Condition(f"A {thing} needs to be in a {mrecep}.", int(in_movable)),
        _Condition(f"A {mrecep} needs to be in a {parent}.", int(movable_placed)),
        _Condition(f"The {mrecep} holding the {thing} needs to be in a {parent}.", int(stacked)),
    ]


_CHECKERS: dict[str, Callable[[AlfredTask, _Scene], list[_Condition]]] = {
    "pick_and_place_simple": _pick_and_place_simple,
    "pick_two_obj_and_place": _pick_two_obj_and_place,
    "look_at_obj_in_light": _look_at_obj_in_light,
    "pick_clean_then_place_in_recep": _pick_clean_then_place,
    "pick_heat_then_place_in_recep": _pick_heat_then_place,
    "pick_cool_then_place_in_recep": _pick_cool_then_place,
    "pick_and_place_with_movable_recep": _pick_and_place_with_movable_recep,
}


def check_alfred(task: AlfredTask, world: World, ontology: Ontology | None = None) -> GoalReport:
    """ALFRED's goal conditions (satisfied, total) for the task in this world; success when all hold."""
    conditions = _CHECKERS[task.task_type](task, _Scene(world, ontology or load_ontology()))
    subgoals = tuple(
        SubgoalStatus(
            description=c.desc,
            success=c.satisfied >= c.total,
            steps=(),
            problem_keys=(),
            goal_conditions_total=c.total,
            goal_conditions_satisfied=c.satisfied,
        )
        for c in conditions
    )
    satisfied = sum(c.satisfied for c in conditions)
    total = sum(c.total for c in conditions)
    return GoalReport(
        satisfied=satisfied,
        total=total,
        success=satisfied == total,
        unsatisfied=human_failures(subgoals),
        description=task.describe(),
        subgoals=subgoals,
    )
