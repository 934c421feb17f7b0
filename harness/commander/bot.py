"""The TATC commander: answers the follower with the next step, found with its tools.

Each answer follows the JARVIS seed's commander (its Figure 5): ProgressCheck for what is left; the
task-level planner (the expert's ``plan_task``, run on the world as it is now, so a follower's detour or
mistake is planned around) for the next interaction; SearchObject/SelectOid for where its object is;
then one instruction in ``symbolic.commands``' form, "Navigate Mug @ (2.00, 5.00, 270), Pickup Mug @
(0.70, 0.37)". What the instruction may carry is the information level of the seed's Table 2:
``full`` (standing pose and click point from the ground-truth segmentation), ``no_segmentation``
(standing pose only), ``no_goal_location`` (the subgoals only).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from harness.commander.tools import CommanderTools, ObjectLocation
from harness.expert.planning import ExpertSubgoal, PlanError
from harness.expert.recipes import Task, plan_task
from harness.world import World
from symbolic.commands import ClickHint, CommandItem, StandHint, format_command
from symbolic.subgoals import Subgoal, SubgoalAction

InfoLevel = Literal["full", "no_segmentation", "no_goal_location"]
INFO_LEVELS: tuple[InfoLevel, ...] = ("full", "no_segmentation", "no_goal_location")

DONE_TEXT = "That's everything: the task is done. Thank you!"


@dataclass(frozen=True)
class CommanderTurn:
    """One answer: the text said, whether the task is complete, and the tool calls behind it."""

    text: str
    task_done: bool
    calls: tuple[str, ...] = field(default=())


class Commander:
    """Answers one episode's follower; holds no state between answers but the task and its tools."""

    def __init__(self, task: Task, tools: CommanderTools, info: InfoLevel = "full") -> None:
        if info not in INFO_LEVELS:
            raise ValueError(f"info must be one of {INFO_LEVELS}, got {info!r}")
        self.task = task
        self.tools = tools
        self.info = info

    def opening(self, world: World) -> str:
        """The first words: what the task is (TEACh's commander starts with the task description)."""
        report = self.tools.progress_check(self.task, world)
        description = report.description.rstrip(".") or "follow my instructions"
        return f"Hello! Today's task: {description}."

    def respond(self, world: World) -> CommanderTurn:
        """The next instruction for the world as it is now, or DONE_TEXT when every condition holds."""
        report = self.tools.progress_check(self.task, world)
        calls = [f"ProgressCheck: {report.satisfied}/{report.total} goal conditions satisfied"]
        if report.success:
            return CommanderTurn(DONE_TEXT, True, tuple(calls))
        try:
            plan = plan_task(self.task, world, self.tools.ontology)
        except PlanError as error:
            left = "; ".join(report.unsatisfied[:2]) or "the rest of the task"
            return CommanderTurn(f"I can't work out the next step ({error}). Still to do: {left}", False)
        if not plan:
            left = "; ".join(report.unsatisfied[:2])
            return CommanderTurn(f"Still to do: {left}", False, tuple(calls))
        steps = _next_steps(plan)
        target = steps[0]
        location = None
        if self.info != "no_goal_location" and world.agent.held != target.object_id:
            location = self.tools.select_oid(world, target.object_id)
            calls.append(f"SearchObject {target.object_type}: {_where(location)}")
        items = self._items(steps, world, location)
        return CommanderTurn(format_command(items), False, tuple(calls))

    def _items(
        self, steps: list[ExpertSubgoal], world: World, location: ObjectLocation | None
    ) -> list[CommandItem]:
        first = steps[0]
        items: list[CommandItem] = []
        if world.agent.held != first.object_id and first.action is not SubgoalAction.NAVIGATE:
            stand = None
            if location is not None and location.stand is not None:
                stand = StandHint(*location.stand)
            items.append(CommandItem(Subgoal(SubgoalAction.NAVIGATE, first.object_type), stand=stand))
        for index, step in enumerate(steps):
            click = None
            if index == 0 and self.info == "full" and location is not None and location.click is not None:
                click = ClickHint(*location.click)
            items.append(CommandItem(step.subgoal, click=click))
        return items


def _next_steps(plan: list[ExpertSubgoal]) -> list[ExpertSubgoal]:
    """The first interaction and those right after it on the same object (ToggleOn then ToggleOff); the
    plan's Navigate steps are left out (the instruction says where to go itself)."""
    interactions = [step for step in plan if step.action is not SubgoalAction.NAVIGATE]
    if not interactions:
        return [plan[-1]]
    steps = [interactions[0]]
    for step in interactions[1:]:
        if step.object_id != steps[0].object_id:
            break
        steps.append(step)
    return steps


def _where(location: ObjectLocation) -> str:
    inside = f" in/on {location.parents[0]}" if location.parents else ""
    x, _, z = location.position
    stand = "no standing pose found" if location.stand is None else f"stand at {location.stand}"
    return f"{location.object_id}{inside} at ({x:.2f}, {z:.2f}); {stand}"
