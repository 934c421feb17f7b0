"""JARVIS's action-level executor (seed 002, Algorithm 3) with Table 5's action predicates.

Each step: judge the previous action (Success; on success advance the subgoal pointer and apply its effect
to the belief, ``ExecutePostActionProcess``), then pursue the subgoal at the pointer:

- Navigate X is done when Interactive(X) holds: X observed in this frame with pixels within reach.
- An interaction with X acts when Interactive holds, clicking an interior pixel of X's mask (``clicks``);
  otherwise it first navigates (the plan may lack the Navigate).
- Getting there: Target(X) (X in the map, FindInMap) -> the navigator walks to the cells from which X can
  be reached (``interaction_goal_cells``) and faces it; on arrival the camera pitches toward X's height.
  Not seeing X there -> FindTargetNearDestination: other pitches, then other standing cells ("delta
  moves"); after several rounds Ignore(X): the mapped X is a false detection. X not in the map -> search
  (``search``: look around, frontier exploration, open closed containers).
- A failed interaction tries another pixel or instance, then another standing cell; Open, Close, Toggle
  and Pour that change nothing twice on one instance already are in the wanted state; a subgoal that keeps
  failing is dropped and the rest of the plan repaired from the current belief (JARVIS Algorithm 2's
  rules; "a failed subgoal goes back to repair and planning").
- Line 80: a failed motion is never repeated; a random feasible motion replaces it.
- TEACh's limits (1000 steps, 30 failed actions) end the episode with Stop.

HLSM (seed 000, §4.3) does the same low-level loop with its own navigation and interaction-pose sampling;
where the two differ we take what works in AI2-THOR (reach within 1.5 m, 90° turns, 30° or 15° looks).
This module holds the step itself; the parts it calls are mixins over ``step.StepContext``: ``choice``
(which instance), ``approach`` (getting there), ``search`` (finding it), ``motion`` (moving safely).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from agent.executor.choice import ROW_REACH_M, ROW_SWITCH_GAP_M
from agent.executor.clicks import Click, ClickPurpose, VisibleInstance, held_type_in_view
from agent.executor.config import ExecutorConfig
from agent.executor.hints import HintFollowing
from agent.executor.motion import OPPOSITE_TURN, GuardedNavigator, MotionSafety, turn_key
from agent.executor.room import MakeRoom
from agent.executor.standin import KindStandIn, SlicingStandIn
from agent.executor.state import Attempt, ExecutorState, FailedClick, Pending, Point
from agent.executor.step import Act, Done, GiveUp, Outcome, StepInputs
from agent.executor.success import instance_colour
from agent.geometry import project_points
from agent.navigation.base import Navigator
from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.predicates import interactive
from symbolic.repair import RepairEvent, repair_plan
from symbolic.subgoals import ACTION_NAME_FOR_SUBGOAL, Subgoal, SubgoalAction
from symbolic.thor import MOTION_ACTIONS, OBJECT_ACTIONS

A = SubgoalAction

STATE_ACTIONS: frozenset[str] = frozenset({"Open", "Close", "ToggleOn", "ToggleOff", "Pour"})
"""Object actions that fail (changing nothing) when the object already is in the wanted state."""

ROW_SWITCHES: frozenset[str] = frozenset({"StoveKnob"})
"""Switches that come in a row, each for one of several appliances of a kind (a stove's burners)."""
ROW_SPACING_M = 0.3
"""Metres: the farthest apart two neighbouring switches of a row stand (the generator's stove knobs 0.15-0.25
m)."""

STOP = "Stop"
MAX_SUBGOALS_PER_STEP = 16
"""Navigate subgoals can finish without an action; this bounds the chain of them in one step."""


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


class Executor:
    """Algorithm 3 for one session (module docstring); ``decide`` is called once per step."""

    def __init__(
        self,
        ontology: Ontology,
        navigator: Navigator,
        belief: BeliefState,
        rng: np.random.Generator,
        config: ExecutorConfig | None = None,
    ) -> None:
        self.ontology = ontology
        self.navigator = GuardedNavigator(navigator)
        self.config = config or ExecutorConfig()
        self.state = ExecutorState(belief=belief)
        self.rng = rng

    # ----- one step ----------------------------------------------------------------------------------
    def decide(self, inputs: StepInputs, plan: Sequence[Subgoal], pointer: int) -> Decision:
        """The next action for the plan at ``pointer`` (Algorithm 3 lines 59-82)."""
        run = _Run(
            ontology=self.ontology,
            navigator=self.navigator,
            rng=self.rng,
            config=self.config,
            state=self.state,
            inputs=inputs,
            plan=list(plan),
            pointer=pointer,
        )
        return run.decide()


class _Run(MakeRoom, HintFollowing, MotionSafety, SlicingStandIn, KindStandIn):
    """One call of ``Executor.decide`` (module docstring): the step itself, on top of the mixins."""

    def decide(self) -> Decision:
        self._judge_previous()
        self._note_containers()
        self._lift_ignored_in_sight()
        limit = self._limit_reached()
        if limit is not None:
            return self._stop(limit)
        for _ in range(MAX_SUBGOALS_PER_STEP):
            if self.pointer >= len(self.plan) and not self._retry_given_up():
                return self._stop("plan done: every subgoal was executed", plan_done=True)
            subgoal = self.plan[self.pointer]
            if self._stand_in(subgoal) or self._kin_stand_in(subgoal):
                subgoal = self.plan[self.pointer]
            attempt = self._attempt_for(subgoal)
            outcome = self._pursue(subgoal, attempt)
            if isinstance(outcome, Act):
                return self._act(outcome, subgoal)
            if isinstance(outcome, Done):
                self._complete(subgoal, outcome.reason, outcome.point)
            elif not self._kin_instead_of_giving_up(subgoal):
                self._give_up(subgoal, outcome)
                if self.state.given_up > self.cfg.max_given_up:
                    return self._stop(f"{self.state.given_up} subgoals given up; stopping")
        return self._stop(f"more than {MAX_SUBGOALS_PER_STEP} subgoals ended in one step")

    def _limit_reached(self) -> str | None:
        if self.inputs.step >= self.cfg.max_steps:
            return f"step limit: {self.cfg.max_steps} actions (TEACh)"
        if self.state.failed_actions >= self.cfg.max_failed_actions:
            limit = self.cfg.max_failed_actions
            return f"failure limit: {self.state.failed_actions} failed actions (TEACh allows {limit})"
        return None

    def _stop(self, reason: str, plan_done: bool = False) -> Decision:
        self.state.pending = None
        subgoal = self.plan[self.pointer] if self.pointer < len(self.plan) else None
        return self._decision(STOP, None, None, reason, stop=True, plan_done=plan_done, subgoal=subgoal)

    def _act(self, outcome: Act, subgoal: Subgoal) -> Decision:
        action, reason = outcome.action, outcome.reason
        manoeuvre = self.state.manoeuvre
        if manoeuvre and (action not in MOTION_ACTIONS or self.inputs.last_success is False):
            manoeuvre.clear()  # it can act now, or the manoeuvre failed
        if manoeuvre and action in MOTION_ACTIONS:
            action = manoeuvre.pop(0)
            reason = f"Collision: making room to turn with what is held: {action}"
        elif action in OPPOSITE_TURN and self._turn_blocked(action):
            action = self._sidestep(action)
            if action.startswith("Pan"):  # turn where there is room, then step back in facing the way wanted
                manoeuvre.extend([outcome.action, "Forward"])
            reason = f"Collision: {outcome.action} would swing what is held into something; {action} first"
        elif (
            action in MOTION_ACTIONS
            and self.inputs.last_success is False
            and action == self.state.last_failed_action
        ):
            action = self._random_feasible_motion(exclude=action)
            reason = (
                f"Collision: {outcome.action} just failed; random feasible {action} instead (Alg. 3 l. 81)"
            )
        click = outcome.click if action == outcome.action else None
        colour = box = before = None
        if click is not None:
            colour = instance_colour(self.inputs.observation, self.inputs.digest, click.instance_id)
            visit = self.state.attempt.search.visit if self.state.attempt is not None else None
            kind = visit.object_type if outcome.purpose == "search" and visit is not None else subgoal.obj
            if action == "Open" and kind in self.onto.enclosing:
                box = self._container_box(kind, click)
                before = self._footprint(kind, click.point)
        self.state.pending = Pending(
            action=action,
            purpose=outcome.purpose if action == outcome.action else "motion",
            plan_index=self.pointer,
            pose=self.pose,
            click=click,
            colour=colour,
            box=box,
            before=before,
        )
        x, y = (click.x, click.y) if click is not None else (None, None)
        return self._decision(action, x, y, reason, subgoal=subgoal, path=outcome.path)

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
        return Decision(
            action=action,
            x=x,
            y=y,
            reason=reason,
            plan=tuple(self.plan),
            pointer=self.pointer,
            repairs=tuple(self.repairs),
            events=tuple(self.events),
            stop=stop,
            plan_done=plan_done,
            question=self.question,
            target_type=subgoal.obj if subgoal is not None else None,
            path=path,
        )

    def _judge_previous(self) -> None:
        """Algorithm 3 lines 61-66: success advances the pointer and the belief, failure is remembered."""
        pending, success = self.state.pending, self.inputs.last_success
        self.state.pending = None
        if pending is None:
            return
        if success is False:
            self.state.failed_actions += 1
            self.state.last_failed_action = pending.action
            held = self.state.belief.held
            if pending.action in OPPOSITE_TURN and held is not None:  # too long to turn with, here (AI2-THOR)
                self.state.blocked_turns.append(turn_key(pending.pose, pending.action))
                if held not in self.state.long_held:
                    self.state.long_held.append(held)
        else:
            self.state.last_failed_action = None
        if pending.action not in OBJECT_ACTIONS:
            return
        if pending.purpose == "search":
            self._judge_search_action(pending, success is not False)
            return
        attempt = self.state.attempt
        if attempt is None or pending.plan_index != self.pointer or attempt.index != self.pointer:
            return
        subgoal = self.plan[self.pointer]
        click = pending.click
        if pending.action == "ToggleOn" and subgoal.action is A.TOGGLE_OFF and click is not None:
            self._judge_late_switch(subgoal, click, success is not False)
            return
        if success is not False:
            if (
                pending.action == "Pickup"
                and click is not None
                and not self.view.percept.persistent_ids
                and not self._from_own_slot(subgoal.obj, click)
            ):
                looks_like = self._held_look(subgoal.obj)
                if looks_like is not None:
                    self._wrong_pickup(subgoal, click, looks_like)
                    return
            point, instance_id = (click.point, click.instance_id) if click is not None else (None, None)
            if click is not None and self._more_switches(subgoal, attempt, click, changed=True):
                return
            opened_box = self._opened_box(subgoal.obj, pending) if pending.action == "Open" else None
            if opened_box is not None:
                self.state.memory.opened_box[subgoal.obj] = opened_box
            if pending.action == "Open":
                self._learn_front(subgoal.obj, pending)
            self._complete(subgoal, f"Success({pending.action} {subgoal.obj})", point, instance_id)
            return
        attempt.failures += 1
        if click is not None:
            attempt.failed_clicks.append(FailedClick.of(click, pending.pose))
            persistent = self.view.percept.persistent_ids
            failures_here = attempt.instance_failures(click.instance_id, click.point, persistent)
            # Twice nothing changed on the true X: it is already in that state. Learned segmentation may
            # have named a counter "Faucet": its spot is ruled out below, and only a second spot that
            # changes nothing twice means the state is already there.
            unchanged = persistent or attempt.failures >= 2 * self.cfg.retries_per_instance
            if pending.action in STATE_ACTIONS and failures_here >= 2 and unchanged:
                if self._more_switches(subgoal, attempt, click, changed=False):
                    return
                self._complete(
                    subgoal,
                    f"{pending.action} {subgoal.obj} changed nothing twice: already in that state",
                    click.point,
                )
                return
            if attempt.failures >= self.cfg.failures_before_room and self._make_room(subgoal, click):
                return
            if subgoal.action is A.PLACE and failures_here >= 2:
                full = self._extent_of(click.instance_id)  # AI2-THOR tried every spot on it: full
                if full is not None:
                    attempt.full.append(full)
            if not persistent and failures_here >= self.cfg.retries_per_instance:
                self._rule_out_click(
                    subgoal.obj, click, f"{pending.action} failed {failures_here} times there"
                )
            if attempt.failures % self.cfg.failures_per_stand == 0:
                attempt.bad_stands.append((pending.pose.x, pending.pose.z))
        self.events.append(f"{pending.action} {subgoal.obj} failed ({attempt.failures} so far)")

    def _held_look(self, wanted: str) -> str | None:
        """What the hand shows after a Pickup of ``wanted``, when it is clearly something else."""
        view = self.view
        classes = view.map.classes
        pickupable = frozenset(name for name in classes.types if self.onto.get(name).pickupable)
        if view.hand_class_ids is not None:  # estimated depth: the hand's region, as the network read it
            class_ids, hand = view.hand_class_ids, view.hand_class_ids > 0
        else:
            class_ids = view.percept.class_ids
            hand = (view.distances > 0) & (view.distances < self.cfg.click.holding_min_distance_m)
        return held_type_in_view(
            class_ids, hand, classes.types, pickupable, wanted, self.cfg.held_check_min_share
        )

    def _wrong_pickup(self, subgoal: Subgoal, click: Click, looks_like: str) -> None:
        """A Pickup X that took something else (learned segmentation misnamed it): the belief holds what
        the hand shows, the spot is ruled out for X, and repair puts the thing down before X is fetched
        again (``pickup-needs-free-hands``)."""
        self._rule_out_click(subgoal.obj, click, f"what it picked up there looks like a {looks_like}")
        self.state.belief.held = looks_like
        self.state.attempt = None
        self._repair_rest(self.plan[self.pointer :])

    def _repair_rest(self, rest: Sequence[Subgoal]) -> None:
        """Repair ``rest`` from the current belief and make it the plan from the pointer on, logging each
        fix at its place in the whole plan."""
        repaired = repair_plan(rest, self.onto, self.state.belief)
        self.repairs.extend(
            RepairEvent(e.rule, e.index + self.pointer, e.reason, e.removed, e.inserted) for e in repaired.log
        )
        self.plan = self.plan[: self.pointer] + list(repaired.plan)

    def _more_switches(self, subgoal: Subgoal, attempt: Attempt, click: Click, changed: bool) -> bool:
        """For a switch of a row (``ROW_SWITCHES``: which stove knob heats which burner is not written on
        it), note the one just switched; True while another of the row is still to switch. Turning every
        knob on, and later off again, heats the pot whichever burner it stands on."""
        obj = subgoal.obj
        if obj not in ROW_SWITCHES or subgoal.action not in (A.TOGGLE_ON, A.TOGGLE_OFF):
            return False
        on = self.state.memory.switched_on.setdefault(obj, [])
        where = click.point
        if subgoal.action is A.TOGGLE_OFF and self.view.percept.persistent_ids:
            on[:] = [item for item in on if item[0] != click.instance_id]
        elif subgoal.action is A.TOGGLE_OFF:
            turned = self._turned_on_at(on, click.point)
            if turned is not None:
                on.remove(turned)
                where = turned[1]
        attempt.switched.append((click.instance_id, where))
        if subgoal.action is A.TOGGLE_ON and changed:
            on.append((click.instance_id, click.point))
        if subgoal.action is A.TOGGLE_OFF and changed and not self.view.percept.persistent_ids:
            attempt.late_switch = self._late_switch(obj, attempt)
            if attempt.late_switch is not None:
                return True
        left = self._switches_left(subgoal, attempt)
        if left:
            self.events.append(f"{subgoal}: switched one; {left} more of the row to switch")
        elif subgoal.action is A.TOGGLE_ON and changed and not attempt.row_panned:
            attempt.row_pan = self._pan_past_edge([point for _, point in attempt.switched])
            return attempt.row_pan is not None
        return left > 0

    @staticmethod
    def _turned_on_at(on: list[tuple[int, Point]], point: Point) -> tuple[int, Point] | None:
        """Which of the switches the agent turned on a ToggleOff clicked at ``point`` was, under learned
        perception (a frame's own ids name nothing later): the one remembered nearest, within half a row's
        spacing. Learned depth puts a knob's point 0.1 m off where it was at the ToggleOn, so matching
        within ``ROW_SWITCH_GAP_M`` left knobs already off counted as on, and each was clicked again,
        "already in that state" (generated valid_unseen game 28)."""
        near = [(math.hypot(p[0] - point[0], p[2] - point[2]), k) for k, (_, p) in enumerate(on)]
        distance, k = min(near, default=(math.inf, -1))
        return on[k] if distance <= ROW_SPACING_M / 2 else None

    def _late_switch(self, obj: str, attempt: Attempt) -> Click | None:
        """A switch of the row in view now, while the row is turned off, that the agent never switched: to
        turn on (and then off with the rest). Under learned segmentation a glowing knob hides its neighbours
        from the network: in generated valid_unseen game 88 the knob beside the one turned on showed only
        once that one was off again, and it was the pot's burner's. Asked under learned segmentation only:
        under true segmentation the row's knobs are mapped before the first is turned on."""
        on = self.state.memory.switched_on.get(obj, [])
        done = [p for _, p in on] + [p for _, p in attempt.switched] + attempt.late_switched
        first = attempt.switched[0][1]
        for seen in self.view.visible(obj):
            point = seen.point
            if math.hypot(point[0] - first[0], point[2] - first[2]) > ROW_REACH_M:
                continue
            if any(math.hypot(point[0] - p[0], point[2] - p[2]) <= ROW_SPACING_M / 2 for p in done):
                continue
            click = self._click_on(seen, attempt, "object")
            if click is not None:
                return click
        return None

    def _judge_late_switch(self, subgoal: Subgoal, click: Click, succeeded: bool) -> None:
        """A late switch turned on (``_late_switch``) is remembered on, so this subgoal turns it off too."""
        if succeeded:
            self.state.memory.switched_on.setdefault(subgoal.obj, []).append((click.instance_id, click.point))
            self.events.append(f"{subgoal}: turned on one of the row seen only now; off with the rest")
        else:
            self.events.append(f"{subgoal}: one of the row seen only now did not turn on")

    def _pan_past_edge(self, switched: list[Point]) -> str | None:
        """A sideways step toward the view's edge when every switch of a row known is switched and another
        could stand past that edge: the spot one knob spacing beyond an end of the switched ones, across the
        view, is out of the frame on that side only (the spacing of the switched ones, or ``ROW_SPACING_M``
        for one alone: with 0.3 m a row of three 0.19 m apart, all in view, looked longer than the frame).
        A knob near the left edge was taken for the whole row, and it was another burner's (generated
        valid_unseen games 28 and 88); with the model's plan, two knobs in view were taken for the row, and
        the third, the pot's burner's, lay past the right edge (game 16). A step, not a turn: the agent
        faces the row's front to click a knob, and from the side learned segmentation does not find knobs.
        None when both or neither such spot is out of the frame. The step is taken whatever the map says of
        the floor there: learned depth spreads a counter's front into the floor beside the agent (game 88:
        the map held a step blocked that the simulator allowed), and a step that fails costs only itself."""
        yaw = math.radians(self.pose.yaw)
        across = np.array([math.cos(yaw), 0.0, -math.sin(yaw)])  # unit vector to the view's right
        points = np.array(switched)  # [N, 3]
        along = points @ across
        gaps = np.diff(np.sort(along))
        gaps = gaps[gaps >= ROW_SWITCH_GAP_M]
        spacing = float(gaps.min()) if len(gaps) else ROW_SPACING_M
        ends = points[[int(np.argmin(along)), int(np.argmax(along))]]
        beside = ends + np.stack([-across, across]) * spacing  # [2, 3] world points past either end
        _, cols, _ = project_points(beside, self.view.camera, self.pose)
        past_left, past_right = bool((cols < 0).any()), bool((cols >= self.view.camera.width).any())
        if past_left == past_right:
            return None
        move = "Pan Left" if past_left else "Pan Right"
        self.events.append(f"the knobs switched end near the view's edge; {move} to see the rest of the row")
        return move

    def _attempt_for(self, subgoal: Subgoal) -> Attempt:
        attempt = self.state.attempt
        if attempt is None or attempt.index != self.pointer or attempt.subgoal != subgoal:
            attempt = Attempt(index=self.pointer, subgoal=subgoal, first_step=self.inputs.step)
            self.state.attempt = attempt
            memory = self.state.memory
            obj = subgoal.obj
            attempt.hint = self._hint_for(subgoal)
            if memory.pins and memory.pins[0][:2] == (subgoal.action.value, obj):
                attempt.pinned = memory.pins.pop(0)[2]
                return attempt
            placed = obj in self.state.belief.placed
            if subgoal.action is A.NAVIGATE and placed and obj in memory.where and self._means_another(obj):
                x, _, z = memory.where.pop(obj)
                self._done_with(obj, x, z)
                memory.placed_into.pop(obj, None)
                attempt.any_instance = True
                self.events.append(f"{subgoal}: another {obj} than the one put down at ({x:.2f}, {z:.2f})")
            elif subgoal.action is A.NAVIGATE and placed:
                self._pin_put_down(obj)
            went = self._just_put_down(obj) or obj in memory.placed_into
            if subgoal.action is A.PICKUP and placed and went and self._means_another(obj):
                # "Place Bowl, Pickup LettuceSliced": the next slice; "Open Cabinet, Pickup Cup, ... Place
                # Cabinet" after a cup went into a cabinet: the next cup, not the one put away
                attempt.any_instance = True
                memory.placed_into.pop(obj, None)
                if obj in memory.where:
                    x, _, z = memory.where[obj]
                    self._done_with(obj, x, z)
                    self.events.append(f"{subgoal}: another {obj} than the one put at ({x:.2f}, {z:.2f})")
        return attempt

    def _done_with(self, obj: str, x: float, z: float) -> None:
        """The X the agent put down at (x, z) is finished with: remember the spot and, when known, the
        instance (slices lie 0.2 m from the bowl they go into; a spot alone would rule them out too)."""
        memory = self.state.memory
        memory.done_with.setdefault(obj, []).append((x, z))
        instance_id = memory.instance.get(obj)
        if instance_id is not None:
            memory.done_ids.setdefault(obj, []).append(instance_id)

    def _complete(
        self,
        subgoal: Subgoal,
        reason: str,
        point: tuple[float, float, float] | None,
        instance_id: int | None = None,
    ) -> None:
        """ExecutePostActionProcess: the belief takes the subgoal's effect, memory where it happened."""
        belief, memory = self.state.belief, self.state.memory
        obj = subgoal.obj
        if point is not None and subgoal.action is not A.NAVIGATE:
            memory.where[obj] = point
            if subgoal.action is A.PLACE and belief.held is not None:
                memory.where[belief.held] = point
                memory.placed_into.setdefault(belief.held, []).append(obj)
                if obj in self.onto.enclosing:
                    memory.stored_in[obj] = (point, instance_id)
            sliced = self.onto.get(obj).sliced_into
            if subgoal.action is A.SLICE and sliced is not None:
                memory.where[sliced] = point
                memory.source[sliced] = point
        if subgoal.action is A.PICKUP:
            memory.where.pop(obj, None)
        if subgoal.action in (A.PICKUP, A.OPEN) and instance_id is not None:
            memory.instance[obj] = instance_id

        self.state.belief = belief.apply(subgoal, self.onto)
        self.state.completed.append(subgoal)
        self.state.attempt = None
        self.pointer += 1
        self.events.append(f"done {subgoal}: {reason}")

    def _pin_put_down(self, obj: str) -> None:
        """A Navigate back to the X the agent put down ("Place SinkBasin, ToggleOn Faucet, ToggleOff Faucet,
        Navigate Mug, Pickup Mug": the mug just filled) makes the belief forget that X was placed, as for
        another X; when ``_means_another`` says it is the same one, the Pickup after is pinned to it, so
        the dry mug beside the sink is not taken instead."""
        upcoming = [s for s in self.plan[self.pointer + 1 :] if s.action is not A.NAVIGATE]
        instance_id = self.state.memory.instance.get(obj)
        if instance_id is None or not upcoming or upcoming[0] != Subgoal(A.PICKUP, obj):
            return
        self.state.memory.pins.insert(0, (A.PICKUP.value, obj, instance_id))

    def _give_up(self, subgoal: Subgoal, outcome: GiveUp) -> None:
        """A failed subgoal goes back to repair: drop it, repair the rest from the current belief. It and
        what repair dropped with it (a Place after a Pickup that failed) wait for ``_retry_given_up``."""
        self.state.given_up += 1
        self.state.attempt = None
        if outcome.question is not None:
            self.question = outcome.question
        self.repairs.append(
            RepairEvent("subgoal-failed", self.pointer, outcome.reason, removed=(subgoal,), inserted=())
        )
        rest = self.plan[self.pointer + 1 :]
        self._repair_rest(rest)
        self.state.retry.extend([subgoal, *_dropped(rest, self.plan[self.pointer :])])
        self.events.append(f"gave up {subgoal}: {outcome.reason}")

    def _retry_given_up(self) -> bool:
        """The plan ran out with subgoals given up: try them once more, repaired from the current belief,
        when the episode has actions and failures to spare. JARVIS sends a failed subgoal back to repair
        and planning, but nothing plans it again when the plan is the oracle's, and with learned
        segmentation a Place given up after six clicks on misnamed spots ended a game at step 35 with the
        cup still in hand; on the second round those spots stay ruled out and others are tried."""
        cfg, state = self.cfg, self.state
        spare_steps = cfg.max_steps - self.inputs.step >= cfg.retry_min_steps
        spare_failures = cfg.max_failed_actions - state.failed_actions >= cfg.max_failures
        if not state.retry or state.retry_rounds >= cfg.retry_rounds or not (spare_steps and spare_failures):
            return False
        queued, state.retry = state.retry, []
        state.retry_rounds += 1
        repaired = repair_plan(queued, self.onto, state.belief)
        if not repaired.plan:
            return False
        reason = f"the plan ran out with {len(queued)} subgoals given up; trying them once more"
        self.repairs.append(RepairEvent("retry-given-up", self.pointer, reason, (), tuple(repaired.plan)))
        self.plan = [*self.plan, *repaired.plan]
        self.events.append(reason)
        return True

    def _before_front(self, obj: str, chosen: VisibleInstance) -> bool:
        """For a container (Fridge, Cabinet...): the agent stands on its front side, where its inside will
        show once open; for anything else, always."""
        if not self._needs_inside(obj):
            return True
        body = self._container_body(obj, chosen.point)
        front = self._front_cells(body) if body is not None else None
        if front is None:
            return True
        return bool(front[self.view.map.world_to_cell(self.pose.x, self.pose.z)])

    def _pursue(self, subgoal: Subgoal, attempt: Attempt) -> Outcome:
        attempt.steps += 1
        if attempt.steps > self.cfg.max_steps_per_subgoal:
            return GiveUp(f"no progress on {subgoal} in {self.cfg.max_steps_per_subgoal} actions")
        if attempt.failures >= self.cfg.max_failures:
            return GiveUp(f"{subgoal} failed {attempt.failures} times")
        obj = subgoal.obj
        if attempt.switched:
            attempt.switch_steps += 1
            if attempt.switch_steps > self.cfg.row_switch_steps:
                return Done(f"switched {len(attempt.switched)} of the {obj} row; the rest is out of reach")
            if attempt.row_pan is not None:
                move, attempt.row_pan, attempt.row_panned = attempt.row_pan, None, True
                return Act(move, f"{subgoal}: the rest of the row may lie past the view's edge")
            if attempt.late_switch is not None:
                late, attempt.late_switch = attempt.late_switch, None
                attempt.late_switched.append(late.point)
                return Act(
                    "ToggleOn",
                    f"{subgoal}: one of the row seen only now was never switched: on, then off with the rest",
                    purpose="plan",
                    click=late,
                )
            if attempt.row_panned and not self._switches_left(subgoal, attempt):
                return Done(f"switched {len(attempt.switched)} of the {obj} row; no more of it in view")
        if subgoal.action is A.NAVIGATE:
            if self.state.belief.held == obj:
                return Done(f"IsGrasped: {obj} is in hand")
            followed = self._follow_stand(attempt)
            if followed is not None:
                return followed
            chosen = self._chosen_visible(obj, attempt)
            if chosen is not None and interactive(self.view, obj) and self._before_front(obj, chosen):
                return Done(f"Interactive({obj}): observed {chosen.nearest_m:.2f} m away")
            return self._approach(obj, attempt)
        action = ACTION_NAME_FOR_SUBGOAL[subgoal.action]
        hinted = self._hinted_click(attempt)
        if hinted is not None:
            return Act(action, f"Hint: {action} where the commander said", purpose="plan", click=hinted)
        chosen = self._chosen_visible(obj, attempt)
        if chosen is not None:
            purpose: ClickPurpose = "surface" if subgoal.action is A.PLACE else "object"
            click = self._click_on(chosen, attempt, purpose)
            if click is not None:
                return Act(action, f"Interactive({action}, {obj})", purpose="plan", click=click)
        remembered = self._click_remembered(subgoal, attempt)
        if remembered is not None:
            where = "it was put down" if subgoal.action is A.PICKUP else "it was switched on"
            return Act(
                action,
                f"{action} {obj} where {where} (not recognised there)",
                purpose="plan",
                click=remembered,
            )
        return self._approach(obj, attempt)


def _dropped(before: Sequence[Subgoal], after: Sequence[Subgoal]) -> list[Subgoal]:
    """The subgoals of ``before`` that ``after`` (its repair) no longer has, in order: the longest common
    subsequence of the two is what repair kept, so what it inserted is passed over. Matching greedily
    instead paired a dropped "Place DiningTable" with the last one of the plan and counted everything
    between as dropped too: the retry then did the plate and the knife over again, and took the mug off
    the table (Breakfast game 23 of the generated valid_unseen)."""
    n, m = len(before), len(after)
    common = [[0] * (m + 1) for _ in range(n + 1)]  # common[i][j]: LCS length of before[i:] and after[j:]
    for i in range(n - 1, -1, -1):
        for j in range(m - 1, -1, -1):
            if before[i] == after[j]:
                common[i][j] = common[i + 1][j + 1] + 1
            else:
                common[i][j] = max(common[i + 1][j], common[i][j + 1])
    dropped, i, j = [], 0, 0
    while i < n:
        if j < m and before[i] == after[j]:
            i, j = i + 1, j + 1
        elif j < m and common[i][j + 1] >= common[i + 1][j]:
            j += 1
        else:
            dropped.append(before[i])
            i += 1
    return dropped
