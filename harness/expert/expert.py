"""Run a plan in the simulator: the reference trajectory of a task, action by action, with click points.

The expert knows the whole world. It plans object-level subgoals (``recipes.plan_task``), then carries each
interaction out in a real ``Simulator`` on a copy of the world, so every action is checked exactly as an
agent's would be: it finds the cheapest pose from which the object shows a clickable pixel within reach
(``navigation.find_view``), walks and looks there, checks that the click resolves to the intended object
(``Simulator.resolve_click``) and acts. A failed action is retried from another pose; a subgoal that
cannot be done ends the plan, and the recipe is planned again from the true state (avoiding a receptacle
that turned out full). The trajectory is what an episode generator writes as the driver's reference
actions, and its subgoals follow TEACh's convention (JARVIS seed, Alg. 2 lines 47-55): an interaction on O
is ``Action O``, a run of motion before it is ``Navigate O``.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field, replace

from harness.expert.approach import stays_put
from harness.expert.navigation import (
    THOROUGH_SIGHT_RENDERS,
    BodyState,
    Reach,
    SightOracle,
    View,
    clicks_from,
    find_view,
    look_actions,
    reduced_spec,
    search_motion,
)
from harness.expert.planning import ExpertSubgoal, PlanError
from harness.expert.recipes import Task, plan_task
from harness.render.camera import ALFRED_CAMERA, TEACH_CAMERA, CameraSpec
from harness.render.renderer import Renderer
from harness.sim.failures import FailureReason
from harness.sim.simulator import HELD_COLLISION_SIZE_M, ActionResult, Simulator
from harness.tasks.alfred import check_alfred
from harness.tasks.progress import GoalReport
from harness.tasks.teach import TaskInstance, check_task
from harness.world.catalog import load_catalog
from harness.world.model import World
from symbolic.ontology import Ontology, load_ontology
from symbolic.subgoals import ACTION_NAME_FOR_SUBGOAL, Subgoal, SubgoalAction
from symbolic.thor import (
    ALFRED_LOOK_STEP_DEG,
    INTERACTION_DISTANCE_M,
    MAX_FAILED_ACTIONS,
    MAX_STEPS,
    MOTION_ACTIONS,
    OBJECT_ACTIONS,
    TEACH_LOOK_STEP_DEG,
)

RETRYABLE = frozenset({FailureReason.TOO_FAR, FailureReason.NOTHING_AT_POINT, FailureReason.BLOCKED})
"""Failures another pose or click can fix; any other failure means the plan was wrong for this state."""
AVOID_AFTER = frozenset(
    {FailureReason.RECEPTACLE_FULL, FailureReason.RECEPTACLE_INCOMPATIBLE, FailureReason.RECEPTACLE_CLOSED}
)
"""Failures after which the next plan should use another receptacle."""


@dataclass(frozen=True)
class ExpertConfig:
    """How the expert acts: the camera its clicks are for, and its search and retry budgets."""

    camera: CameraSpec = TEACH_CAMERA
    """The driver's camera (TEACh: 900x900, 90°); clicks are fractions of its frame."""
    look_step_deg: int = TEACH_LOOK_STEP_DEG  # degrees per Look Up/Down (TEACh 30, ALFRED 15)
    check_side_px: int = 300  # visibility renders at the camera's resolution divided down to this, pixels
    reach_margin_m: float = 0.01  # clicked surfaces stay this much inside the 1.5 m reach (rounding), metres
    max_view_renders: int = 40  # poses rendered per search before giving up on an object
    max_sight_renders: int = 16  # poses the planner's look-ahead renders before calling an object unseen
    pose_attempts: int = 3  # poses tried per interaction before the subgoal counts as failed
    max_plans: int = 5  # plans (the first and re-plans) per episode
    max_steps: int = MAX_STEPS  # TEACh's episode limit, actions
    max_failed_actions: int = MAX_FAILED_ACTIONS  # TEACh's limit on failed actions

    @classmethod
    def alfred(cls) -> ExpertConfig:
        """ALFRED's driver: 300x300 frames with a 60° field of view, 15° look steps."""
        return cls(
            camera=ALFRED_CAMERA,
            look_step_deg=ALFRED_LOOK_STEP_DEG,
        )


