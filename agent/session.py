"""The state of one conversation with the agent, and its step: observation in, action out.

JARVIS (seed 002) Algorithm 1 keeps exactly this between simulator steps: the future subgoals
``G_future`` with their ``pointer``, the semantic map, the step count and whether it must stop; each step
runs Algorithm 3. One step here (DESIGN.md §3): infer the last action's success -> the pose (the caller's,
or dead reckoning) -> perception (the current subgoal's object is the target of HLSM eq. (5)) -> the
executor judges the last action once (what the hand now holds) -> record a blocked move -> map update
(HLSM eq. (1)) -> the executor decides (and, when its decision asks for it, the planner re-plans and the
executor pursues the new plan) -> a trace entry. Everything that can refuse the input (perception included)
runs before anything changes, so a refused step leaves the session as it was.

Frames. The map lives in the agent's own frame. Without an EDH history it is the caller's world frame
(the first pose, or the origin when poses never come). With a history replayed from an unknown start, the
first world pose that arrives fixes a rigid transform (a multiple of 90° and a shift) from the caller's
frame to the map's, so the live frames land where the dead-reckoned history frames did.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

import numpy as np

from agent.classes import load_class_index
from agent.executor import (
    Decision,
    Executor,
    ExecutorConfig,
    FrameDigest,
    Hint,
    HistoryStep,
    ReplanReason,
    StepInputs,
    SuccessConfig,
    digest,
    history_poses,
    holding_before,
    infer_success,
    needs_thumbnail,
)
from agent.executor.config import STAND_CLEARANCE_M
from agent.explorers import DEFAULT_EXPLORER, ExplorerName
from agent.geometry import Camera, Pose, depth_to_points, track_pose
from agent.mapping import MapConfig, SemanticMap, render_map_png
from agent.navigation import NavigatorName, make_navigator
from agent.perception import (
    HandRegion,
    NetworkPaths,
    Observation,
    ObservationError,
    Perception,
    PerceptionName,
    make_perception,
    without_hand,
)
from agent.planning import (
    DialogueTurn,
    Planner,
    PlanningContext,
    PlanOutcome,
    PlanSource,
    Speaker,
    belief_after,
    make_planner,
)
from agent.snapshot import Name, SnapshotError, dumps, encoded_size, loads
from agent.trace import Trace, TraceEntry
from symbolic.ontology import Ontology, load_ontology
from symbolic.readings import choose_reading
from symbolic.repair import BEAM_READING, SUBGOAL_FAILED, RepairEvent
from symbolic.subgoals import Subgoal, format_subgoals
from symbolic.thor import (
    ALFRED_LOOK_STEP_DEG,
    MAX_FAILED_ACTIONS,
    MAX_STEPS,
    OBJECT_ACTIONS,
    TEACH_LOOK_STEP_DEG,
)

Mode = Literal["edh", "tfd", "tatc", "instruction"]
"""TEACh's Execution from Dialogue History, Trajectory from Dialogue, Two-Agent Task Completion; ALFRED."""

START_HORIZON_DEG: dict[str, float] = {"instruction": 30.0}
"""Camera pitch assumed at the start when the caller sends no pose: ALFRED starts looking 30° down;
TEACh's agents (and our harness) start level, which is the default for the other modes."""

MOVES: frozenset[str] = frozenset({"Forward", "Backward", "Pan Left", "Pan Right"})
"""Motions that translate the body (a blocked one leaves a collision in the map)."""

ASK_NEXT = "What should I do next?"
"""The follower's question when its plan runs out in TATC."""

EXECUTOR_SIZE_EVERY = 20
"""Steps between measurements of the executor's encoded size for the trace (encoding costs ~0.3 ms)."""


@dataclass(frozen=True)
class SessionLimits:
    """TEACh's episode limits, from the service settings, and how often a session re-plans on its own."""

    max_steps: int = MAX_STEPS  # actions per episode
    max_failed_actions: int = MAX_FAILED_ACTIONS  # failed actions per episode
    max_progress_replans: int = 4  # re-plans after the plan ran out or a subgoal failed (``_replan_reason``)


