"""The TATC commander: answers the follower with the next step, found with its tools.

Each answer follows the JARVIS seed's commander (its Figure 5): ProgressCheck for what is left; the
task-level planner (the expert's ``plan_task``, run on the world as it is now, so a follower's detour or
mistake is planned around) for the next interaction; SearchObject/SelectOid for where its object is;
then one instruction in ``symbolic.commands``' form, "Navigate Mug @ (2.00, 5.00, 270, 30), Pickup Mug @
(0.70, 0.37)". What the instruction may carry is the information level of the seed's Table 2:
``full`` (standing pose and click point from the ground-truth segmentation), ``no_segmentation``
(standing pose only), ``no_goal_location`` (the subgoals only).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Literal

from harness.commander.tools import CommanderTools, ObjectLocation
from harness.expert.planning import ExpertSubgoal, PlanError, PlanState
from harness.expert.recipes import Task, plan_task
from harness.sim.simulator import Simulator
from harness.world.model import World
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
    """Answers one episode's follower. Between answers it keeps the plan it is instructing from, so it
    does not change its mind while the follower carries it out (planning afresh from every state can flip
    between equally good plans: put the plate down, pick it up, put it down...)."""

    def __init__(self, task: Task, tools: CommanderTools, info: InfoLevel = "full") -> None:
        if info not in INFO_LEVELS:
            raise ValueError(f"info must be one of {INFO_LEVELS}, got {info!r}")
        self.task = task
        self.tools = tools
        self.info = info
        self.remaining: list[ExpertSubgoal] = []
        """The plan after the steps last instructed: followed on while it still achieves the task."""

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
            self.remaining = []
            return CommanderTurn(DONE_TEXT, True, tuple(calls))
        if self.remaining and self._achieves_task(self.remaining, world):
            plan = self.remaining
        else:
            try:
                plan = self._plan(world)
            except PlanError as error:
                self.remaining = []
                left = "; ".join(report.unsatisfied[:2]) or "the rest of the task"
                return CommanderTurn(f"I can't work out the next step ({error}). Still to do: {left}", False)
        plan = _without_no_ops(plan, world)
        if not plan:
            left = "; ".join(report.unsatisfied[:2])
            return CommanderTurn(f"Still to do: {left}", False, tuple(calls))
        steps, end = _next_steps(plan)
        self.remaining = plan[end:]
        target = steps[0]
        location = None
        if self.info != "no_goal_location" and world.agent.held != target.object_id:
            location = self.tools.select_oid(world, target.object_id, target.action.value)
            calls.append(f"SearchObject {target.object_type}: {_where(location)}")
        items = self._items(steps, world, location)
        return CommanderTurn(format_command(items), False, tuple(calls))

    def _plan(self, world: World) -> list[ExpertSubgoal]:
        """The expert's task planner on the world as it is, acting only on objects the follower can see and
        reach from somewhere (the expert's own look-ahead); without it when that finds no plan."""
        try:
            return plan_task(self.task, world, self.tools.ontology, sight=self.tools.sight)
        except PlanError:
            return plan_task(self.task, world, self.tools.ontology)

    def _achieves_task(self, plan: list[ExpertSubgoal], world: World) -> bool:
        """Whether carrying out ``plan`` from ``world`` (the planner's own model of each step) completes the
        task: the follower did what it was told, so the rest of the plan still holds."""
        state = PlanState(world, self.tools.ontology)
        try:
            for step in plan:
                _APPLY[step.action](state, step.object_id)
        except (PlanError, KeyError):
            return False
        return self.tools.progress_check(self.task, state.world).success

    def _items(
        self, steps: list[ExpertSubgoal], world: World, location: ObjectLocation | None
    ) -> list[CommandItem]:
        first = steps[0]
        items: list[CommandItem] = []
        if world.agent.held != first.object_id and first.action is not SubgoalAction.NAVIGATE:
            stand = None
            if location is not None and location.stand is not None:
                stand = StandHint(*location.stand, horizon=location.horizon)
            items.append(CommandItem(Subgoal(SubgoalAction.NAVIGATE, first.object_type), stand=stand))
        clicks = self._clicks(steps, world, location) if self.info == "full" else []
        for index, step in enumerate(steps):
            click = ClickHint(*clicks[index]) if index < len(clicks) else None
            items.append(CommandItem(step.subgoal, click=click))
        return items

    def _clicks(
        self, steps: list[ExpertSubgoal], world: World, location: ObjectLocation | None
    ) -> list[tuple[float, float]]:
        """Where to click for each step in turn, from the hinted pose, as the ground-truth segmentation
        shows it after the steps before (ToggleOn then ToggleOff, Place on a plate then Pickup the plate):
        the steps are tried on a copy of the world; the list stops at the first step without a click."""
        if location is None or location.stand is None or location.click is None or location.horizon is None:
            return []
        trial = world.copy()
        x, z, yaw = location.stand
        trial.agent = replace(trial.agent, x=x, z=z, yaw=int(yaw) % 360, horizon=location.horizon)
        simulator = Simulator(trial, self.tools.camera, look_step_deg=self.tools.look_step_deg)
        clicks = [location.click]
        for index, step in enumerate(steps):
            if index > 0:
                click = self.tools.click_from_here(simulator.world, step.object_id, step.action.value)
                if click is None:
                    break
                clicks.append(click)
            if index + 1 < len(steps) and not simulator.step(step.action.value, *clicks[index]).success:
                break
        return clicks


def _without_no_ops(plan: list[ExpertSubgoal], world: World) -> list[ExpertSubgoal]:
    """The plan without "Pickup X, Place Y" pairs where X already lies in Y (a recipe that puts the food in
    the pot asks for it even when the follower already did; the food in the pot may not even be clickable)."""
    kept: list[ExpertSubgoal] = []
    index = 0
    while index < len(plan):
        step = plan[index]
        after = plan[index + 1] if index + 1 < len(plan) else None
        if (
            step.action is SubgoalAction.PICKUP
            and after is not None
            and after.action is SubgoalAction.PLACE
            and world.agent.held != step.object_id
            and step.object_id in world.objects  # not a slice the plan is yet to cut
            and world.objects[step.object_id].parent_id == after.object_id
        ):
            index += 2
            continue
        kept.append(step)
        index += 1
    return kept or plan


def _next_steps(plan: list[ExpertSubgoal]) -> tuple[list[ExpertSubgoal], int]:
    """The first interaction and those right after it on the same object (ToggleOn then ToggleOff), and
    the index in ``plan`` just past them; the plan's Navigate steps are left out (the instruction says where
    to go itself)."""
    first = next((i for i, step in enumerate(plan) if step.action is not SubgoalAction.NAVIGATE), None)
    if first is None:
        return [plan[-1]], len(plan)
    steps = [plan[first]]
    end = first + 1
    while end < len(plan):
        step = plan[end]
        if step.action is not SubgoalAction.NAVIGATE and step.object_id != steps[0].object_id:
            break
        if step.action is not SubgoalAction.NAVIGATE:
            steps.append(step)
        elif step.object_id != steps[0].object_id:
            break
        end += 1
    return steps, end


_APPLY: dict[SubgoalAction, Callable[[PlanState, str], object]] = {
    SubgoalAction.NAVIGATE: PlanState.navigate,
    SubgoalAction.PICKUP: PlanState.pickup,
    SubgoalAction.PLACE: PlanState.place,
    SubgoalAction.OPEN: PlanState.open,
    SubgoalAction.CLOSE: PlanState.close,
    SubgoalAction.TOGGLE_ON: lambda state, object_id: state.toggle(object_id, on=True),
    SubgoalAction.TOGGLE_OFF: lambda state, object_id: state.toggle(object_id, on=False),
    SubgoalAction.SLICE: PlanState.slice,
    SubgoalAction.POUR: PlanState.pour,
}
"""Each subgoal action as the planner's own state change (``PlanState``'s primitives)."""


def _where(location: ObjectLocation) -> str:
    inside = f" in/on {location.parents[0]}" if location.parents else ""
    x, _, z = location.position
    stand = "no standing pose found" if location.stand is None else f"stand at {location.stand}"
    return f"{location.object_id}{inside} at ({x:.2f}, {z:.2f}); {stand}"
