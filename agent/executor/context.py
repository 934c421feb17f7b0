"""What every collaborator of one executor step shares: its inputs, its outcomes and the view helpers.

JARVIS (seed 002) Algorithm 3 is one function per step; here its jobs are collaborators (which instance,
getting there, searching, moving safely, stand-ins, ...), each handed this step's ``StepContext``: the
step's inputs, the plan and pointer being worked on (repairs change them within the step), the belief the
step works with, what the step reports (events, repairs, a question), and the camera-pitch and turning
helpers they all use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from agent.executor.clicks import Click, ClickPurpose, VisibleInstance, choose_click
from agent.executor.config import ExecutorConfig
from agent.executor.mapview import MapCluster, SessionMapView
from agent.executor.state import Attempt, PendingPurpose, Point, Verdict
from agent.executor.success import FrameDigest
from agent.geometry import Pose
from agent.navigation.base import Navigator
from agent.perception.base import Observation
from symbolic.belief import BeliefState
from symbolic.ontology import Ontology
from symbolic.repair import RepairEvent
from symbolic.subgoals import Subgoal, SubgoalAction
from symbolic.thor import HORIZON_MAX_DEG, HORIZON_MIN_DEG, TURN_STEP_DEG

SideFloor = tuple[int, np.ndarray, float]
"""One side of a piece of furniture: (standable known cells on it, bool [X, Z] cells of it, direction in
degrees; ``fronts.ContainerFronts.side_floor``)."""


@dataclass(frozen=True, eq=False)
class StepInputs:
    """One step as the executor sees it (built by the session)."""

    step: int  # index of the action to choose
    pose: Pose
    view: SessionMapView
    observation: Observation
    digest: FrameDigest
    previous: Verdict  # the previous action, judged (``Executor.judge``)

    @property
    def last_success(self) -> bool | None:
        """The previous action's success (None before the first)."""
        return self.previous.success


@dataclass(frozen=True)
class Act:
    """Pursuing a subgoal needs this action now."""

    action: str
    reason: str  # the predicate or rule behind it
    purpose: PendingPurpose = "motion"
    click: Click | None = None
    path: tuple[tuple[int, int], ...] = ()


@dataclass(frozen=True)
class Done:
    """The subgoal holds without another action (a Navigate whose target is at hand)."""

    reason: str
    point: Point | None = None  # where it was done (the click), for memory


@dataclass(frozen=True)
class GiveUp:
    """The subgoal cannot be achieved; it goes back to repair."""

    reason: str
    question: str | None = None  # what the follower would ask the commander


Outcome = Act | Done | GiveUp


@dataclass(eq=False)
class StepContext:
    """One pass of the executor over the plan in one step: the plan and pointer worked on, what happened,
    and the camera helpers."""

    onto: Ontology
    navigator: Navigator
    rng: np.random.Generator
    cfg: ExecutorConfig
    inputs: StepInputs
    plan: list[Subgoal]
    pointer: int
    belief: BeliefState  # the belief this step works with (the executor keeps it between steps)
    events: list[str] = field(default_factory=list)
    repairs: list[RepairEvent] = field(default_factory=list)
    question: str | None = None
    gave_up: bool = False  # a subgoal was given up to repair in this pass (a reason to re-plan)
    searches: int = 0  # search decisions made this pass (``SearchConfig.max_searches_per_step``)
    side_floors: dict[MapCluster, list[SideFloor]] = field(default_factory=dict)  # per body, computed once
    # a step (``ContainerFronts.side_floor``)

    @property
    def view(self) -> SessionMapView:
        return self.inputs.view

    @property
    def pose(self) -> Pose:
        return self.inputs.pose

    @property
    def subgoal(self) -> Subgoal | None:
        """The subgoal at the pointer, or None past the plan's end."""
        return self.plan[self.pointer] if self.pointer < len(self.plan) else None

    def upcoming_actions(self) -> list[Subgoal]:
        """The plan's subgoals from the pointer on that act on something (Navigates left out)."""
        return [s for s in self.plan[self.pointer :] if s.action is not SubgoalAction.NAVIGATE]

    # ----- camera and body helpers -------------------------------------------------------------------
    def horizons(self) -> list[float]:
        """The camera pitches the look step reaches, degrees down, from the highest up."""
        step = self.cfg.look_step_deg
        count = int(round((HORIZON_MAX_DEG - HORIZON_MIN_DEG) / step))
        return [HORIZON_MIN_DEG + k * step for k in range(count + 1)]

    def look_toward(self, horizon: float) -> str:
        return "Look Down" if horizon > self.pose.horizon else "Look Up"

    def horizon_toward_point(self, point: Point) -> float:
        """The reachable pitch nearest the one that looks at a world point."""
        distance = max(math.hypot(point[0] - self.pose.x, point[2] - self.pose.z), 0.1)
        angle = math.degrees(math.atan2(self.view.camera.height_m - point[1], distance))
        return min(self.horizons(), key=lambda h: abs(h - angle))

    def sweep_toward(self, horizon: float, count: int) -> list[float]:
        """The ``count`` reachable pitches nearest ``horizon``, nearest first (the lower one on a tie): the
        pitches to look from when looking for something about there."""
        return sorted(self.horizons(), key=lambda h: (abs(h - horizon), h))[:count]

    def next_pitch(self, sweep: list[float]) -> tuple[float | None, int]:
        """The next pitch of a sweep to look from, or None when the sweep is done, and how many of its
        pitches the camera has reached (they leave the sweep)."""
        reached = 0
        while sweep and abs(sweep[0] - self.pose.horizon) < 1e-3:
            sweep.pop(0)
            reached += 1
        return (sweep[0] if sweep else None), reached

    def pitch_toward(self, point: Point) -> str | None:
        """The look that pitches toward a world point, or None when already looking at its height."""
        horizon = self.horizon_toward_point(point)
        return self.look_toward(horizon) if abs(horizon - self.pose.horizon) > 1e-3 else None

    def turn_toward(self, point: Point) -> str | None:
        """The turn that brings a world point toward the middle of the view, if it is more than a third of
        the field of view off-centre and, with the simulator's segmentation, the turn leaves it nearer the
        middle than it was.

        A turn is TURN_STEP_DEG (90°): a point 40° right of ahead would end 50° left, out of a 90° view, and
        the next step would turn back; with the simulator's segmentation the limit is half a turn. Learned
        segmentation keeps turning from a third of the view: with it the wider limit loses
        learned-perception bench games and gains none."""
        bearing = math.degrees(math.atan2(point[0] - self.pose.x, point[2] - self.pose.z))
        off = (bearing - self.pose.yaw + 180.0) % 360.0 - 180.0  # degrees right of straight ahead
        limit = self.view.camera.hfov_deg / 3
        if self.view.percept.persistent_ids:
            limit = max(limit, TURN_STEP_DEG / 2)
        if abs(off) > limit:
            return "Turn Right" if off > 0 else "Turn Left"
        return None

    def click_on(self, chosen: VisibleInstance, attempt: Attempt, purpose: ClickPurpose) -> Click | None:
        """The pixel to click on a visible instance, avoiding where clicks on it failed this subgoal."""
        view = self.view
        avoid = attempt.avoided_pixels(chosen.instance_id, self.pose, view.percept.persistent_ids)
        exact = view.percept.depth_far is None
        return choose_click(chosen, view.click_frame, purpose, self.cfg.click, avoid=avoid, exact_depth=exact)