@dataclass(frozen=True)
class ExpertAction:
    """One driver action as executed: click (x = column, y = row fractions) for object actions only."""

    action: str
    x: float | None
    y: float | None
    object_id: str | None
    """The object the simulator acted on (None for motion)."""
    object_type: str | None
    success: bool
    failure: FailureReason | None
    subgoal_index: int
    """Index into the trajectory's ``subgoals`` of the subgoal this action serves."""


@dataclass(frozen=True)
class ExpertTrajectory:
    """A reference trajectory and how it went."""

    actions: tuple[ExpertAction, ...]
    subgoals: tuple[Subgoal, ...]
    """Type-level subgoals of the executed actions (TEACh's history/future subgoals)."""
    subgoal_object_ids: tuple[str, ...]
    """The object instance of each subgoal."""
    subgoal_spans: tuple[tuple[int, int], ...]
    """Action index range [start, end) of each subgoal."""
    plan: tuple[ExpertSubgoal, ...]
    """The last object-level plan the expert carried out."""
    initial_report: GoalReport
    final_report: GoalReport
    success: bool
    failure_reason: str | None
    """Why the task was not achieved: "<category>: <detail>" (None on success)."""
    final_world: World = field(repr=False)
    plans: int
    """How many plans were made (1 when nothing had to be re-planned)."""
    seconds: float


def goal_report(task: Task, world: World, ontology: Ontology | None = None) -> GoalReport:
    """The task's goal conditions in this world (TEACh's or ALFRED's checker)."""
    if isinstance(task, TaskInstance):
        return check_task(task, world, ontology=ontology)
    return check_alfred(task, world, ontology)


class _OutOfBudget(Exception):
    """The episode hit TEACh's step or failed-action limit."""


@dataclass(frozen=True)
class _Stuck:
    """A subgoal that could not be carried out, why, and a receptacle to avoid next time."""

    reason: str
    avoid: str | None = None


