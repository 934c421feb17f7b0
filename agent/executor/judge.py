"""Judging the previous action (JARVIS Algorithm 3 lines 61-66): once, when the next frame arrives.

``judge`` gives the verdict before the frame enters the map: whether the action worked (the session's
``infer_success``), what the hand now holds (the map leaves the held object out), the failure counts and
what a failed motion teaches. ``PreviousAction`` then draws the consequences for the plan, on the map
updated with the frame (an opened door's new cells tell the container's front): success advances the
pointer and the belief, an object action that changed nothing twice means the object already was in that
state, a failed Place into a full receptacle makes room, and under learned segmentation a spot whose
actions keep failing is ruled out, and a Pickup whose hand shows another type is put down and fetched again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from agent.executor.approach import Approach
from agent.executor.clicks import Click, held_type_in_view
from agent.executor.context import StepContext
from agent.executor.detections import FalseDetections
from agent.executor.fronts import ContainerFronts
from agent.executor.motion import note_outcome
from agent.executor.progress import PlanProgress
from agent.executor.room import MakeRoom
from agent.executor.state import ExecutorState, FailedClick, Verdict
from agent.executor.switches import RowSwitches
from agent.executor.visit import ContainerVisits
from symbolic.subgoals import Subgoal, SubgoalAction
from symbolic.thor import OBJECT_ACTIONS

A = SubgoalAction

STATE_ACTIONS: frozenset[str] = frozenset({"Open", "Close", "ToggleOn", "ToggleOff", "Pour"})
"""Object actions that fail (changing nothing) when the object already is in the wanted state."""


def judge(
    state: ExecutorState, success: bool | None, plan: Sequence[Subgoal], held_object: str | None
) -> Verdict:
    """The verdict on the action returned last step (``state.pending``), given whether it succeeded: the
    caller's ``held_object`` (when sent) overrides the believed hand; a Pickup or Place that just worked
    changes what the hand holds in this frame (else the object just picked up, floating before the camera,
    would be mapped); failures are counted. ``plan`` is the plan the pending action's index refers to."""
    belief = state.belief
    if held_object is not None and belief.held != held_object:
        belief.held = held_object
    pending = state.pending
    state.pending = None
    holding = belief.held is not None
    held_type = belief.held
    if pending is not None and success is not False:
        if pending.action == "Pickup":
            index = pending.plan_index
            holding = True
            held_type = plan[index].obj if index is not None and index < len(plan) else None
        elif pending.action == "Place":
            holding, held_type = False, None
    if pending is not None:
        if success is False:
            state.progress.failed_actions += 1
        note_outcome(state.motion, pending, success, belief.held)
    return Verdict(pending, success, holding, held_type if holding else None)


@dataclass(eq=False)
class PreviousAction:
    """The consequences of the verdict for the plan (module docstring)."""

    ctx: StepContext
    state: ExecutorState
    progress: PlanProgress
    switches: RowSwitches
    room: MakeRoom
    visits: ContainerVisits
    approach: Approach
    fronts: ContainerFronts
    detections: FalseDetections

    def apply(self, verdict: Verdict) -> None:
        """Algorithm 3 lines 61-66 for an object action: success advances the pointer and the belief,
        failure is remembered on the attempt (and may end it, make room, or rule a spot out)."""
        pending, success = verdict.pending, verdict.success
        if pending is None or pending.action not in OBJECT_ACTIONS:
            return
        if pending.purpose == "search":
            self.visits.judge(pending, success is not False, self.state.attempt)
            return
        ctx, cfg = self.ctx, self.ctx.cfg
        attempt = self.state.attempt
        if attempt is None or pending.plan_index != ctx.pointer or attempt.index != ctx.pointer:
            return
        subgoal = ctx.plan[ctx.pointer]
        click = pending.click
        if pending.action == "ToggleOn" and subgoal.action is A.TOGGLE_OFF and click is not None:
            self.switches.judge_late_switch(subgoal, click, success is not False)
            return
        if success is not False:
            if (
                pending.action == "Pickup"
                and click is not None
                and not ctx.view.percept.persistent_ids
                and not self.approach.from_own_slot(subgoal.obj, click)
            ):
                looks_like = self._held_look(subgoal.obj)
                if looks_like is not None:
                    self._wrong_pickup(subgoal, click, looks_like)
                    return
            point, instance_id = (click.point, click.instance_id) if click is not None else (None, None)
            if click is not None and self.switches.more_to_switch(subgoal, attempt, click, changed=True):
                return
            if pending.action == "Open":
                self.fronts.remember_opened(subgoal.obj, pending)
            self.progress.complete(subgoal, f"Success({pending.action} {subgoal.obj})", point, instance_id)
            return
        attempt.failures += 1
        if click is not None:
            attempt.failed_clicks.append(FailedClick.of(click, pending.pose))
            persistent = ctx.view.percept.persistent_ids
            failures_here = attempt.instance_failures(click.instance_id, click.point, persistent)
            # Twice nothing changed on the true X: it is already in that state. Learned segmentation may
            # have named a counter "Faucet": its spot is ruled out below, and only a second spot that
            # changes nothing twice means the state is already there.
            unchanged = persistent or attempt.failures >= 2 * cfg.retries_per_instance
            if pending.action in STATE_ACTIONS and failures_here >= 2 and unchanged:
                if self.switches.more_to_switch(subgoal, attempt, click, changed=False):
                    return
                reason = f"{pending.action} {subgoal.obj} changed nothing twice: already in that state"
                self.progress.complete(subgoal, reason, click.point)
                return
            if attempt.failures >= cfg.failures_before_room and self.room.make_room(subgoal, click):
                self.progress.drop_attempt()
                return
            if subgoal.action is A.PLACE and failures_here >= 2:
                full = self.fronts.extent_of(click.instance_id)  # AI2-THOR tried every spot: full
                if full is not None:
                    attempt.full.append(full)
            if not persistent and failures_here >= cfg.retries_per_instance:
                self.detections.rule_out(
                    subgoal.obj, click, f"{pending.action} failed {failures_here} times there"
                )
            if attempt.failures % cfg.failures_per_stand == 0:
                attempt.bad_stands.append((pending.pose.x, pending.pose.z))
        ctx.events.append(f"{pending.action} {subgoal.obj} failed ({attempt.failures} so far)")

    def _held_look(self, wanted: str) -> str | None:
        """What the hand shows after a Pickup of ``wanted``, when it is clearly something else."""
        ctx = self.ctx
        view = ctx.view
        classes = view.map.classes
        pickupable = frozenset(name for name in classes.types if ctx.onto.get(name).pickupable)
        if view.hand_class_ids is not None:  # estimated depth: the hand's region, as the network read it
            class_ids, hand = view.hand_class_ids, view.hand_class_ids > 0
        else:
            class_ids = view.percept.class_ids
            hand = (view.distances > 0) & (view.distances < ctx.cfg.click.holding_min_distance_m)
        return held_type_in_view(
            class_ids, hand, classes.types, pickupable, wanted, ctx.cfg.held_check_min_share
        )

    def _wrong_pickup(self, subgoal: Subgoal, click: Click, looks_like: str) -> None:
        """A Pickup X that took something else (learned segmentation misnamed it): the belief holds what
        the hand shows, the spot is ruled out for X, and repair puts the thing down before X is fetched
        again (``pickup-needs-free-hands``)."""
        ctx = self.ctx
        self.detections.rule_out(subgoal.obj, click, f"what it picked up there looks like a {looks_like}")
        ctx.belief.held = looks_like
        self.progress.drop_attempt()
        self.progress.repair_rest(ctx.plan[ctx.pointer :])
