"""JARVIS's action-level executor (seed 002, Algorithm 3) with Table 5's action predicates.

Each step: the previous action is judged (``judge``: Success; on success the subgoal pointer and the belief
advance, ``ExecutePostActionProcess``), then the subgoal at the pointer is pursued:

- Navigate X is done when Interactive(X) holds: X observed in this frame with pixels within reach.
- An interaction with X acts when Interactive holds, clicking an interior pixel of X's mask (``clicks``);
  otherwise it first navigates (the plan may lack the Navigate).
- Getting there: Target(X) (X in the map, FindInMap) -> the navigator walks to the cells from which X can
  be reached and faces it (``approach``); on arrival the camera pitches toward X's height. Not seeing X
  there -> FindTargetNearDestination: other pitches, then other standing cells; after several rounds
  Ignore(X) (``detections``). X not in the map -> search (``search``: look around, explore, open closed
  containers).
- A failed interaction tries another pixel or instance, then another standing cell; Open, Close, Toggle
  and Pour that change nothing twice on one instance already are in the wanted state; a subgoal that keeps
  failing is dropped and the rest of the plan repaired from the current belief (JARVIS Algorithm 2's
  rules; "a failed subgoal goes back to repair and planning", ``progress``), and the decision asks the
  session to re-plan.
- Line 80: a failed motion is never repeated; a random feasible motion replaces it (``motion``).
- TEACh's limits (1000 steps, 30 failed actions) end the episode with Stop.

HLSM (seed 000, §4.3) does the same low-level loop with its own navigation and interaction-pose sampling;
where the two differ we take what works in AI2-THOR (reach within 1.5 m, 90° turns, 30° or 15° looks).
This module holds the step itself; each job is a collaborator handed the step's ``StepContext``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from agent.executor import sightings
from agent.executor.approach import Approach
from agent.executor.choice import InstanceChoice
from agent.executor.clicks import ClickPurpose
from agent.executor.config import ExecutorConfig
from agent.executor.context import Act, Done, GiveUp, Outcome, StepContext, StepInputs
from agent.executor.detections import FalseDetections
from agent.executor.fronts import ContainerFronts
from agent.executor.hints import HintFollowing
from agent.executor.judge import PreviousAction, judge
from agent.executor.mapview import SessionMapView
from agent.executor.motion import MotionSafety
from agent.executor.progress import PlanProgress
from agent.executor.room import MakeRoom
from agent.executor.search import ContainerSearch
from agent.executor.standin import StandIns
from agent.executor.state import Attempt, ExecutorState, Hint, Pending, Point, Verdict
from agent.executor.success import FrameDigest, instance_colour
from agent.executor.switches import RowSwitches
from agent.executor.visit import ContainerVisits
from agent.geometry import Camera, Pose
from agent.mapping import SemanticMap
from agent.navigation.base import Navigator
from agent.perception.base import Observation, Percept
from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.predicates import interactive
from symbolic.repair import RepairEvent
from symbolic.subgoals import ACTION_NAME_FOR_SUBGOAL, Subgoal, SubgoalAction

A = SubgoalAction

STOP = "Stop"

ReplanReason = Literal["the plan ran out", "a subgoal failed"]
"""Why a decision asks for a new plan: the pointer reached the plan's end, or a subgoal was given up to
repair this step (and the episode goes on)."""


@dataclass(frozen=True)
class Decision:
    """The executor's answer for one step."""

    action: str
    x: float | None
    y: float | None
    reason: str  # the predicate or rule that chose the action
    plan: tuple[Subgoal, ...]  # the plan after this step (changed when a failed subgoal was repaired)
    pointer: int
    repairs: tuple[RepairEvent, ...]  # repairs made this step
    events: tuple[str, ...]  # what happened this step (subgoals done or given up, ignores, searches)
    stop: bool  # the executor ends the episode (limits) or the plan is done
    plan_done: bool  # the pointer reached the end of the plan
    question: str | None  # what the follower would ask the commander
    target_type: str | None  # the object the current subgoal is about
    path: tuple[tuple[int, int], ...] = ()  # map cells of the navigator's planned path
    replan: ReplanReason | None = None  # why a new plan would help now (the session decides whether)