class _Episode:
    """One expert run: the simulator, the reduced-resolution renderer and the actions taken so far."""

    def __init__(self, world: World, config: ExpertConfig, ontology: Ontology) -> None:
        self.config = config
        self.ontology = ontology
        self.sim = Simulator(world.copy(), config.camera, look_step_deg=config.look_step_deg)
        self.renderer = Renderer(reduced_spec(config.camera, config.check_side_px))
        self.sight = SightOracle(
            self.renderer,
            config.camera,
            config.look_step_deg,
            config.reach_margin_m,
            config.max_sight_renders,
        )
        self.taken: list[tuple[ActionResult, float | None, float | None, str | None]] = []
        self.done: list[ExpertSubgoal] = []
        """Interactions carried out so far (across re-plans), for ``approach.stays_put``."""
        self._reach_key: tuple[object, ...] | None = None
        self._reach: Reach | None = None

    def step(self, action: str, x: float | None = None, y: float | None = None) -> ActionResult:
        if len(self.taken) >= self.config.max_steps:
            raise _OutOfBudget(f"{self.config.max_steps} actions")
        object_types = {oid: o.object_type for oid, o in self.sim.world.objects.items()}
        result = self.sim.step(action, x, y)
        self.taken.append((result, x, y, object_types.get(result.object_id or "")))
        if sum(not r.success for r, *_ in self.taken) > self.config.max_failed_actions:
            raise _OutOfBudget(f"{self.config.max_failed_actions} failed actions")
        return result

    def reach(self) -> Reach:
        """Shortest motion from where the agent stands (cached until it moves or the floor changes)."""
        world = self.sim.world
        agent = world.agent
        ix, iz = world.room.cell_of(agent.x, agent.z)
        held = world.held_object()
        long_held = held is not None and max(held.size) > HELD_COLLISION_SIZE_M
        grid = self.sim.reachable()
        key = (ix, iz, agent.yaw, long_held, grid.tobytes())
        if key != self._reach_key:
            self._reach_key, self._reach = key, search_motion(grid, BodyState(ix, iz, agent.yaw), long_held)
        assert self._reach is not None
        return self._reach

    def find(
        self,
        object_id: str,
        top_y: float | None,
        exclude: set[tuple[BodyState, float]],
        companion: tuple[str, World] | None = None,
        quick: bool = False,
        reach_inside: bool = False,
    ) -> View | None:
        """The cheapest verified view within the search budget; failing that, every candidate pose is tried
        (as the planner's look-ahead does before it calls an object seen), so an object that only shows
        from a few far poses is not given up on. ``quick`` (a preference the caller can drop: another
        pose than this one, or one that serves the next interaction too) spends only the quick budget.
        ``reach_inside``: only poses with the object's centre within reach (``find_view``)."""
        budgets = (
            (self.config.max_view_renders,)
            if quick
            else (self.config.max_view_renders, THOROUGH_SIGHT_RENDERS)
        )
        for budget in budgets:
            view = find_view(
                self.sim.world,
                object_id,
                self.reach(),
                self.renderer,
                self.config.camera,
                self.config.look_step_deg,
                top_y=top_y,
                reach_margin_m=self.config.reach_margin_m,
                max_renders=budget,
                exclude=frozenset(exclude),
                companion=companion,
                reach_inside=reach_inside,
            )
            if view is not None:
                return view
        return None

    def go_to(self, view: View) -> bool:
        """Walk and look to the view's pose; False if a motion failed on the way."""
        path = self.reach().path_to(view.state)
        path += look_actions(self.sim.world.agent.horizon, view.horizon, self.config.look_step_deg)
        return all(self.step(action).success for action in path)

    def _top_y(self, subgoal: ExpertSubgoal) -> float | None:
        """For placing on a top surface, its height (the click should land on the free part of the top)."""
        if subgoal.action is not SubgoalAction.PLACE:
            return None
        catalog = load_catalog()
        kind = subgoal.object_type
        if catalog.placement(kind) != "on" or catalog.single_slot(kind):
            return None
        return self.sim.world.objects[subgoal.object_id].top

    def here(self) -> tuple[BodyState, float]:
        world = self.sim.world
        ix, iz = world.room.cell_of(world.agent.x, world.agent.z)
        return BodyState(ix, iz, world.agent.yaw), world.agent.horizon

    def interact(
        self, subgoal: ExpertSubgoal, walk: bool = False, companion: tuple[str, World] | None = None
    ) -> _Stuck | None:
        """Carry out one interaction subgoal; None on success. ``walk``: act from another pose than the
        current one when there is one (``approach.stays_put`` says whether a person would walk here);
        ``companion``: when walking anyway, prefer a pose from which the next interaction can be done too
        (staying for this one must not cost a move before it)."""
        target = subgoal.object_id
        action = ACTION_NAME_FOR_SUBGOAL[subgoal.action]
        tried: set[tuple[BodyState, float]] = set()
        why = f"no view: no pose shows the {subgoal.object_type} within reach to {action}"
        for attempt in range(self.config.pose_attempts):
            if target not in self.sim.world.objects:
                return _Stuck(f"plan: {subgoal.object_type} {target} no longer exists")
            view = None
            top_y = self._top_y(subgoal)
            exclude = tried | {self.here()} if walk and attempt == 0 else tried
            inside = walk and attempt == 0 and self._reaches_inside(subgoal)
            if not walk and attempt == 0:
                view = self._view_from_here(subgoal, top_y)
            if companion is not None and attempt == 0:
                if inside:
                    view = self.find(target, top_y, exclude, companion, quick=True, reach_inside=True)
                view = view or self.find(target, top_y, exclude, companion, quick=True)
            if walk and attempt == 0:
                if inside:
                    view = view or self.find(target, top_y, exclude, quick=True, reach_inside=True)
                view = view or self.find(target, top_y, exclude, quick=True)
            view = view or self.find(target, top_y, tried)
            if view is None:
                return _Stuck(why, avoid=target)
            tried.add((view.state, view.horizon))
            if not self.go_to(view):
                why = "blocked: a move on the way failed"
                continue
            clicks = [c for c in view.clicks if self.sim.resolve_click(c[0], c[1], action) == target]
            if not clicks:
                why = f"click: no click on the {subgoal.object_type} resolves to it"
                continue
            result = self.step(action, *clicks[0])
            if result.success:
                return None
            why = f"action failed: {action} {subgoal.object_type}: {result.failure}"
            if result.failure not in RETRYABLE:
                avoid = target if result.failure in AVOID_AFTER else None
                return _Stuck(why, avoid)
        return _Stuck(why)

    def _companion(self, subgoal: ExpertSubgoal, rest: list[ExpertSubgoal]) -> tuple[str, World] | None:
        """The next interaction's object and the world it will be seen in, when it is to be done from
        where this one is (``approach.stays_put``): opening a door is assumed to succeed."""
        following = next((s for s in rest if s.action is not SubgoalAction.NAVIGATE), None)
        world = self.sim.world
        if following is None or following.object_id not in world.objects:
            return None
        if not stays_put([*self.done, subgoal], following, world, self.ontology):
            return None
        if subgoal.action is SubgoalAction.OPEN and subgoal.object_id in world.objects:
            world = world.copy()
            world.objects[subgoal.object_id].is_open = True
        return following.object_id, world

    def _view_from_here(self, subgoal: ExpertSubgoal, top_y: float | None) -> View | None:
        """The pose the agent stands in, when the object shows within reach from it. Staying put means
        acting from here: the cheapest candidate pose can be another one (candidates favour facing the
        object squarely), and a step or turn for it would write a Navigate into the reference."""
        clicks = self._clicks_here(subgoal.object_id, top_y)
        return View(*self.here(), clicks, 0.0) if clicks else None

    def _clicks_here(self, object_id: str, top_y: float | None = None) -> tuple[tuple[float, float], ...]:
        """Click points on the object within reach from the pose the agent stands in."""
        state, horizon = self.here()
        reach = INTERACTION_DISTANCE_M - self.config.reach_margin_m
        return clicks_from(
            self.sim.world, object_id, state, horizon, self.renderer, self.config.camera, reach, top_y
        )

    def _reaches_inside(self, subgoal: ExpertSubgoal) -> bool:
        """Whether this interaction opens or fills a fridge, microwave, cabinet or drawer: then a pose with
        its inside within reach is preferred, so what goes in or comes out next is taken from the same spot
        (a microwave opened from the edge of reach leaves the plate put in it out of reach)."""
        return subgoal.action in (SubgoalAction.OPEN, SubgoalAction.PLACE) and (
            subgoal.object_type in self.ontology.enclosing
        )

    def _piece_at_hand(self, plan: list[ExpertSubgoal], index: int) -> ExpertSubgoal:
        """The slice to pick up where the cutting was done: the planned piece if it shows from here, else
        another piece of the same cut that does (swapped with it in the rest of the plan). A person takes
        the slice in front of them; walking round for the one the plan happened to number would write a
        Navigate into the reference that no dialogue explains."""
        subgoal = plan[index]
        if (
            subgoal.action is not SubgoalAction.PICKUP
            or self.ontology.get(subgoal.object_type).sliced_from is None
        ):
            return subgoal
        if self._clicks_here(subgoal.object_id):
            return subgoal
        world = self.sim.world
        whole = subgoal.object_id.rsplit("|", 1)[0]
        handled = {s.object_id for s in self.done}
        for object_id, obj in world.objects.items():
            sibling = object_id.rsplit("|", 1)[0] == whole and obj.object_type == subgoal.object_type
            if (
                sibling
                and object_id != subgoal.object_id
                and object_id not in handled
                and self._clicks_here(object_id)
            ):
                swap = {subgoal.object_id: object_id, object_id: subgoal.object_id}
                plan[index:] = [
                    replace(s, object_id=swap.get(s.object_id, s.object_id)) for s in plan[index:]
                ]
                return plan[index]
        return subgoal

    def approach(self, subgoal: ExpertSubgoal) -> _Stuck | None:
        """Go where the object is in view and within reach, to do nothing there (ALFRED's look-at goal)."""
        view = self.find(subgoal.object_id, None, set())
        if view is None:
            return _Stuck(f"no view: no pose shows the {subgoal.object_type} within reach", subgoal.object_id)
        return None if self.go_to(view) else _Stuck("blocked: a move on the way failed")

    def execute(self, plan: list[ExpertSubgoal]) -> _Stuck | None:
        for index, subgoal in enumerate(plan):
            if subgoal.action is SubgoalAction.NAVIGATE:
                if any(s.action is not SubgoalAction.NAVIGATE for s in plan[index + 1 :]):
                    continue  # the next interaction walks there itself
                stuck = self.approach(subgoal)
            else:
                walk = not stays_put(self.done, subgoal, self.sim.world, self.ontology)
                if not walk:
                    subgoal = self._piece_at_hand(plan, index)
                companion = self._companion(subgoal, plan[index + 1 :]) if walk else None
                stuck = self.interact(subgoal, walk, companion)
                if stuck is None:
                    self.done.append(subgoal)
            if stuck is not None:
                return stuck
        return None


