"""What every part of one executor step shares: its inputs, its outcomes and the agent's view helpers.

JARVIS (seed 002) Algorithm 3 is one function per step; here it is split by job (which instance,
getting there, searching, moving safely, the step itself), each a mixin over ``StepContext``, which holds
the step's inputs and the executor's state and offers the camera-pitch and turning helpers all of them use.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from agent.executor.clicks import Click, ClickPurpose, VisibleInstance, choose_click
from agent.executor.config import ExecutorConfig
from agent.executor.mapview import IgnoredSpot, MapCluster, SessionMapView
from agent.executor.state import Attempt, ExecutorState, PendingPurpose, Point
from agent.executor.success import FrameDigest
from agent.geometry import Pose
from agent.navigation.base import Navigator
from agent.perception.base import Observation
from symbolic.ontology import Ontology
from symbolic.repair import RepairEvent
from symbolic.subgoals import Subgoal
from symbolic.thor import HORIZON_MAX_DEG, HORIZON_MIN_DEG, TURN_STEP_DEG


@dataclass(frozen=True, eq=False)
class StepInputs:
    """One step as the executor sees it (built by the session)."""

    step: int  # index of the action to choose
    pose: Pose
    view: SessionMapView
    observation: Observation
    digest: FrameDigest
    last_success: bool | None  # the previous action's success (None before the first)


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
    point: tuple[float, float, float] | None = None  # where it was done (the click), for memory


@dataclass(frozen=True)
class GiveUp:
    """The subgoal cannot be achieved; it goes back to repair."""

    reason: str
    question: str | None = None  # what the follower would ask the commander


Outcome = Act | Done | GiveUp


class StepContext(ABC):
    """One call of ``Executor.decide``: the plan and pointer being worked on, what happened, and helpers."""

    def __init__(
        self,
        *,
        ontology: Ontology,
        navigator: Navigator,
        rng: np.random.Generator,
        config: ExecutorConfig,
        state: ExecutorState,
        inputs: StepInputs,
        plan: list[Subgoal],
        pointer: int,
    ) -> None:
        self.onto = ontology
        self.navigator = navigator
        self.rng = rng
        self.cfg = config
        self.state = state
        self.inputs = inputs
        self.view = inputs.view
        self.pose = inputs.pose
        self.plan = plan
        self.pointer = pointer
        self.events: list[str] = []
        self.repairs: list[RepairEvent] = []
        self.question: str | None = None
        self.searches = 0  # search decisions made this step (``search.MAX_SEARCHES_PER_STEP``)
        self._side_floors: dict[MapCluster, list[tuple[int, np.ndarray, float]]] = {}  # ``_side_floor``

    @abstractmethod
    def _search(self, obj: str, attempt: Attempt) -> Outcome:
        """¬FindInMap(X): where to look for it (``search.ContainerSearch``)."""

    @abstractmethod
    def _unstick(self, attempt: Attempt) -> Act | None:
        """A move out of a spot the navigator sees no way out of (``motion.MotionSafety``)."""

    # ----- camera and body helpers -------------------------------------------------------------------
    def _horizons(self) -> list[float]:
        step = self.cfg.look_step_deg
        count = int(round((HORIZON_MAX_DEG - HORIZON_MIN_DEG) / step))
        return [HORIZON_MIN_DEG + k * step for k in range(count + 1)]

    def _look_toward(self, horizon: float) -> str:
        return "Look Down" if horizon > self.pose.horizon else "Look Up"

    def _horizon_toward_point(self, point: tuple[float, float, float]) -> float:
        distance = max(math.hypot(point[0] - self.pose.x, point[2] - self.pose.z), 0.1)
        angle = math.degrees(math.atan2(self.view.camera.height_m - point[1], distance))
        return min(self._horizons(), key=lambda h: abs(h - angle))

    def _pitch_toward(self, point: Point) -> str | None:
        """The look that pitches toward a world point, or None when already looking at its height."""
        horizon = self._horizon_toward_point(point)
        return self._look_toward(horizon) if abs(horizon - self.pose.horizon) > 1e-3 else None

    def _turn_toward(self, point: tuple[float, float, float]) -> str | None:
        """The turn that brings a world point toward the middle of the view, if it is more than a third of
        the field of view off-centre and, with the simulator's segmentation, the turn leaves it nearer the
        middle than it was.

        A turn is TURN_STEP_DEG (90°): a point 40° right of ahead would end 50° left, out of a 90° view,
        and the next step turned back (generated valid_unseen game 47: left, right, left, right at an open
        cabinet, after which the agent looked in facing away from it). Learned segmentation keeps turning
        from a third of the view: with it, the wider limit lost 5 of the 24 learned-perception bench games
        and gained none (SR 66.7% -> 45.8%, all five ended at the step limit); why was not traced."""
        bearing = math.degrees(math.atan2(point[0] - self.pose.x, point[2] - self.pose.z))
        off = (bearing - self.pose.yaw + 180.0) % 360.0 - 180.0  # degrees right of straight ahead
        limit = self.view.camera.hfov_deg / 3
        if self.view.percept.persistent_ids:
            limit = max(limit, TURN_STEP_DEG / 2)
        if abs(off) > limit:
            return "Turn Right" if off > 0 else "Turn Left"
        return None

    def _rule_out_click(self, obj: str, click: Click, why: str) -> None:
        """Learned segmentation named something X that X's actions fail on (a coffee machine read as a pot):
        rule the clicked spot out for X for the rest of the episode, so neither the frame nor the map sends
        the agent back to it (HLSM's Ignore for a false detection)."""
        x, _, z = click.point
        reason = f"Ignore({obj}) at ({x:.2f}, {z:.2f}): {why}"
        self.state.ignored.append(
            IgnoredSpot(obj, x, z, self.cfg.false_detection_radius_m, reason, subgoal_index=None)
        )
        self.events.append(reason)
        self.view.forget(obj)

    def _lift_ignored_in_sight(self) -> None:
        """Lift every spot ruled out for not being seen (``IgnoredSpot.until_seen``) where an instance of its
        type now shows within reach. The lettuce mapped in a fridge that was then closed was not seen from
        around the fridge and was ignored; when the search opened the fridge, it lay in plain sight and the
        agent searched the kitchen for 400 more steps (generated valid_unseen game 45).

        True segmentation only: learned detections flicker from frame to frame, so one frame showing the
        thing where four look-arounds did not is no evidence, and lifting on it sent the agent back and forth
        to a plate it could not reach for 300 steps (learned perception, generated valid_unseen game 10)."""
        if not self.view.percept.persistent_ids:
            return
        ignored = self.state.ignored
        lifted = [
            spot
            for spot in ignored
            if spot.until_seen
            and any(
                v.clickable and spot.covers(v.point[0], v.point[2])
                for v in self.view.in_frame(spot.object_type)
            )
        ]
        if not lifted:
            return
        ignored[:] = [spot for spot in ignored if spot not in lifted]
        for spot in lifted:
            self.events.append(f"the {spot.object_type} at ({spot.x:.2f}, {spot.z:.2f}) is in sight again")
            self.view.forget(spot.object_type)

    def _click_on(self, chosen: VisibleInstance, attempt: Attempt, purpose: ClickPurpose) -> Click | None:
        view = self.view
        avoid = attempt.avoided_pixels(chosen.instance_id, self.pose, view.percept.persistent_ids)
        return choose_click(
            chosen,
            view.percept.instances,
            view.reach,
            view.usable,
            view.percept.depth,
            view.camera,
            self.pose,
            purpose,
            self.cfg.click,
            avoid=avoid,
            exact_depth=view.percept.depth_far is None,
        )
