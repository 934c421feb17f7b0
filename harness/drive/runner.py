"""Drive one episode through the agent service over HTTP and score it, as TEACh's inference runner does.

TEACh's ``InferenceRunner`` loop: show the driver model the current egocentric frame, execute the action it
returns in the simulator (object actions at the returned click point), count failed actions, and end on Stop,
after ``MAX_STEPS`` actions or after ``MAX_FAILED_ACTIONS`` failed ones; then compare the final state with
the task's goal conditions (SR, GC and their trajectory-length weighted forms, ``harness.drive.metrics``).
Here the simulator is ours (``harness.sim.simulator``) and the driver model is the service, reached only
through ``harness.drive.client``. What the runner tells the agent follows what AI2-THOR gives a TEACh
runner: the pose (metadata has it) but not whether the last action succeeded (TEACh never says; the agent
infers it).
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

import httpx
import numpy as np

from harness.drive.client import ARRAY_FRAMES, AgentClient, FrameEncoding, ServiceError, pose_of
from harness.drive.metrics import EpisodeOutcome, episode_metrics
from harness.episodes.model import Episode
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.tasks.alfred import AlfredTask
from harness.tasks.progress import GoalReport
from harness.world.model import World
from symbolic.subgoals import format_subgoals
from symbolic.thor import (
    ALFRED_LOOK_STEP_DEG,
    MAX_FAILED_ACTIONS,
    MAX_STEPS,
    OBJECT_ACTIONS,
    TEACH_HFOV_DEG,
    TEACH_LOOK_STEP_DEG,
)

DEFAULT_CAMERA = CameraSpec(300, 300, TEACH_HFOV_DEG)
"""TEACh renders 900x900 at 90° (``thor.TEACH_IMAGE_SIDE``); 300x300 keeps an episode fast, and the
``camera`` option (``--camera 900`` on the command line) restores TEACh's size."""

Perception = Literal["oracle", "learned"]
PlannerName = Literal["oracle", "model"]
NavigatorName = Literal["fmm", "vin"]
ExplorerName = Literal["frontier", "goal_transformer"]
EndReason = Literal["stop", "step_limit", "failure_limit", "error"]
SubgoalStatus = Literal["done", "failed", "replanned", "not reached"]

EPISODE_FAILURES: dict[EndReason, str] = {
    "stop": "wrong final state",
    "step_limit": "timeout (step limit)",
    "failure_limit": "failure limit",
    "error": "service error",
}
"""Why an unsuccessful episode failed, by how it ended (the benchmark's episode-level failure reasons)."""


@dataclass(frozen=True)
class RunnerOptions:
    """What the runner shows the agent and when it ends an episode."""

    camera: CameraSpec = DEFAULT_CAMERA
    perception: Perception = "oracle"  # oracle: depth + instance segmentation with each frame
    planner: PlannerName = "oracle"  # oracle: the episode's future subgoals are given to the session
    navigator: NavigatorName = "fmm"
    explorer: ExplorerName | None = None  # None: the service's default explorer
    give_pose: bool = True  # world pose with each frame, as AI2-THOR's metadata provides it
    give_success: bool = False  # TEACh never tells the driver whether its last action succeeded
    noise: bool = True  # renderer light/sensor noise, a fresh draw every step
    max_steps: int = MAX_STEPS  # actions returned by the agent, Stop and failed ones included (TEACh)
    max_failures: int = MAX_FAILED_ACTIONS  # failed actions that end the episode (TEACh)
    record_frames: bool = False  # keep every egocentric RGB frame (for a GIF)
    send_rgb: bool = True  # oracle perception does not read RGB; AI2-THOR always renders it
    transport: Literal["json", "multipart"] = "json"
    frames: Literal["png", "arrays"] = "png"  # arrays: .npy RGB and ids, float32 depth (ARRAY_FRAMES)
    seed: int = 0  # the session's seed
    delete_session: bool = True  # free the service's slot when done (keep it to read map.png and trace)

    def __post_init__(self) -> None:
        if self.max_steps < 1:
            raise ValueError(f"max_steps must be at least 1, got {self.max_steps}")
        if self.max_failures < 1:
            raise ValueError(f"max_failures must be at least 1, got {self.max_failures}")

    def encoding(self) -> FrameEncoding:
        base = ARRAY_FRAMES if self.frames == "arrays" else FrameEncoding()
        return replace(
            base,
            transport=self.transport,
            send_rgb=self.send_rgb or self.perception == "learned",
            send_oracle=self.perception == "oracle",
        )