def _category(reason: str) -> str:
    """A failure reason with object ids reduced to their types, for histograms."""
    return re.sub(r"\b([A-Za-z]+)\|[^\s,;:]+", r"\1", reason)


def run_expert(
    world: World, task: Task, config: ExpertConfig | None = None, ontology: Ontology | None = None
) -> ExpertTrajectory:
    """The expert's trajectory for the task from the world's state (the world itself is not changed)."""
    config = config or ExpertConfig()
    ontology = ontology or load_ontology()
    started = time.perf_counter()
    episode = _Episode(world, config, ontology)
    initial = goal_report(task, episode.sim.world, ontology)
    avoid: set[str] = set()
    plan: list[ExpertSubgoal] = []
    failure: str | None = None
    plans = 0
    try:
        while not goal_report(task, episode.sim.world, ontology).success:
            if plans >= config.max_plans:
                failure = f"gave up: {plans} plans did not reach the goal; last: {failure}"
                break
            plans += 1
            try:
                plan = plan_task(task, episode.sim.world, ontology, frozenset(avoid), episode.sight)
            except PlanError as error:
                failure = f"no plan: {error}"
                break
            stuck = episode.execute(plan)
            if stuck is None:
                failure = "goal not met: the plan ran but the goal check fails"
                continue
            failure = stuck.reason
            if stuck.avoid is not None:
                avoid.add(stuck.avoid)
    except _OutOfBudget as budget:
        failure = f"budget: the episode hit {budget}"
    final = goal_report(task, episode.sim.world, ontology)
    actions, subgoals, object_ids, spans = _with_subgoals(episode, plan)
    return ExpertTrajectory(
        actions=actions,
        subgoals=subgoals,
        subgoal_object_ids=object_ids,
        subgoal_spans=spans,
        plan=tuple(plan),
        initial_report=initial,
        final_report=final,
        success=final.success,
        failure_reason=None if final.success else (_category(failure) if failure else "goal not met"),
        final_world=episode.sim.world.copy(),
        plans=plans,
        seconds=time.perf_counter() - started,
    )