class Executor:
    """Algorithm 3 for one session (module docstring). Each step the session calls ``judge`` before the
    frame enters the map, builds the step's view with ``map_view`` and calls ``decide``; after a re-plan
    the decision asked for, ``pursue`` goes on with the new plan in the same step."""

    def __init__(
        self,
        ontology: Ontology,
        navigator: Navigator,
        belief: BeliefState,
        rng: np.random.Generator,
        config: ExecutorConfig | None = None,
    ) -> None:
        self.ontology = ontology
        self.navigator = navigator
        self.config = config or ExecutorConfig()
        self.state = ExecutorState(belief=belief)
        self.rng = rng

    # ----- what the session reads and tells -----------------------------------------------------------
    @property
    def belief(self) -> BeliefState:
        """What the agent believes now (a re-plan repairs from it)."""
        return self.state.belief

    @property
    def completed(self) -> tuple[Subgoal, ...]:
        """The subgoals carried out so far, in order (a re-plan's history)."""
        return tuple(self.state.progress.completed)

    def new_plan(self, hints: Sequence[Hint] | None = None) -> None:
        """The planner gave a new plan: the given-up subgoals are not retried (the planner's word on what is
        left), and a commander's hints, when the plan came with them, replace the old ones."""
        self.state.progress.retry.clear()
        if hints is not None:
            self.state.hints = list(hints)

    def hint_stands(self) -> list[Pose]:
        """Where the commander's hints not yet used send the agent (the map must hold them, seen or not)."""
        return [hint.stand for hint in self.state.hints if hint.stand is not None]

    def remember(self, object_type: str, point: Point) -> None:
        """Where an object of ``object_type`` was acted on before the session began (an EDH history)."""
        self.state.memory.where[object_type] = point

    def clicked_colours(self, obs: Observation, frame: FrameDigest) -> tuple[np.ndarray, np.ndarray] | None:
        """The previous click's instance colour before and now (``instance_colour``), for judging an object
        action that changes no geometry; None without a click or a colour."""
        pending = self.state.pending
        if pending is None or pending.click is None or pending.colour is None:
            return None
        now = instance_colour(obs, frame, pending.click.instance_id)
        return None if now is None else (pending.colour, now)

    # ----- one step ----------------------------------------------------------------------------------
    def judge(self, success: bool | None, plan: Sequence[Subgoal], held_object: str | None = None) -> Verdict:
        """The previous action's verdict, before this step's frame enters the map (``judge.judge``)."""
        return judge(self.state, success, plan, held_object)

    def map_view(
        self,
        semantic_map: SemanticMap,
        percept: Percept,
        camera: Camera,
        pose: Pose,
        verdict: Verdict,
        hand_class_ids: np.ndarray | None = None,
    ) -> SessionMapView:
        """The step's view of the map and frame, with the spots this executor ruled out."""
        return SessionMapView(
            semantic_map,
            percept,
            camera,
            pose,
            holding=verdict.holding,
            held_type=verdict.held_type,
            last_success=verdict.success,
            ignored=self.state.detections.ignored,
            explore_attempts=self.state.detections.explore_attempts,
            click_config=self.config.click,
            stand_clearance_m=self.config.stand_clearance_m,
            hand_class_ids=hand_class_ids,
        )

    def decide(self, inputs: StepInputs, plan: Sequence[Subgoal], pointer: int) -> Decision:
        """The next action for the plan at ``pointer`` (Algorithm 3 lines 59-82): the consequences of the
        verdict in ``inputs.previous`` first, then the containers in view are noted, then the pursuit."""
        step = _Step(self, inputs, plan, pointer)
        step.previous.apply(inputs.previous)
        sightings.note_view(self.state.searched.containers, inputs.view, self.ontology, self.config.search)
        return step.pursue()

    def pursue(self, inputs: StepInputs, plan: Sequence[Subgoal], pointer: int) -> Decision:
        """The next action for a new plan in the step ``decide`` asked to re-plan in: the previous action is
        judged and the frame noted already."""
        return _Step(self, inputs, plan, pointer).pursue()