@dataclass(frozen=True)
class ActionRecord:
    """One action the agent returned and what the simulator made of it."""

    step: int
    action: str
    x: float | None
    y: float | None
    success: bool
    failure: str | None  # FailureReason value
    subgoal: str | None  # what the service said it was executing
    plan_version: int  # index into EpisodeRun.plans
    pointer: int  # plan pointer the service reported with this action
    reason: str  # the service's words for why this action


@dataclass(frozen=True)
class SubgoalOutcome:
    """How far one subgoal of one plan version got."""

    plan_version: int
    index: int
    subgoal: str
    status: SubgoalStatus
    steps: int  # actions returned while the pointer was on it
    failed_actions: int
    last_reason: str  # the service's reason for the last action spent on it


@dataclass
class EpisodeRun:
    """Everything one episode produced: metrics, actions, per-subgoal outcomes, goal reports, frames."""

    episode: Episode
    session_id: str
    outcome: EpisodeOutcome
    end_reason: EndReason
    actions: list[ActionRecord]
    plans: list[list[str]]
    """Each plan the service followed, in order (the first is the repaired initial plan)."""
    subgoals: list[SubgoalOutcome]
    initial_plan: dict[str, Any]
    """The session's plan as created: subgoals, text, repair_log (the oracle plan after repair)."""
    initial_report: GoalReport
    final_report: GoalReport
    frames: list[np.ndarray] = field(default_factory=list)
    error_detail: str | None = None

    @property
    def metrics(self) -> dict[str, Any]:
        return episode_metrics(self.outcome)

    @property
    def failure(self) -> str | None:
        """None for a success, else why the episode failed (EPISODE_FAILURES)."""
        return None if self.outcome.success else EPISODE_FAILURES[self.end_reason]

    def summary(self) -> dict[str, Any]:
        """A JSON-ready record of the run (no frames)."""
        return {
            "instance_id": self.episode.instance_id,
            "task_name": self.outcome.task_name,
            "session_id": self.session_id,
            "end_reason": self.end_reason,
            "failure": self.failure,
            "error_detail": self.error_detail,
            "metrics": self.metrics,
            "unsatisfied": list(self.final_report.unsatisfied),
            "plans": self.plans,
            "subgoals": [asdict(s) for s in self.subgoals],
            "actions": [asdict(a) for a in self.actions],
        }


class PlanProgress:
    """Which subgoal each action served, from the plan and pointer the service returns with every step.

    A step's pointer is the subgoal the returned action serves; a new plan text means the service re-planned
    (JARVIS Alg. 1: a failed subgoal goes back to repair and planning), which starts a new plan version.
    """

    def __init__(self, initial_plan: Mapping[str, Any]) -> None:
        self.plans: list[list[str]] = [_plan_texts(initial_plan)]
        self.reached: list[int] = [int(initial_plan["pointer"])]
        self._steps: Counter[tuple[int, int]] = Counter()
        self._failed: Counter[tuple[int, int]] = Counter()
        self._reason: dict[tuple[int, int], str] = {}

    def see(self, result: Mapping[str, Any]) -> tuple[int, int]:
        """Record one StepResult; returns (plan version, pointer) of the action it carries."""
        texts = _plan_texts(result["plan"])
        pointer = int(result["plan"]["pointer"])
        if texts != self.plans[-1]:
            self.plans.append(texts)
            self.reached.append(pointer)
        version = len(self.plans) - 1
        self.reached[version] = max(self.reached[version], pointer)
        if result["action"] != "Stop" and pointer < len(texts):
            self._steps[version, pointer] += 1
            self._reason[version, pointer] = str(result.get("reason", ""))
        return version, pointer

    def failed(self, version: int, pointer: int) -> None:
        self._failed[version, pointer] += 1

    def outcomes(self) -> list[SubgoalOutcome]:
        """Old plans: done up to the pointer, then the subgoal that was re-planned; the last plan: done,
        then the one the episode ended on (failed), then those never reached."""
        out = []
        last = len(self.plans) - 1
        for version, texts in enumerate(self.plans):
            reached = self.reached[version]
            for index, text in enumerate(texts):
                if index < reached:
                    status: SubgoalStatus = "done"
                elif index == reached:
                    status = "failed" if version == last else "replanned"
                elif version == last:
                    status = "not reached"
                else:
                    break
                key = (version, index)
                out.append(
                    SubgoalOutcome(
                        version,
                        index,
                        text,
                        status,
                        self._steps[key],
                        self._failed[key],
                        self._reason.get(key, ""),
                    )
                )
        return out


def _plan_texts(plan: Mapping[str, Any]) -> list[str]:
    return [str(subgoal["text"]) for subgoal in plan["subgoals"]]