def _with_subgoals(
    episode: _Episode, plan: list[ExpertSubgoal]
) -> tuple[tuple[ExpertAction, ...], tuple[Subgoal, ...], tuple[str, ...], tuple[tuple[int, int], ...]]:
    """Subgoals of the executed actions by TEACh's rule, and each action's subgoal index.

    A successful interaction on O is ``Action O``; the actions since the previous one (motion and failed
    attempts) are ``Navigate O`` if any of them moved the agent, else part of the interaction's subgoal.
    Motion after the last interaction is ``Navigate`` to the plan's final Navigate object (ALFRED's look-at),
    else part of the last subgoal.
    """
    subgoals: list[Subgoal] = []
    object_ids: list[str] = []
    spans: list[tuple[int, int]] = []
    owner = [0] * len(episode.taken)
    pending: list[int] = []

    def add(subgoal: Subgoal, object_id: str, indices: list[int]) -> None:
        for i in indices:
            owner[i] = len(subgoals)
        subgoals.append(subgoal)
        object_ids.append(object_id)
        spans.append((indices[0], indices[-1] + 1))

    for i, (result, _, _, object_type) in enumerate(episode.taken):
        if not (result.success and result.action in OBJECT_ACTIONS and result.object_id and object_type):
            pending.append(i)
            continue
        interaction = Subgoal(SubgoalAction(result.action), object_type)
        if any(episode.taken[j][0].action in MOTION_ACTIONS for j in pending):
            add(Subgoal(SubgoalAction.NAVIGATE, object_type), result.object_id, pending)
            add(interaction, result.object_id, [i])
        else:
            add(interaction, result.object_id, [*pending, i])
        pending = []
    if pending:
        last = plan[-1] if plan else None
        if last is not None and last.action is SubgoalAction.NAVIGATE:
            add(last.subgoal, last.object_id, pending)
        elif subgoals:
            for i in pending:
                owner[i] = len(subgoals) - 1
            spans[-1] = (spans[-1][0], pending[-1] + 1)
    actions = tuple(
        ExpertAction(
            action=result.action,
            x=x,
            y=y,
            object_id=result.object_id,
            object_type=object_type,
            success=result.success,
            failure=result.failure,
            subgoal_index=owner[i] if subgoals else -1,
        )
        for i, (result, x, y, object_type) in enumerate(episode.taken)
    )
    return actions, tuple(subgoals), tuple(object_ids), tuple(spans)