@dataclass(frozen=True)
class SessionSpec:
    """What the client chose when it created the session, fixed for the session's life: the API's create
    request less the conversation itself (``app.session_builder`` makes one from it)."""

    mode: Mode
    camera: Camera
    perception: PerceptionName
    navigator: NavigatorName
    explorer: ExplorerName = DEFAULT_EXPLORER  # how the search explores for an unmapped target
    networks: NetworkPaths = NetworkPaths()  # the learned back-end's checkpoints
    seed: int = 0  # the executor's random choices
    limits: SessionLimits = SessionLimits()


@dataclass(frozen=True)
class StepDecision:
    """What one step answered; kept so a retried request gets the same answer (idempotent retries)."""

    step: int
    action: str
    x: float | None
    y: float | None
    subgoal: Subgoal | None
    plan: tuple[Subgoal, ...]
    pointer: int
    plan_source: PlanSource
    repair_log: tuple[RepairEvent, ...]
    utterance: str | None
    done: bool
    reason: str


@dataclass(frozen=True)
class FrameAlignment:
    """Caller's world frame -> the map's frame: rotate by ``-yaw_deg`` about the origin, then shift."""

    yaw_deg: float = 0.0  # multiple of 90
    dx: float = 0.0  # metres
    dz: float = 0.0  # metres

    @classmethod
    def between(cls, world: Pose, mapped: Pose) -> FrameAlignment:
        """The alignment taking the world pose ``world`` onto the map-frame pose ``mapped``."""
        yaw = (round((world.yaw - mapped.yaw) / 90.0) * 90) % 360
        x, z = _rotate(world.x, world.z, yaw)
        return cls(float(yaw), mapped.x - x, mapped.z - z)

    def to_map(self, pose: Pose) -> Pose:
        x, z = _rotate(pose.x, pose.z, self.yaw_deg)
        return replace(pose, x=x + self.dx, z=z + self.dz, yaw=(pose.yaw - self.yaw_deg) % 360.0)


def _rotate(x: float, z: float, yaw_deg: float) -> tuple[float, float]:
    """(x, z) seen from a frame turned ``yaw_deg`` right: headings lose ``yaw_deg``."""
    a = math.radians(yaw_deg)
    return x * math.cos(a) - z * math.sin(a), x * math.sin(a) + z * math.cos(a)