def session_payload(episode: Episode, options: RunnerOptions) -> dict[str, Any]:
    """The SessionCreate body for an episode (DESIGN.md §4)."""
    camera = options.camera
    payload: dict[str, Any] = {
        "mode": "instruction" if episode.benchmark == "alfred" else episode.benchmark,
        "camera": {
            "width": camera.width,
            "height": camera.height,
            "hfov_deg": camera.hfov_deg,
            "height_m": camera.height_m,
        },
        "perception": options.perception,
        "planner": options.planner,
        "navigator": options.navigator,
        "seed": options.seed,
    }
    if options.explorer is not None:
        payload["explorer"] = options.explorer
    if episode.benchmark == "alfred":
        payload["instruction"] = episode.instruction
    else:
        payload["dialogue"] = [{"speaker": speaker, "text": text} for speaker, text in episode.dialogue]
    if episode.benchmark == "edh":
        payload["history"] = {"actions": list(episode.history_actions)}
    if options.planner == "oracle":
        if not episode.future_subgoals:
            raise ValueError(f"episode {episode.instance_id} has no future_subgoals for the oracle planner")
        payload["subgoals"] = format_subgoals(episode.future_subgoals)
    return payload


@dataclass
class EpisodeLog:
    """What a running episode gathers (its actions, failures by reason, how it ended) and the EpisodeRun it
    becomes. Every way of driving an episode through the service (native, TEACh's RemoteModel, commander and
    follower) keeps one, so the failure limit and the metrics row are the same for all."""

    episode: Episode
    initial_report: GoalReport
    max_failures: int
    started: float = field(default_factory=time.perf_counter)
    actions: list[ActionRecord] = field(default_factory=list)
    failures: Counter[str] = field(default_factory=Counter)
    frames: list[np.ndarray] = field(default_factory=list)
    end_reason: EndReason = "step_limit"
    error_detail: str | None = None

    def add(self, record: ActionRecord, progress: PlanProgress | None = None) -> bool:
        """Keep one carried-out action; True when its failure reaches the limit, which ends the episode."""
        self.actions.append(record)
        if record.failure is None:
            return False
        self.failures[record.failure] += 1
        if progress is not None:
            progress.failed(record.plan_version, record.pointer)
        if sum(self.failures.values()) < self.max_failures:
            return False
        self.end_reason = "failure_limit"
        return True

    def broken(self, error: Exception) -> None:
        """The service or the connection failed: the episode ends here, with the reason kept."""
        self.end_reason, self.error_detail = "error", str(error)

    def finished(self, world: World, created: Mapping[str, Any], progress: PlanProgress | None) -> EpisodeRun:
        """Score the world as the episode left it. ``created`` is the session as created (its id and plan);
        ``progress`` is None when the protocol reports no plan with each action (TEACh's RemoteModel)."""
        final_report = self.episode.check(world)
        wall_s = time.perf_counter() - self.started
        outcome = episode_outcome(
            self.episode,
            self.initial_report,
            final_report,
            self.actions,
            self.failures,
            self.end_reason,
            wall_s,
        )
        return EpisodeRun(
            episode=self.episode,
            session_id=str(created["session_id"]),
            outcome=outcome,
            end_reason=self.end_reason,
            actions=self.actions,
            plans=progress.plans if progress is not None else [_plan_texts(created["plan"])],
            subgoals=progress.outcomes() if progress is not None else [],
            initial_plan=dict(created["plan"]),
            initial_report=self.initial_report,
            final_report=final_report,
            frames=self.frames,
            error_detail=self.error_detail,
        )


StepListener = Callable[[ActionRecord, Mapping[str, Any]], None]
"""Called after each action is carried out, with its record and the service's StepResult (live progress)."""


def run_episode(
    episode: Episode,
    client: AgentClient,
    options: RunnerOptions | None = None,
    on_step: StepListener | None = None,
) -> EpisodeRun:
    """One episode, start to end, through the service; the episode's world is not modified."""
    options = options or RunnerOptions()
    encoding = options.encoding()
    look_step = ALFRED_LOOK_STEP_DEG if episode.benchmark == "alfred" else TEACH_LOOK_STEP_DEG
    simulator = Simulator(episode.world.copy(), options.camera, look_step_deg=look_step)
    log = EpisodeLog(episode, episode.check(simulator.world), options.max_failures)
    created = client.create_session(session_payload(episode, options))
    session_id = str(created["session_id"])
    progress = PlanProgress(created["plan"])
    last_success: bool | None = None
    try:
        for step in range(options.max_steps):
            frame = simulator.observe(noise_seed=step if options.noise else None)
            if options.record_frames and frame.rgb is not None:
                log.frames.append(frame.rgb)
            result = client.step(
                session_id,
                frame,
                pose=pose_of(simulator.world.agent) if options.give_pose else None,
                last_action_success=last_success if options.give_success else None,
                step_index=step,
                encoding=encoding,
            )
            version, pointer = progress.see(result)
            record = execute_action(simulator, step, result, version, pointer)
            if on_step is not None:
                on_step(record, result)
            last_success = record.success
            if log.add(record, progress):
                break
            if record.action == "Stop" or result.get("done"):
                log.end_reason = "stop"
                break
    except (ServiceError, httpx.HTTPError) as error:
        log.broken(error)
    if options.record_frames:
        final_rgb = simulator.observe(noise_seed=None).rgb
        if final_rgb is not None:
            log.frames.append(final_rgb)
    run = log.finished(simulator.world, created, progress)
    if options.delete_session:
        _delete_quietly(client, session_id)
    return run


