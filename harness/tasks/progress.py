"""What a goal check reports, for TEACh and ALFRED tasks alike: counts for SR/GC and words for a commander.

The shape follows TEACh's progress check (``Task_THOR.check_episode_progress`` in alexa/teach): a list
of subgoals, each with steps naming an object and a description, plus the goal-condition counts that
TEACh's GC metric is computed from.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

ConditionValue = str | int
"""A wanted property value: an object type or class, or 0/1 for a boolean simulator property."""


@dataclass(frozen=True)
class ProgressStep:
    """One line of TEACh's progress check: an object and whether its condition holds."""

    success: bool
    object_id: str
    object_type: str
    desc: str


@dataclass(frozen=True)
class ProblemKey:
    """A property of an object that still has the wrong value (what a commander bot should ask for)."""

    object_id: str
    object_type: str
    determiner: str
    property_name: str
    desired_value: ConditionValue


@dataclass(frozen=True)
class SubgoalStatus:
    """One entry of TEACh's ``subgoals`` list: a component, a sub-task or a relation."""

    description: str
    success: bool
    steps: tuple[ProgressStep, ...]
    problem_keys: tuple[ProblemKey, ...]
    goal_conditions_total: int
    goal_conditions_satisfied: int
    representative_object_id: str | None = None
    fallback_desc: str = ""
    """Our words for a failure TEACh reports without a step (e.g. "Find a Knife.")."""


@dataclass(frozen=True)
class GoalReport:
    """Goal conditions of a task in one state: what SR and GC are computed from."""

    satisfied: int
    total: int
    success: bool
    unsatisfied: tuple[str, ...]
    """Human descriptions of what is still wrong (TEACh's condition_failure_descs / failure_desc)."""
    description: str = ""
    subgoals: tuple[SubgoalStatus, ...] = ()

    @property
    def problem_keys(self) -> tuple[ProblemKey, ...]:
        return tuple(key for subgoal in self.subgoals if not subgoal.success for key in subgoal.problem_keys)

    @property
    def remaining_object_ids(self) -> tuple[str, ...]:
        """Objects a commander should point the follower to, in report order, each once."""
        return tuple(dict.fromkeys(key.object_id for key in self.problem_keys))

    @property
    def remaining_object_types(self) -> tuple[str, ...]:
        """Types of those objects, each once (what a commander names: "the Plate", "the Tomato")."""
        return tuple(dict.fromkeys(key.object_type for key in self.problem_keys))


def human_failures(subgoals: Iterable[SubgoalStatus]) -> tuple[str, ...]:
    """What is still wrong, in words, each once: failed steps, else our fallback, else the description."""
    lines: list[str] = []
    for subgoal in subgoals:
        if subgoal.success:
            continue
        failed = [step.desc for step in subgoal.steps if not step.success]
        lines.extend(failed or [subgoal.fallback_desc or subgoal.description])
    return tuple(dict.fromkeys(line for line in lines if line))