@dataclass
class AgentSession:
    """One conversation: configuration, dialogue, the repaired plan, the map and progress through it."""

    session_id: str
    spec: SessionSpec
    planner: Planner
    instruction: str | None
    dialogue: list[DialogueTurn]
    history_subgoals: tuple[Subgoal, ...]
    created_at: datetime
    updated_at: datetime
    executor: Executor
    perception_backend: Perception = field(repr=False)
    ontology: Ontology = field(repr=False)
    plan: list[Subgoal] = field(default_factory=list)
    plan_source: PlanSource = "none"
    repair_log: list[RepairEvent] = field(default_factory=list)
    pointer: int = 0  # index into ``plan`` of the subgoal being executed
    step: int = 0  # actions returned so far (TEACh stops at thor.MAX_STEPS)
    done: bool = False
    given_subgoals: str | Sequence[object] | None = field(default=None, repr=False)
    semantic_map: SemanticMap | None = field(default=None, repr=False)
    pose: Pose | None = None  # where the agent stands, in the map's frame
    alignment: FrameAlignment | None = None  # fixed by the first world pose (module docstring)
    dead_reckoned: bool = False  # the pose so far comes from dead reckoning (history or no poses)
    last_action: str | None = None
    last_world_pose: Pose | None = None  # the caller's pose at the previous step, in the map's frame
    last_digest: FrameDigest | None = field(default=None, repr=False)
    last_decision: StepDecision | None = None
    last_path: tuple[tuple[int, int], ...] = ()
    last_target: str | None = None
    trace: Trace = field(default_factory=Trace, repr=False)
    executor_size: int | None = None  # bytes, last measured by ``_executor_size``
    progress_replans: int = 0  # re-plans made because the plan ran out or failed
    success_config: SuccessConfig = field(default_factory=SuccessConfig)
    hand: HandRegion = field(default_factory=HandRegion)  # where a held object shows in the frame

    @classmethod
    def start(
        cls,
        session_id: str,
        spec: SessionSpec,
        planner: Planner,
        *,
        instruction: str | None = None,
        dialogue: Sequence[DialogueTurn] = (),
        history_subgoals: Sequence[Subgoal] = (),
        given_subgoals: str | Sequence[object] | None = None,
        perception_backend: Perception | None = None,
        history: Sequence[HistoryStep] = (),
        history_start: Pose | None = None,
        ontology: Ontology | None = None,
        now: datetime | None = None,
    ) -> AgentSession:
        """A new session with its first plan (Algorithm 1, line 1: plan before the first step), its
        perception back-end (``make_perception`` unless given), and the EDH history (``history``)
        replayed into the map."""
        ontology = ontology or load_ontology()
        context = PlanningContext(
            dialogue=tuple(dialogue),
            history_subgoals=tuple(history_subgoals),
            instruction=instruction,
            given_subgoals=given_subgoals,
        )
        outcome = planner.plan(context)
        backend = perception_backend or make_perception(spec.perception, spec.camera, spec.networks)
        look_step = ALFRED_LOOK_STEP_DEG if spec.mode == "instruction" else TEACH_LOOK_STEP_DEG
        executor = Executor(
            ontology,
            make_navigator(spec.navigator, STAND_CLEARANCE_M),
            belief_after(history_subgoals, ontology),
            np.random.default_rng(spec.seed),
            ExecutorConfig(
                look_step_deg=look_step,
                max_steps=spec.limits.max_steps,
                max_failed_actions=spec.limits.max_failed_actions,
                explorer=spec.explorer,
            ),
        )
        started = now or datetime.now(UTC)
        session = cls(
            session_id=session_id,
            spec=spec,
            planner=planner,
            instruction=instruction,
            given_subgoals=given_subgoals,
            dialogue=list(dialogue),
            history_subgoals=tuple(history_subgoals),
            created_at=started,
            updated_at=started,
            executor=executor,
            perception_backend=backend,
            ontology=ontology,
        )
        session._adopt_plan(outcome)
        if history:
            session._replay(history, history_start)
        return session

    # ----- dialogue ----------------------------------------------------------------------------------
    def add_utterance(self, speaker: Speaker, text: str, now: datetime | None = None) -> bool:
        """Record a turn; a commander turn re-plans when the planner reads dialogue. Returns re-planned?

        The new plan is computed before anything is changed, so a planner error leaves the session as it
        was. A re-plan restarts the pointer: the new plan covers only the future (and a finished TATC
        episode resumes).
        """
        turn = DialogueTurn(speaker=speaker, text=text)
        replanned = speaker == "Commander" and self.planner.replans_on_dialogue
        if replanned:
            outcome = self.planner.plan(self._planning_context([*self.dialogue, turn]))
            self._adopt_plan(outcome)
            self.done = False
        self.dialogue.append(turn)
        self.updated_at = now or datetime.now(UTC)
        return replanned

    def _adopt_plan(self, outcome: PlanOutcome) -> None:
        """A plan read from the whole conversation replaces the plan, its repair log and its progress."""
        self.plan = list(outcome.plan)
        self.plan_source = outcome.source
        self.repair_log = list(outcome.repair_log)
        self.pointer = 0
        self._adopt_hints(outcome)

    def _adopt_hints(self, outcome: PlanOutcome) -> None:
        """A new plan for the executor, with the commander's stand and click hints, stand poses in the map's
        frame."""
        hints = []
        for item in outcome.hints:
            stand = look = None
            if item.stand is not None:
                stand = self._mapped(Pose(item.stand.x, item.stand.z, item.stand.yaw % 360.0))
                look = item.stand.horizon
            click = (item.click.x, item.click.y) if item.click is not None else None
            hints.append(Hint(item.subgoal, stand, look, click))
        self.executor.new_plan(hints)

    def current_subgoal(self) -> Subgoal | None:
        """The subgoal at the pointer, or None when the plan is exhausted."""
        return self.plan[self.pointer] if self.pointer < len(self.plan) else None

    def plan_text(self) -> str:
        """The plan in DESIGN.md §5's text form, e.g. ``Navigate Knife, Pickup Knife``."""
        return format_subgoals(self.plan)

    def _planning_context(
        self, dialogue: Sequence[DialogueTurn], *, readings_wanted: bool = False
    ) -> PlanningContext:
        """A re-plan reads the history plus what this session has carried out since (the seed's Eq. (1)
        history), and repairs from what the agent believes now (it may hold what the last plan picked up)."""
        return PlanningContext(
            dialogue=tuple(dialogue),
            history_subgoals=(*self.history_subgoals, *self.executor.completed),
            instruction=self.instruction,
            given_subgoals=self.given_subgoals,
            belief=self.executor.belief,
            readings_wanted=readings_wanted,
        )

    # ----- one step ----------------------------------------------------------------------------------
    @property
    def look_step_deg(self) -> float:
        return float(self.executor.config.look_step_deg)

    def step_once(self, obs: Observation, now: datetime | None = None) -> StepDecision:
        """One step of Algorithm 1: this observation in, the next action out (module docstring).

        Raises ObservationError (before changing anything) when perception cannot use the observation.
        """
        started = time.perf_counter()
        index = self.step
        previous_action = self.last_action
        if self.done:
            return self._record_final(index, "the episode has ended; nothing more to do", now)
        mapped_pose = self._mapped(obs.pose)
        success = infer_success(
            self.last_action,
            self.last_digest,
            frame_digest := digest(
                obs, self.success_config, thumbnail=needs_thumbnail(obs, self.last_action)
            ),
            reported=obs.last_action_success,
            poses=(self.last_world_pose, mapped_pose)
            if self.last_world_pose is not None and mapped_pose is not None
            else None,
            colours=self.executor.clicked_colours(obs, frame_digest),
            config=self.success_config,
        )
        pose = self._pose_now(mapped_pose, success.success)
        if self.semantic_map is not None:  # a pose the map cannot hold would fail after the map grew
            try:
                self.semantic_map.check_pose(pose)
            except ValueError as error:
                given = "" if obs.pose is not None else "the dead-reckoned pose "
                raise ObservationError("pose", f"{given}{error}") from error
        subgoal = self.current_subgoal()
        percept = self.perception_backend.perceive(obs, target_type=subgoal.obj if subgoal else None)
        perceived = time.perf_counter()
        # ---- nothing has changed so far; from here on the session moves to this step ----
        if mapped_pose is None:
            self.dead_reckoned = self.dead_reckoned or self.alignment is None
        if obs.pose is not None and self.alignment is None:
            self.alignment = (
                FrameAlignment.between(obs.pose, pose) if self.dead_reckoned else FrameAlignment()
            )
            self.dead_reckoned = False
        verdict = self.executor.judge(success.success, self.plan, held_object=obs.held_object)
        semantic_map = self._ensure_map(pose)
        for stand in self.executor.hint_stands():  # places the commander sent it to, seen or not yet
            semantic_map.cover(stand.x, stand.z)
        previous = self.pose
        if self.last_action in MOVES and success.success is False and previous is not None:
            semantic_map.record_collision(previous, self.last_action)  # JARVIS Alg. 3 l. 66, remembered once
        hand_class_ids = None
        if (
            verdict.holding and percept.depth_far is not None
        ):  # estimated depth cannot tell the hand by nearness
            hand = self.hand.mask(self.spec.camera)
            hand_class_ids = np.where(hand, percept.class_ids, 0)
            percept = without_hand(percept, hand)
        stats = semantic_map.update(percept, pose, holding=verdict.holding)
        mapped = time.perf_counter()
        view = self.executor.map_view(semantic_map, percept, self.spec.camera, pose, verdict, hand_class_ids)
        inputs = StepInputs(index, pose, view, obs, frame_digest, verdict)
        decision = self.executor.decide(inputs, self.plan, self.pointer)
        events = list(decision.events)
        why = self._replan_reason(decision)
        if why is not None:
            self._apply(decision)
            if self._replan_from_progress(why, events):
                decision = self.executor.pursue(inputs, self.plan, self.pointer)
                events.extend(decision.events)
        decided = time.perf_counter()
        self._apply(decision)
        self.pose = pose
        self.last_world_pose = mapped_pose
        if frame_digest.thumbnail is None and needs_thumbnail(obs, decision.action):
            frame_digest = digest(obs, self.success_config)  # the next step compares colours
        self.last_digest = frame_digest
        self.last_action = decision.action
        self.last_path = decision.path
        self.last_target = decision.target_type
        result = self._answer(index, decision, now)
        timing = {
            "perceive": (perceived - started) * 1e3,
            "map": (mapped - perceived) * 1e3,
            "decide": (decided - mapped) * 1e3,
        }
        timing["total"] = (time.perf_counter() - started) * 1e3
        self.trace.append(
            TraceEntry(
                step=index,
                time=self.updated_at.isoformat(),
                inputs=_inputs_summary(obs),
                last_action=previous_action,
                last_action_success=success.success,
                success_evidence=success.evidence,
                pose={"x": round(pose.x, 3), "z": round(pose.z, 3), "yaw": pose.yaw, "horizon": pose.horizon},
                map=_map_summary(semantic_map, stats.points, stats.carved),
                subgoal=str(result.subgoal) if result.subgoal is not None else None,
                pointer=self.pointer,
                action=result.action,
                x=result.x,
                y=result.y,
                reason=result.reason,
                events=events,
                timing_ms={k: round(v, 3) for k, v in timing.items()},
                state_bytes=self.state_bytes(executor_bytes=self._executor_size(index)),
            )
        )
        return result

    def _mapped(self, world: Pose | None) -> Pose | None:
        """A caller's world pose in the map's frame (the alignment it would get now, if none yet)."""
        if world is None:
            return None
        if self.alignment is not None:
            return self.alignment.to_map(world)
        if self.dead_reckoned and self.pose is not None:
            return FrameAlignment.between(world, self.pose).to_map(world)
        return world

    def _pose_now(self, mapped: Pose | None, success: bool | None) -> Pose:
        """The caller's pose when given, else dead reckoning from the previous pose (DESIGN.md §3)."""
        if mapped is not None:
            return mapped
        previous = self.pose or Pose(0.0, 0.0, 0.0, START_HORIZON_DEG.get(self.spec.mode, 0.0))
        return track_pose(
            previous,
            reported=None,
            last_action=self.last_action,
            last_action_success=success,
            look_step_deg=self.look_step_deg,
        )

    def _replan_reason(self, decision: Decision) -> ReplanReason | None:
        """Why the language planner should plan again now, or None: when the executor's decision asks for it
        (the plan ran out, or a subgoal failed; issue #5). Only a planner that reads dialogue re-plans (the
        oracle's plan is the plan), never in TATC (the follower asks its commander instead) nor after a
        commander's explicit command, and at most ``max_progress_replans`` times, so a model that keeps
        proposing what fails cannot loop."""
        if (
            not self.planner.replans_on_dialogue
            or self.spec.mode == "tatc"
            or self.plan_source == "commander"
        ):
            return None  # a commander's explicit instruction is not second-guessed
        if self.progress_replans >= self.spec.limits.max_progress_replans:
            return None
        return decision.replan

    def _replan_from_progress(self, why: str, events: list[str]) -> bool:
        """Plan from the dialogue and everything done so far; adopt the plan unless it is empty (the model
        says nothing is left). Notes what happened in ``events`` (the step's trace)."""
        self.progress_replans += 1
        after_failure = why == "a subgoal failed"
        outcome = self.planner.plan(self._planning_context(self.dialogue, readings_wanted=after_failure))
        if not outcome.plan:
            events.append(f"re-planned because {why}: nothing left to do")
            return False
        self.plan = list(outcome.plan)
        self.plan_source = outcome.source
        self.repair_log.extend(outcome.repair_log)
        if after_failure and outcome.readings:
            self._turn_to_another_reading(outcome, events)
        self.pointer = 0
        self.executor.new_plan()
        events.append(f"re-planned because {why}: {format_subgoals(self.plan)}")
        return True

    def _turn_to_another_reading(self, outcome: PlanOutcome, events: list[str]) -> None:
        """After a subgoal failed: the model's next reading when its first asks for that subgoal again
        (``symbolic.readings``), judged by what the map has seen and how often the subgoal was given up;
        logged under ``beam-reading`` when it changes the plan, in the step's trace either way."""
        given_up = Counter(s for e in self.repair_log if e.rule == SUBGOAL_FAILED for s in e.removed)
        seen = self.semantic_map.last_seen.keys() if self.semantic_map is not None else set()
        readings = (outcome.plan, *outcome.readings)
        choice = choose_reading(readings, given_up, seen)
        if choice.index == 0:
            events.append(choice.reason)
            return
        chosen = readings[choice.index]
        self.plan = list(chosen)
        self.repair_log.append(RepairEvent(BEAM_READING, 0, choice.reason, outcome.plan, chosen))
        events.append(f"{choice.reason}: {format_subgoals(chosen)}")

    def _ensure_map(self, pose: Pose) -> SemanticMap:
        if self.semantic_map is None:
            self.semantic_map = SemanticMap(self.spec.camera, pose, MapConfig())
        return self.semantic_map

    def _apply(self, decision: Decision) -> None:
        self.plan = list(decision.plan)
        self.pointer = decision.pointer
        self.repair_log.extend(decision.repairs)

    def _answer(self, index: int, decision: Decision, now: datetime | None) -> StepDecision:
        utterance = decision.question
        done = decision.stop
        if decision.plan_done and self.spec.mode == "tatc":
            utterance = ASK_NEXT
            done = not self.planner.replans_on_dialogue  # the commander's next turn can give a new plan
        self.done = done
        self.step = index + 1
        self.updated_at = now or datetime.now(UTC)
        return self._decided(index, decision.action, decision.x, decision.y, utterance, done, decision.reason)

    def _record_final(self, index: int, reason: str, now: datetime | None) -> StepDecision:
        """After the episode ended: Stop again (TEACh's runners stop calling; curl may not)."""
        self.step = index + 1
        self.updated_at = now or datetime.now(UTC)
        result = self._decided(index, "Stop", None, None, None, True, reason)
        self.last_action = "Stop"
        return result

    def _decided(
        self, step: int, action: str, x: float | None, y: float | None, said: str | None, done: bool, why: str
    ) -> StepDecision:
        """Step ``step``'s answer with the plan as it now stands, kept to answer a retried request again."""
        self.last_decision = StepDecision(
            step=step,
            action=action,
            x=x,
            y=y,
            subgoal=self.current_subgoal(),
            plan=tuple(self.plan),
            pointer=self.pointer,
            plan_source=self.plan_source,
            repair_log=tuple(self.repair_log),
            utterance=said,
            done=done,
            reason=why,
        )
        return self.last_decision

    # ----- EDH history -------------------------------------------------------------------------------
    def _replay(self, history: Sequence[HistoryStep], start: Pose | None) -> None:
        """Project the history frames into the map at their dead-reckoned poses (Algorithm 2 l. 47-55);
        remember where the history acted on objects when its frames have depth."""
        origin = start or Pose(0.0, 0.0, 0.0, START_HORIZON_DEG.get(self.spec.mode, 0.0))
        actions = [h.action for h in history]
        poses = history_poses(actions, origin, self.look_step_deg)
        holding = holding_before(actions)
        semantic_map = self._ensure_map(origin)
        for entry, pose, held in zip(history, poses, holding, strict=False):
            obs = entry.observation
            if obs is None:
                continue
            try:
                percept = self.perception_backend.perceive(obs, target_type=None)
            except ObservationError:
                continue  # a frame this back-end cannot read (TEACh's RGB-only history, oracle perception)
            if held and percept.depth_far is not None:
                percept = without_hand(percept, self.hand.mask(self.spec.camera))
            semantic_map.update(percept, pose, holding=held)
            if entry.action in OBJECT_ACTIONS and entry.x is not None and entry.y is not None:
                self._remember_click(entry, percept.depth, pose)
        self.pose = poses[-1]
        self.dead_reckoned = start is None
        self.alignment = FrameAlignment() if start is not None else None

    def _remember_click(self, entry: HistoryStep, depth: np.ndarray, pose: Pose) -> None:
        """Where a history object action clicked, as the executor's memory of that object type."""
        obs = entry.observation
        assert obs is not None and entry.x is not None and entry.y is not None
        H, W = depth.shape
        row, col = min(int(round(entry.y * H)), H - 1), min(int(round(entry.x * W)), W - 1)
        if depth[row, col] <= 0 or obs.instances is None:
            return
        object_type = obs.legend.get(int(obs.instances[row, col]))
        if object_type is None:
            return
        mask = np.zeros((H, W), dtype=bool)
        mask[row, col] = True
        point = depth_to_points(depth, self.spec.camera, pose, mask)[0]
        self.executor.remember(object_type, (float(point[0]), float(point[1]), float(point[2])))

    # ----- what a person can look at -----------------------------------------------------------------
    def map_png(self) -> bytes:
        """The semantic map picture (agent, planned path, current target, legend); an empty map before the
        first step."""
        semantic_map = self.semantic_map or SemanticMap(self.spec.camera, Pose(0.0, 0.0), MapConfig())
        current = self.current_subgoal()
        return render_map_png(
            semantic_map,
            agent_pose=self.pose,
            path_cells=self.last_path or None,
            target_type=self.last_target or (current.obj if current is not None else None),
        )

    # ----- size and serialization --------------------------------------------------------------------
    def _executor_size(self, index: int) -> int:
        """The executor's encoded size, measured every ``EXECUTOR_SIZE_EVERY`` steps (it grows slowly)."""
        if self.executor_size is None or index % EXECUTOR_SIZE_EVERY == 0:
            self.executor_size = _executor_bytes(self.executor)
        return self.executor_size

    def state_bytes(self, *, executor_bytes: int | None = None) -> int:
        """Bytes this session holds in memory: the map, the trace, the frame digest and the executor (its
        size in a snapshot before compression; pass a recent ``executor_bytes`` to skip encoding it again)."""
        map_bytes = self.semantic_map.nbytes if self.semantic_map is not None else 0
        digest_bytes = self.last_digest.nbytes if self.last_digest is not None else 0
        if executor_bytes is None:
            executor_bytes = _executor_bytes(self.executor)
        return map_bytes + self.trace.nbytes + digest_bytes + executor_bytes

    def to_bytes(self, *, with_trace: bool = True) -> bytes:
        """A compact snapshot (``agent.snapshot``: versioned, no pickle) of everything but the process-wide
        parts (ontology, class table, planner, perception networks, goal transformer), which are named in
        it and taken from the loading process by ``from_bytes``.

        ``with_trace=False`` leaves the trace out (named, to be given back to ``from_bytes``), for a store
        that keeps the trace lines itself: they were most of a long episode's snapshot (400 lines took a
        snapshot from 0.6 to 2.9 ms and from 15 to 50 KB), written again after every step."""
        named: dict[int, Name] = {
            id(self.ontology): ("ontology",),
            id(self.planner): ("planner", self.planner.name),
            id(self.perception_backend): ("perception",),
        }
        if not with_trace:
            named[id(self.trace)] = ("trace",)
        return dumps(self, named)

    @classmethod
    def from_bytes(
        cls,
        data: bytes,
        *,
        ontology: Ontology | None = None,
        planner: Planner | None = None,
        planners: Callable[[str], Planner] | None = None,
        networks: NetworkPaths | None = None,
        trace: Trace | None = None,
    ) -> AgentSession:
        """The session ``to_bytes`` wrote, with this process's ontology, planner (``planner``, else
        ``planners(name)`` for the name in the snapshot, else ``make_planner``'s default for it) and a
        perception back-end for its camera, on ``networks`` when given (the loading service's configured
        checkpoints, rather than paths read from stored bytes), and ``trace`` for a snapshot written
        without its trace (refused without one).

        Raises SnapshotError (a ValueError) for bytes that are not a snapshot of a session this build reads.
        """
        ontology = ontology or load_ontology()
        session = loads(data, _process_wide(ontology, planner, planners, trace))
        if not isinstance(session, AgentSession):
            raise SnapshotError(f"snapshot holds a {type(session).__name__}, not a session")
        if networks is not None:
            session.spec = replace(session.spec, networks=networks)
        spec = session.spec
        session.perception_backend = make_perception(spec.perception, spec.camera, spec.networks)
        return session


