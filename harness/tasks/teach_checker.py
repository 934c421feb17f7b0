"""TEACh's goal-condition checker, so SR and GC mean here what they mean in TEACh.

A re-implementation of ``Task_THOR.check_episode_progress`` (alexa/teach, ``src/teach/dataset/
task_THOR.py``) over AI2-THOR-style metadata dicts, including its counting quirks, so the numbers are
TEACh's for the same state and the same object order. Every condition of every required instance counts
once; relations count once per head instance; the best-satisfying candidates are credited, chosen
greedily in TEACh's order. Deliberate deviations, none of which changes a count:

- candidates with equally many satisfied conditions are ordered by distance to the agent's *camera*
  (TEACh measures from the agent's body position); this only changes which objects a step names;
- a tail component of mixed object types reports the first candidate's type in a problem key (TEACh takes
  an arbitrary element of a set);
- a sub-task whose anchor component was skipped (determiner "0") contributes no objects to relations
  (TEACh would fail on ``None``);
- subgoals that fail without a failed step (a missing Knife, say) get our own short ``fallback_desc`` so a
  commander always has something to say.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from harness.tasks.progress import (
    ConditionValue,
    GoalReport,
    ProblemKey,
    ProgressStep,
    SubgoalStatus,
    human_failures,
)
from harness.tasks.teach_definitions import BoundSubtask, BoundTask, ObjectComponent, Relation

ObjectMetadata = Mapping[str, Any]
"""One object as AI2-THOR/TEACh report it (``objectId``, ``objectType``, ``isDirty``, ...)."""

_SLICE_SUFFIX = "Sliced"
_CRACK_SUFFIX = "Cracked"
TYPE_ALIASES: dict[str, str] = {
    "Sink": "SinkBasin",
    "SinkBasin": "Sink",
    "Bathtub": "BathtubBasin",
    "BathtubBasin": "Bathtub",
}
"""TEACh treats a sink and its basin (and a bathtub and its basin) as the same thing in type checks."""


@dataclass
class _Candidate:
    obj: ObjectMetadata
    props_sat: dict[str, bool]
    num_props_sat: int
    distance: float


@dataclass
class _ComponentOutcome:
    success: bool
    satisfied: list[ObjectMetadata]
    candidates: list[ObjectMetadata]
    total: int
    satisfied_count: int
    steps: list[ProgressStep]
    problem_keys: list[ProblemKey]


@dataclass
class _TaskOutcome:
    description: str
    success: bool
    satisfied: list[ObjectMetadata] | None
    candidates: list[ObjectMetadata] | None
    subgoals: list[SubgoalStatus]
    total: int
    satisfied_count: int


@dataclass(frozen=True)
class _Scene:
    objects: Sequence[ObjectMetadata]
    by_id: Mapping[str, ObjectMetadata]
    agent_position: tuple[float, float, float] | None

    def distance_to_agent(self, obj: ObjectMetadata) -> float:
        if self.agent_position is None:
            return 0.0
        pos = obj["position"]
        return math.dist((pos["x"], pos["y"], pos["z"]), self.agent_position)


def _type_matches(obj: ObjectMetadata | None, desired: ConditionValue) -> bool:
    if obj is None:
        return False
    actual = obj["objectType"]
    return bool(actual == desired or TYPE_ALIASES.get(actual) == desired)


def _parent_receptacles(
    obj: ObjectMetadata, scene: _Scene, seen: frozenset[str] = frozenset()
) -> list[str] | None:
    """AI2-THOR's parentReceptacles, else the chain of TEACh's simbotLastParentReceptacle."""
    parents = obj.get("parentReceptacles")
    if parents is not None:
        return list(parents)
    last = obj.get("simbotLastParentReceptacle")
    if last is None or last == obj["objectId"] or last in seen:
        return None
    chain = [last]
    parent = scene.by_id.get(last)
    if parent is not None:
        chain += _parent_receptacles(parent, scene, seen | {obj["objectId"]}) or []
    return chain


def _props_satisfied(
    obj: ObjectMetadata, conditions: Mapping[str, ConditionValue], scene: _Scene
) -> dict[str, bool]:
    """Per condition: does the object satisfy it (TEACh's obj_satisfies_props)."""
    sats: dict[str, bool] = {}
    for prop, wanted in conditions.items():
        if prop not in obj:
            sats[prop] = False
        elif prop == "objectType":
            sats[prop] = _type_matches(obj, wanted)
        elif prop == "simbotLastParentReceptacle" and wanted is not None:
            parent = scene.by_id.get(obj[prop]) if obj[prop] is not None else None
            sats[prop] = parent is not None and (
                _type_matches(parent, wanted) or wanted in parent.get("simbotObjectClass", [])
            )
        elif prop == "parentReceptacles":
            parent_ids = _parent_receptacles(obj, scene) or []
            parents = [scene.by_id.get(pid) for pid in parent_ids]
            sats[prop] = any(
                p is not None and (_type_matches(p, wanted) or wanted in p.get("simbotObjectClass", []))
                for p in parents
            )
        elif type(wanted) is int and wanted in (0, 1):
            sats[prop] = bool(obj[prop]) == bool(wanted)
        elif isinstance(obj[prop], list):
            sats[prop] = wanted in obj[prop]
        else:
            sats[prop] = obj[prop] == wanted
    return sats


def _could_become_primary(obj: ObjectMetadata, component: ObjectComponent, sats: Mapping[str, bool]) -> bool:
    """A candidate must match the primary condition, or be the whole object a slice/cracked egg comes from."""
    primary = component.primary_condition
    target = component.conditions[primary]
    if sats[primary]:
        return True
    if not isinstance(target, str):
        return False
    return any(
        suffix in target and obj.get(primary) == target.replace(suffix, "")
        for suffix in (_SLICE_SUFFIX, _CRACK_SUFFIX)
    )


def _failure_steps(
    component: ObjectComponent,
    problems: Sequence[_Candidate],
    representative: ObjectMetadata | None,
) -> list[ProgressStep]:
    """A failed step per problem object and described condition; one success step per condition otherwise."""
    failing: dict[str, list[_Candidate]] = {}
    for cand in problems:
        for key, ok in cand.props_sat.items():
            if not ok and key in component.condition_failure_descs:
                failing.setdefault(key, []).append(cand)
    steps: list[ProgressStep] = []
    for key, desc in component.condition_failure_descs.items():
        if key in failing:
            steps.extend(
                ProgressStep(False, c.obj["objectId"], c.obj["objectType"], desc) for c in failing[key]
            )
        elif representative is not None:
            steps.append(ProgressStep(True, representative["objectId"], representative["objectType"], desc))
    return steps


def _problem_keys(component: ObjectComponent, problems: Sequence[_Candidate]) -> list[ProblemKey]:
    return [
        ProblemKey(
            c.obj["objectId"], c.obj["objectType"], component.determiner, key, component.conditions[key]
        )
        for c in problems
        for key, ok in c.props_sat.items()
        if not ok
    ]


def _check_n_instances(component: ObjectComponent, num_instances: int, scene: _Scene) -> _ComponentOutcome:
    """TEACh's check_component_n_instances (allow_state_change=False, as in progress checks).

    Kept quirk: when a whole object could be sliced into the wanted slice type, TEACh looks for only
    one more problem object, however many instances are missing (one potato makes many slices).
    """
    if component.instance_shareable:
        num_instances = 1
    primary_target = component.conditions[component.primary_condition]
    success = False
    satisfied: list[ObjectMetadata] = []
    candidates: list[_Candidate] = []
    num_instances_to_check = num_instances
    for obj in scene.objects:
        sats = _props_satisfied(obj, component.conditions, scene)
        if all(sats.values()):
            satisfied.append(obj)
            success = success or len(satisfied) >= num_instances
            continue
        if success or not _could_become_primary(obj, component, sats):
            continue
        non_primary = [ok for key, ok in sats.items() if key != component.primary_condition]
        if all(non_primary) and isinstance(primary_target, str) and _SLICE_SUFFIX in primary_target:
            num_instances_to_check = 1
        cand = _Candidate(obj, sats, sum(sats.values()), scene.distance_to_agent(obj))
        position = next(
            (
                i
                for i, cur in enumerate(candidates)
                if cand.num_props_sat > cur.num_props_sat
                or (cand.num_props_sat == cur.num_props_sat and cand.distance < cur.distance)
            ),
            len(candidates),
        )
        candidates.insert(position, cand)

    still_needed = max(0, num_instances_to_check - len(satisfied))
    problems = candidates[: min(len(candidates), still_needed)]
    per_obj = len(component.conditions)
    representative = satisfied[0] if satisfied else (candidates[0].obj if candidates else None)
    return _ComponentOutcome(
        success=success,
        satisfied=satisfied,
        candidates=[c.obj for c in candidates],
        total=per_obj * num_instances,
        satisfied_count=per_obj * min(num_instances, len(satisfied)) + sum(c.num_props_sat for c in problems),
        steps=_failure_steps(component, problems, representative),
        problem_keys=_problem_keys(component, problems),
    )


def _check_all_instances(component: ObjectComponent, scene: _Scene) -> _ComponentOutcome:
    """TEACh's check_component_all_instances: every object matching the primary condition must comply."""
    satisfied: list[ObjectMetadata] = []
    problems: list[_Candidate] = []
    for obj in scene.objects:
        sats = _props_satisfied(obj, component.conditions, scene)
        if not sats[component.primary_condition]:
            continue
        if all(sats.values()):
            satisfied.append(obj)
        else:
            problems.append(_Candidate(obj, sats, sum(sats.values()), 0.0))
    per_obj = len(component.conditions)
    return _ComponentOutcome(
        success=not problems,
        satisfied=satisfied,
        candidates=[c.obj for c in problems],
        total=per_obj * (len(satisfied) + len(problems)),
        satisfied_count=per_obj * len(satisfied) + sum(c.num_props_sat for c in problems),
        steps=_failure_steps(component, problems, satisfied[0] if satisfied else None),
        problem_keys=_problem_keys(component, problems),
    )


def _count(determiner: str, what: str) -> int:
    try:
        return int(determiner)
    except ValueError:
        raise ValueError(f"{what}: determiner {determiner!r} is not 'a', 'all' or a number") from None


def _relation_heads(
    entity: str, satisfied: Mapping[str, list[ObjectMetadata]], candidates: Mapping[str, list[ObjectMetadata]]
) -> list[ObjectMetadata]:
    return list(satisfied.get(entity, [])) + list(candidates.get(entity, []))


def _property_values(obj: ObjectMetadata, prop: str, scene: _Scene) -> list[str] | None:
    if prop == "parentReceptacles":
        return _parent_receptacles(obj, scene)
    value = obj.get(prop)
    return list(value) if value is not None else None


def _split_heads(
    objs: Sequence[ObjectMetadata], prop: str, tail_ids: set[str], scene: _Scene
) -> tuple[list[ObjectMetadata], list[ObjectMetadata]]:
    """Head objects whose ``prop`` holds one of the tail ids, and the others."""
    related: list[ObjectMetadata] = []
    unrelated: list[ObjectMetadata] = []
    for obj in objs:
        values = _property_values(obj, prop, scene) or []
        (related if any(v in tail_ids for v in values) else unrelated).append(obj)
    return related, unrelated


def _relation_total(
    relation: Relation, heads: Mapping[str, list[ObjectMetadata]], num_task_instances: int
) -> int:
    """One goal condition per head instance that must be related."""
    total = 0
    for entity, det in zip(relation.head_entities, relation.head_determiners, strict=True):
        if det == "a":
            total += num_task_instances
        elif det == "all":
            total += num_task_instances * len(heads[entity])
        else:
            total += num_task_instances * _count(det, f"relation head {entity!r}")
    return total


@dataclass
class _HeadStatus:
    determiner: str
    satisfied: list[ObjectMetadata]
    unsatisfied: list[ObjectMetadata]
    instances_needed: int

    @property
    def goal_conditions_satisfied(self) -> int:
        return min(self.instances_needed, len(self.satisfied))

    @property
    def success(self) -> bool:
        return len(self.satisfied) >= self.instances_needed


@dataclass
class _TailStatus:
    tail: ObjectMetadata
    heads: list[_HeadStatus]

    @property
    def success(self) -> bool:
        return all(h.success for h in self.heads)

    @property
    def num_heads_satisfied(self) -> int:
        return sum(h.success for h in self.heads)

    @property
    def num_instances_satisfied(self) -> int:
        return sum(h.goal_conditions_satisfied for h in self.heads)


def _check_relation(
    relation: Relation,
    satisfied: Mapping[str, list[ObjectMetadata]],
    candidates: Mapping[str, list[ObjectMetadata]],
    scene: _Scene,
    num_task_instances: int,
) -> SubgoalStatus:
    """TEACh's check_relation for tail determiners "a" (any tail object) and "the" (one tail object)."""
    heads = {e: _relation_heads(e, satisfied, candidates) for e in relation.head_entities}
    total = _relation_total(relation, heads, num_task_instances)
    tails = _relation_heads(relation.tail_entity, satisfied, candidates)
    if not tails:
        return SubgoalStatus("", False, (), (), total, 0, fallback_desc=relation.failure_desc)
    check = _RelationCheck(relation, heads, tails, scene, num_task_instances, total)
    if relation.tail_determiner == "a":
        return check.any_tail()
    if relation.tail_determiner == "the":
        return check.one_tail()
    raise ValueError(
        f"relation tail determiner {relation.tail_determiner!r} is not supported (TEACh: 'a', 'the')"
    )


@dataclass(frozen=True)
class _RelationCheck:
    """One relation with its head and tail objects: what both of TEACh's tail rules weigh and report."""

    relation: Relation
    heads: Mapping[str, list[ObjectMetadata]]
    tails: list[ObjectMetadata]
    scene: _Scene
    num_task_instances: int
    total: int

    def any_tail(self) -> SubgoalStatus:
        """Each head object may sit in any tail object.

        Kept quirk: satisfied heads are not capped at the need.
        """
        relation = self.relation
        tail_ids = {t["objectId"] for t in self.tails}
        tail_type = self.tails[0]["objectType"]
        success = True
        satisfied_count = 0
        steps: list[ProgressStep] = []
        keys: list[ProblemKey] = []
        all_satisfied: list[ObjectMetadata] = []
        for entity, det in zip(relation.head_entities, relation.head_determiners, strict=True):
            if det == "0":
                continue
            ok_objs, bad_objs = _split_heads(self.heads[entity], relation.property, tail_ids, self.scene)
            satisfied_count += len(ok_objs)
            if det == "all":
                if bad_objs:
                    success = False
                    self._report_problems(bad_objs, det, tail_type, steps, keys)
                elif ok_objs:
                    steps.append(self._success_step(ok_objs[0]))
            else:
                needed = self.num_task_instances * (
                    1 if det == "a" else _count(det, f"relation head {entity!r}")
                )
                if len(ok_objs) < needed:
                    success = False
                    self._report_problems(bad_objs[: needed - len(ok_objs)], det, tail_type, steps, keys)
            all_satisfied += ok_objs
        if success and all_satisfied and not steps:
            steps.append(self._success_step(all_satisfied[0]))
        return self._status(success, steps, keys, satisfied_count)

    def one_tail(self) -> SubgoalStatus:
        """All heads of one task instance must sit in the *same* tail object; the best tails are credited."""
        relation = self.relation
        num_task_instances = self.num_task_instances
        satisfied_tails: list[_TailStatus] = []
        ranked: list[_TailStatus] = []
        for tail in self.tails:
            status = _TailStatus(tail, [])
            for entity, det in zip(relation.head_entities, relation.head_determiners, strict=True):
                if det == "0":
                    continue
                ok_objs, bad_objs = _split_heads(
                    self.heads[entity], relation.property, {tail["objectId"]}, self.scene
                )
                if det == "all":
                    needed = len(self.heads[entity])
                elif det == "a":
                    needed = 1
                else:
                    needed = _count(det, f"relation head {entity!r}")
                status.heads.append(_HeadStatus(det, ok_objs, bad_objs, needed))
            if status.success:
                satisfied_tails.append(status)
                if len(satisfied_tails) >= num_task_instances:
                    break
                continue
            # TEACh's insertion rule: ahead of the first tail that satisfies fewer heads or fewer instances.
            position = next(
                (
                    i
                    for i, cur in enumerate(ranked)
                    if status.num_heads_satisfied > cur.num_heads_satisfied
                    or status.num_instances_satisfied > cur.num_instances_satisfied
                ),
                len(ranked),
            )
            ranked.insert(position, status)
            ranked = ranked[: max(0, num_task_instances - len(satisfied_tails))]

        satisfied_count = sum(
            h.goal_conditions_satisfied for t in satisfied_tails[:num_task_instances] for h in t.heads
        )
        steps: list[ProgressStep] = []
        keys: list[ProblemKey] = []
        for status in ranked[: max(0, num_task_instances - len(satisfied_tails))]:
            for head in status.heads:
                satisfied_count += head.goal_conditions_satisfied
                missing = head.instances_needed - len(head.satisfied)
                self._report_problems(
                    head.unsatisfied[: max(0, missing)],
                    head.determiner,
                    status.tail["objectType"],
                    steps,
                    keys,
                )
        success = len(satisfied_tails) >= num_task_instances
        return self._status(success, steps, keys, satisfied_count)

    def _success_step(self, obj: ObjectMetadata) -> ProgressStep:
        return ProgressStep(True, obj["objectId"], obj["objectType"], self.relation.failure_desc)

    def _report_problems(
        self,
        objs: Sequence[ObjectMetadata],
        det: str,
        tail_type: str,
        steps: list[ProgressStep],
        keys: list[ProblemKey],
    ) -> None:
        """A failed step and a problem key per head object not related as it should be."""
        for obj in objs:
            steps.append(ProgressStep(False, obj["objectId"], obj["objectType"], self.relation.failure_desc))
            keys.append(
                ProblemKey(obj["objectId"], obj["objectType"], det, self.relation.property, tail_type)
            )

    def _status(
        self, success: bool, steps: list[ProgressStep], keys: list[ProblemKey], satisfied_count: int
    ) -> SubgoalStatus:
        return SubgoalStatus(
            "",
            success,
            tuple(steps),
            tuple(keys),
            self.total,
            satisfied_count,
            fallback_desc=self.relation.failure_desc,
        )


def _representative_id(outcome: _TaskOutcome) -> str | None:
    """TEACh's __get_representative_obj_id: the object best standing for a sub-task in its subgoal."""
    if not outcome.success and outcome.candidates:
        return str(outcome.candidates[0]["objectId"])
    if outcome.satisfied:
        return str(outcome.satisfied[0]["objectId"])
    if outcome.candidates:
        return str(outcome.candidates[0]["objectId"])
    last = None
    for subgoal in outcome.subgoals:
        for step in subgoal.steps:
            if step.success:
                return step.object_id
            last = step.object_id
    return last


def _component_status(outcome: _ComponentOutcome, component: ObjectComponent, count: int) -> SubgoalStatus:
    target = component.conditions[component.primary_condition]
    needed = 1 if component.instance_shareable else count
    fallback = f"Find a {target}." if needed == 1 else f"Find {needed} {target}."
    return SubgoalStatus(
        description="",
        success=outcome.success,
        steps=tuple(outcome.steps),
        problem_keys=tuple(outcome.problem_keys),
        goal_conditions_total=outcome.total,
        goal_conditions_satisfied=outcome.satisfied_count,
        fallback_desc=fallback,
    )


def _check_task(task: BoundTask, scene: _Scene, num_instances_needed: int = 1) -> _TaskOutcome:
    """TEACh's check_episode_progress with use_task_candidates_in_relations=False (its default)."""
    subgoals: list[SubgoalStatus] = []
    anchor_satisfied: list[ObjectMetadata] | None = None
    anchor_candidates: list[ObjectMetadata] | None = None
    satisfied: dict[str, list[ObjectMetadata]] = {}
    candidates: dict[str, list[ObjectMetadata]] = {}

    for comp in task.components:
        determiner = comp.determiner
        if determiner == "0":
            continue
        if determiner == "all":
            if isinstance(comp, BoundSubtask):
                raise ValueError(f"task {task.definition.task_name!r}: determiner 'all' on a sub-task")
            out = _check_all_instances(comp.component, scene)
            if not out.success or out.steps:
                subgoals.append(_component_status(out, comp.component, 1))
            satisfied[comp.key], candidates[comp.key] = out.satisfied, out.candidates
            if task.anchor == comp.key:
                anchor_satisfied, anchor_candidates = out.satisfied, out.candidates
            continue

        count = num_instances_needed * (
            1 if determiner == "a" else _count(determiner, f"component {comp.key!r}")
        )
        if isinstance(comp, BoundSubtask):
            sub = _check_task(comp.task, scene, count)
            prefix = f"{determiner} x " if determiner not in ("a", "the", "all") else ""
            subgoals.append(
                SubgoalStatus(
                    description=prefix + sub.description,
                    success=all(s.success for s in sub.subgoals),
                    steps=tuple(step for s in sub.subgoals for step in s.steps if not step.success),
                    problem_keys=tuple(key for s in sub.subgoals for key in s.problem_keys),
                    goal_conditions_total=sub.total,
                    goal_conditions_satisfied=sub.satisfied_count,
                    representative_object_id=_representative_id(sub),
                    fallback_desc=" ".join(human_failures(sub.subgoals)),
                )
            )
            satisfied[comp.key] = sub.satisfied or []
            if task.anchor == comp.key:
                anchor_satisfied, anchor_candidates = sub.satisfied, sub.candidates
        else:
            out = _check_n_instances(comp.component, count, scene)
            subgoals.append(_component_status(out, comp.component, count))
            satisfied[comp.key], candidates[comp.key] = out.satisfied, out.candidates
            if task.anchor == comp.key:
                anchor_satisfied, anchor_candidates = out.satisfied, out.candidates

    for relation in task.relations:
        subgoals.append(_check_relation(relation, satisfied, candidates, scene, num_instances_needed))

    return _TaskOutcome(
        description=task.desc,
        success=all(s.success for s in subgoals),
        satisfied=anchor_satisfied,
        candidates=anchor_candidates,
        subgoals=subgoals,
        total=sum(s.goal_conditions_total for s in subgoals),
        satisfied_count=sum(s.goal_conditions_satisfied for s in subgoals),
    )


def check_bound_task(
    task: BoundTask,
    objects: Sequence[ObjectMetadata],
    agent_position: tuple[float, float, float] | None = None,
) -> GoalReport:
    """TEACh's progress check of a bound task on object metadata carrying simbotObjectClass and receptacle."""
    scene = _Scene(objects=objects, by_id={o["objectId"]: o for o in objects}, agent_position=agent_position)
    outcome = _check_task(task, scene)
    return GoalReport(
        satisfied=outcome.satisfied_count,
        total=outcome.total,
        success=outcome.success,
        unsatisfied=human_failures(outcome.subgoals),
        description=outcome.description,
        subgoals=tuple(outcome.subgoals),
    )