def execute_action(
    simulator: Simulator, step: int, result: Mapping[str, Any], version: int, pointer: int
) -> ActionRecord:
    """Carry out the service's action; Stop is not a simulator action (it ends the episode, TEACh)."""
    action = str(result["action"])
    x, y = (result.get("x"), result.get("y")) if action in OBJECT_ACTIONS else (None, None)
    success, failure = True, None
    if action != "Stop":
        outcome = simulator.step(action, x, y)
        success, failure = outcome.success, outcome.failure.value if outcome.failure is not None else None
    reason = str(result.get("reason", ""))
    return ActionRecord(step, action, x, y, success, failure, result.get("subgoal"), version, pointer, reason)


def _delete_quietly(client: AgentClient, session_id: str) -> None:
    """Free the slot; a session the service already dropped is fine (the episode is over either way)."""
    try:
        client.delete(session_id)
    except (ServiceError, httpx.HTTPError):
        return


def episode_outcome(
    episode: Episode,
    initial_report: GoalReport,
    final_report: GoalReport,
    actions: Sequence[ActionRecord],
    failures: Mapping[str, int],
    end_reason: EndReason,
    wall_s: float,
) -> EpisodeOutcome:
    """The metrics row of a finished episode; every way of driving an episode (native, TEACh's
    RemoteModel, commander and follower) ends in the same row, so their numbers compare."""
    return EpisodeOutcome(
        instance_id=episode.instance_id,
        task_name=episode_task_name(episode),
        success=final_report.success,
        gc_satisfied=final_report.satisfied,
        gc_total=final_report.total,
        init_gc_satisfied=initial_report.satisfied,
        init_gc_total=initial_report.total,
        pred_len=len(actions),
        ref_len=episode.reference_length,
        failure_reasons=dict(failures),
        steps=len(actions),
        wall_s=wall_s,
        predicted_stop=end_reason == "stop",
        error=end_reason == "error",
    )


def episode_task_name(episode: Episode) -> str:
    """TEACh's task name, or ALFRED's task type."""
    return episode.task.task_type if isinstance(episode.task, AlfredTask) else episode.task.task_name


# ---- describing a run --------------------------------------------------------------------------------


def describe_subgoals(run: EpisodeRun) -> list[str]:
    """One line per subgoal outcome: "  [done]   Pickup Knife  (12 steps, 1 failed)"."""
    lines = []
    for item in run.subgoals:
        plan = f"plan {item.plan_version} " if len(run.plans) > 1 else ""
        note = f"  ({item.steps} steps, {item.failed_actions} failed)"
        why = (
            f"  last: {item.last_reason}"
            if item.status in ("failed", "replanned") and item.last_reason
            else ""
        )
        lines.append(f"  {plan}[{item.status:>11}] {item.subgoal:<28}{note}{why}")
    return lines


def describe_metrics(run: EpisodeRun) -> list[str]:
    m = run.metrics
    ended = f"{run.end_reason}" + (f" ({run.error_detail})" if run.error_detail else "")
    lines = [
        f"  SR {m['success']}  GC {m['goal_condition_success']:.3f}  "
        f"TLW-SR {m['success_spl']:.3f}  TLW-GC {m['goal_condition_spl']:.3f}",
        f"  actions {m['traj_len']} (reference {m['gt_path_len']}), failed {m['num_api_fails']}, "
        f"ended by {ended}, {run.outcome.wall_s:.1f} s",
    ]
    if run.outcome.failure_reasons:
        reasons = ", ".join(f"{r} x{n}" for r, n in Counter(run.outcome.failure_reasons).most_common())
        lines.append(f"  failed actions: {reasons}")
    if run.final_report.unsatisfied:
        lines.append("  still wrong: " + "; ".join(run.final_report.unsatisfied))
    return lines