def _process_wide(
    ontology: Ontology,
    planner: Planner | None,
    planners: Callable[[str], Planner] | None,
    trace: Trace | None,
) -> Callable[[Name], object]:
    """The objects ``to_bytes`` named, from this process (``from_bytes`` builds the perception back-end
    itself, once the session's camera is known) or from the caller (the trace)."""

    def resolve(name: Name) -> object:
        match name:
            case ("ontology",):
                return ontology
            case ("trace",):
                if trace is None:
                    raise SnapshotError("snapshot was written without its trace, and none was given")
                return trace
            case ("planner", planner_name):
                if planner is not None:
                    return planner
                return (
                    planners(planner_name) if planners is not None else make_planner(planner_name, ontology)
                )
            case ("perception",):
                return None
            case ("classes",):
                return load_class_index()
            case ("goal_policy", checkpoint):
                from models.goal_transformer.policy import load_goal_policy  # torch loads here, once

                return load_goal_policy(Path(checkpoint))
        raise SnapshotError(f"snapshot names an unknown process-wide object {name!r}")

    return resolve


def _executor_bytes(executor: Executor) -> int:
    """Size of the executor's per-session state in a snapshot, before compression (shared parts named)."""
    return encoded_size((executor.state, executor.navigator))


def _inputs_summary(obs: Observation) -> dict[str, Any]:
    summary: dict[str, Any] = {
        "rgb": obs.rgb is not None,
        "depth": obs.depth is not None,
        "depth_uncertainty": obs.depth_uncertainty is not None,
        "segmentation": obs.instances is not None,
        "instances_in_legend": len(obs.legend),
    }
    if obs.pose is not None:
        summary["pose"] = {"x": obs.pose.x, "z": obs.pose.z, "yaw": obs.pose.yaw, "horizon": obs.pose.horizon}
    if obs.last_action_success is not None:
        summary["last_action_success"] = obs.last_action_success
    if obs.held_object is not None:
        summary["held_object"] = obs.held_object
    if obs.instances is not None and not obs.instance_ids_persistent:
        summary["segmentation_ids_persistent"] = False
    return summary


def _map_summary(semantic_map: SemanticMap, points: int, carved: int) -> dict[str, Any]:
    """Map statistics from views the step computed anyway (explored, obstacles, collisions)."""
    cell_area = semantic_map.config.cell_m**2
    return {
        "cells": list(semantic_map.shape),
        "explored_m2": round(float(np.count_nonzero(semantic_map.explored())) * cell_area, 2),
        "obstacle_m2": round(float(np.count_nonzero(semantic_map.obstacles())) * cell_area, 2),
        "collision_cells": int(np.count_nonzero(semantic_map.collisions())),
        "points": points,
        "carved": carved,
    }