class _Step:
    """One pass of the executor over the plan in a step: its collaborators, wired to one ``StepContext``."""

    def __init__(self, executor: Executor, inputs: StepInputs, plan: Sequence[Subgoal], pointer: int) -> None:
        state = executor.state
        self.state = state
        self.ctx = ctx = StepContext(
            executor.ontology,
            executor.navigator,
            executor.rng,
            executor.config,
            inputs,
            list(plan),
            pointer,
            state.belief,
        )
        memory = state.memory
        self.detections = FalseDetections(ctx, state.detections)
        self.choice = InstanceChoice(ctx, memory)
        self.fronts = ContainerFronts(ctx, memory, state.searched.containers)
        self.motion = MotionSafety(ctx, state.motion)
        self.switches = RowSwitches(ctx, memory)
        self.hints = HintFollowing(ctx, state.hints, memory)
        self.approach = Approach(ctx, memory, self.choice, self.fronts, self.motion, self.detections)
        visits = ContainerVisits(
            ctx, memory, state.searched, self.choice, self.approach, self.fronts, self.motion, self.detections
        )
        self.search = ContainerSearch(
            ctx, memory, state.searched, state.detections, self.choice, self.approach, visits
        )
        self.stand_ins = StandIns(ctx, state.progress.missing, self.choice)
        self.progress = PlanProgress(ctx, state, self.choice, self.hints)
        room = MakeRoom(ctx, memory, self.fronts)
        self.previous = PreviousAction(
            ctx,
            state,
            self.progress,
            self.switches,
            room,
            visits,
            self.approach,
            self.fronts,
            self.detections,
        )

    def pursue(self) -> Decision:
        """Pursue the plan from the pointer until a subgoal needs an action (Navigates may finish without
        one, given-up subgoals are repaired away), or the episode ends."""
        ctx, state, cfg = self.ctx, self.state, self.ctx.cfg
        self.detections.lift_in_sight()
        limit = self._limit_reached()
        if limit is not None:
            return self._stop(limit)
        for _ in range(cfg.max_subgoals_per_step):
            if ctx.pointer >= len(ctx.plan) and not self.progress.retry_given_up():
                return self._stop("plan done: every subgoal was executed", plan_done=True)
            subgoal = ctx.plan[ctx.pointer]
            if self.stand_ins.slicing_tool(subgoal, state.attempt) or self.stand_ins.kin(subgoal):
                self.progress.drop_attempt()
                subgoal = ctx.plan[ctx.pointer]
            attempt = self.progress.attempt_for(subgoal)
            outcome = self._pursue(subgoal, attempt)
            if isinstance(outcome, Act):
                return self._act(outcome, subgoal)
            if isinstance(outcome, Done):
                self.progress.complete(subgoal, outcome.reason, outcome.point)
            elif self.stand_ins.kin_instead_of_giving_up(subgoal):
                self.progress.drop_attempt()
            else:
                self.progress.give_up(subgoal, outcome)
                if state.progress.given_up > cfg.max_given_up:
                    return self._stop(f"{state.progress.given_up} subgoals given up; stopping")
        return self._stop(f"more than {cfg.max_subgoals_per_step} subgoals ended in one step")

    def _limit_reached(self) -> str | None:
        cfg, failed = self.ctx.cfg, self.state.progress.failed_actions
        if self.ctx.inputs.step >= cfg.max_steps:
            return f"step limit: {cfg.max_steps} actions (TEACh)"
        if failed >= cfg.max_failed_actions:
            return f"failure limit: {failed} failed actions (TEACh allows {cfg.max_failed_actions})"
        return None

    def _pursue(self, subgoal: Subgoal, attempt: Attempt) -> Outcome:
        """The next action of the subgoal at the pointer, Done when it holds without one, or GiveUp."""
        ctx, cfg = self.ctx, self.ctx.cfg
        attempt.steps += 1
        if attempt.steps > cfg.max_steps_per_subgoal:
            return GiveUp(f"no progress on {subgoal} in {cfg.max_steps_per_subgoal} actions")
        if attempt.failures >= cfg.max_failures:
            return GiveUp(f"{subgoal} failed {attempt.failures} times")
        row = self.switches.pursue(subgoal, attempt)
        if row is not None:
            return row
        obj = subgoal.obj
        if subgoal.action is A.NAVIGATE:
            if ctx.belief.held == obj:
                return Done(f"IsGrasped: {obj} is in hand")
            followed = self.hints.follow_stand(attempt)
            if followed is not None:
                return followed
            chosen = self.choice.chosen_visible(obj, attempt)
            if chosen is not None and interactive(ctx.view, obj) and self.approach.before_front(obj, chosen):
                return Done(f"Interactive({obj}): observed {chosen.nearest_m:.2f} m away")
            return self.search.reach(obj, attempt)
        action = ACTION_NAME_FOR_SUBGOAL[subgoal.action]
        hinted = self.hints.hinted_click(attempt)
        if hinted is not None:
            return Act(action, f"Hint: {action} where the commander said", purpose="plan", click=hinted)
        chosen = self.choice.chosen_visible(obj, attempt)
        if chosen is not None:
            purpose: ClickPurpose = "surface" if subgoal.action is A.PLACE else "object"
            click = ctx.click_on(chosen, attempt, purpose)
            if click is not None:
                return Act(action, f"Interactive({action}, {obj})", purpose="plan", click=click)
        remembered = self.approach.click_remembered(subgoal, attempt)
        if remembered is not None:
            where = "it was put down" if subgoal.action is A.PICKUP else "it was switched on"
            return Act(
                action,
                f"{action} {obj} where {where} (not recognised there)",
                purpose="plan",
                click=remembered,
            )
        return self.search.reach(obj, attempt)

    def _act(self, outcome: Act, subgoal: Subgoal) -> Decision:
        """The decision for an action: made safe to take (``MotionSafety.guard``), and kept pending to be
        judged next step (with what an Open's judging will compare: the container's extent and footprint)."""
        ctx, state = self.ctx, self.state
        action, reason = self.motion.guard(outcome)
        click = outcome.click if action == outcome.action else None
        colour = box = before = None
        if click is not None:
            colour = instance_colour(ctx.inputs.observation, ctx.inputs.digest, click.instance_id)
            visit = state.attempt.search.visit if state.attempt is not None else None
            kind = visit.object_type if outcome.purpose == "search" and visit is not None else subgoal.obj
            if action == "Open" and kind in ctx.onto.enclosing:
                box = self.fronts.container_box(kind, click)
                before = self.fronts.footprint(kind, click.point)
        state.pending = Pending(
            action=action,
            purpose=outcome.purpose if action == outcome.action else "motion",
            plan_index=ctx.pointer,
            pose=ctx.pose,
            click=click,
            colour=colour,
            box=box,
            before=before,
        )
        x, y = (click.x, click.y) if click is not None else (None, None)
        return self._decision(action, x, y, reason, subgoal=subgoal, path=outcome.path)

    def _stop(self, reason: str, plan_done: bool = False) -> Decision:
        self.state.pending = None
        return self._decision(
            STOP, None, None, reason, subgoal=self.ctx.subgoal, stop=True, plan_done=plan_done
        )

    def _decision(
        self,
        action: str,
        x: float | None,
        y: float | None,
        reason: str,
        *,
        subgoal: Subgoal | None,
        stop: bool = False,
        plan_done: bool = False,
        path: tuple[tuple[int, int], ...] = (),
    ) -> Decision:
        ctx = self.ctx
        self.state.belief = ctx.belief
        replan: ReplanReason | None = None
        if plan_done:
            replan = "the plan ran out"
        elif ctx.gave_up and not stop:
            replan = "a subgoal failed"
        return Decision(
            action=action,
            x=x,
            y=y,
            reason=reason,
            plan=tuple(ctx.plan),
            pointer=ctx.pointer,
            repairs=tuple(ctx.repairs),
            events=tuple(ctx.events),
            stop=stop,
            plan_done=plan_done,
            question=ctx.question,
            target_type=subgoal.obj if subgoal is not None else None,
            path=path,
            replan=replan,
        )
