"""Drive one episode through the agent service over HTTP and score it, as TEACh's inference runner does.

TEACh's ``InferenceRunner`` loop: show the driver model the current egocentric frame, execute the action it
returns in the simulator (object actions at the returned click point), count failed actions, and end on Stop,
after ``MAX_STEPS`` actions or after ``MAX_FAILED_ACTIONS`` failed ones; then compare the final state with
the task's goal conditions (SR, GC and their trajectory-length weighted forms, ``harness.metrics``). Here
the simulator is ours (``harness.simulator``) and the driver model is the service, reached only through
``harness.client``. What the runner tells the agent follows what AI2-THOR gives a TEACh runner: the pose
(metadata has it) but not whether the last action succeeded (TEACh never says; the agent infers it).
"""

from __future__ import annotations

import argparse
import io
import json
import re
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, get_args

import httpx
import numpy as np
from PIL import Image

from harness.camera import CameraSpec
from harness.client import ARRAY_FRAMES, AgentClient, FrameEncoding, ServiceError, TeachRemoteModel, pose_of
from harness.episodes.build import BuildConfig, BuildError
from harness.episodes.generate import GenerateConfig, generate_one, write_game
from harness.episodes.model import Episode
from harness.episodes.phrases import load_phrase_bank
from harness.episodes.sample import TaskSamplingError
from harness.episodes.teach_format import load_edh, load_tfd
from harness.metrics import EpisodeOutcome, episode_metrics
from harness.service import running_service
from harness.simulator import Simulator
from harness.splits import SPLITS, Split
from harness.tasks.alfred import AlfredTask
from harness.tasks.progress import GoalReport
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world import World
from symbolic.cli_args import (
    Parser,
    existing_dir,
    existing_path,
    fail,
    http_url,
    int_at_least,
    plain,
    port,
    positive_float,
)
from symbolic.ontology import load_ontology
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


# ---- generated episodes ------------------------------------------------------------------------------


class EpisodeUnavailable(RuntimeError):
    """No game for this index: the task cannot be posed in the world, or the expert failed (the generator
    skips such games)."""


def _generate_into(
    out: Path,
    split: Split,
    index: int,
    camera: CameraSpec,
    tasks: Sequence[str],
    images: bool = False,
) -> str:
    """Write the generated game of ``index`` (and with ``images`` its driver frames) under ``out``, TEACh's
    layout; returns its game id."""
    config = GenerateConfig(
        out=Path("."),
        splits=(split,),
        n=1,
        tasks=tuple(tasks),
        build=BuildConfig(camera=camera, images=images),
    )
    name = f"{split} #{index} ({tasks[index % len(tasks)]})"
    try:
        _, built = generate_one(split, index, config, load_phrase_bank(), load_ontology())
    except (TaskSamplingError, BuildError) as error:
        raise EpisodeUnavailable(f"{name}: {error}") from error
    write_game(out, built, io.StringIO())
    return built.game_id


def _edh_path(out: Path, split: Split, game_id: str, instance: str) -> Path:
    path = out / "edh_instances" / split / f"{game_id}.{instance}.json"
    if not path.is_file():
        cuts = len(list(path.parent.glob(f"{game_id}.edh*.json")))
        raise EpisodeUnavailable(f"{split} game {game_id} has {cuts} EDH instances, no {instance}")
    return path


def generated_episode(
    split: Split,
    index: int,
    camera: CameraSpec = DEFAULT_CAMERA,
    tasks: Sequence[str] = BENCHMARK_TASKS,
    instance: str = "tfd",
) -> Episode:
    """An episode of the game ``python -m harness generate`` writes for ``index`` of ``split`` (task
    ``tasks[index % len(tasks)]``), read back through the TEACh-format reader.

    ``instance`` "tfd": the game's initial world, the whole dialogue, the expert's subgoals (the oracle plan)
    and actions (the reference). "edh0", "edh1"...: an EDH cut, its world after the history actions were
    replayed, the dialogue so far, history and future subgoals. The expert acts with ``camera``, the one the
    runner will use; the files go to a temporary directory.
    """
    if instance != "tfd" and not re.fullmatch(r"edh\d+", instance):
        raise ValueError(f"instance must be 'tfd' or 'edh<k>' (edh0, edh1, ...), got {instance!r}")
    with tempfile.TemporaryDirectory(prefix="jarvis-episode-") as scratch:
        out = Path(scratch)
        game_id = _generate_into(out, split, index, camera, tasks)
        if instance == "tfd":
            return load_tfd(out / "tfd_instances" / split / f"{game_id}.tfd0.json", out / "games", split)
        return load_edh(_edh_path(out, split, game_id, instance), out / "games", split)


def generated_tfd_episode(
    split: Split, index: int, camera: CameraSpec = DEFAULT_CAMERA, tasks: Sequence[str] = BENCHMARK_TASKS
) -> Episode:
    """The generated game's TfD episode (what the benchmarks run)."""
    return generated_episode(split, index, camera, tasks, instance="tfd")


# ---- TEACh's inference runner with RemoteModel ---------------------------------------------------------


@dataclass
class TeachInstance:
    """An EDH instance as TEACh's inference runner holds it: the file's JSON, the history frames it loads
    from ``images/<split>/<game_id>/`` (``driver_image_history``), and the name it passes as ``edh_name``
    (the instance file's path)."""

    edh_instance: dict[str, Any]
    history_images: list[Image.Image]
    edh_name: str


def load_teach_instance(path: Path, images_dir: Path) -> TeachInstance:
    """What TEACh's runner reads for one instance file (``images_dir``: the data's ``images/<split>``)."""
    data = json.loads(path.read_text(encoding="utf-8"))
    folder = images_dir / str(data["game_id"])
    images = []
    for name in data.get("driver_image_history", []):
        with Image.open(folder / name) as image:
            images.append(image.convert("RGB"))
    return TeachInstance(edh_instance=data, history_images=images, edh_name=str(path))


def generated_teach_instance(
    split: Split,
    index: int,
    camera: CameraSpec = DEFAULT_CAMERA,
    tasks: Sequence[str] = BENCHMARK_TASKS,
    instance: str = "edh0",
) -> tuple[Episode, TeachInstance]:
    """A generated game's EDH cut written with its driver frames: the episode (its world after the history)
    and the instance as TEACh's runner would read it from those files."""
    if not re.fullmatch(r"edh\d+", instance):
        raise ValueError(f"instance must be 'edh<k>' (edh0, edh1, ...), got {instance!r}")
    with tempfile.TemporaryDirectory(prefix="jarvis-teach-") as scratch:
        out = Path(scratch)
        game_id = _generate_into(out, split, index, camera, tasks, images=True)
        path = _edh_path(out, split, game_id, instance)
        episode = load_edh(path, out / "games", split)
        teach = load_teach_instance(path, out / "images" / split)
        teach.edh_name = f"edh_instances/{split}/{path.name}"  # the temporary folder is gone after this
    return episode, teach


def run_teach_episode(
    episode: Episode,
    instance: TeachInstance,
    model: TeachRemoteModel,
    options: RunnerOptions | None = None,
) -> EpisodeRun:
    """One EDH instance the way TEACh's ``InferenceRunner._run_edh_instance`` runs it with ``RemoteModel``.

    ``start_new_edh_instance`` with the history frames, then per step: the current frame as a PIL image,
    ``get_next_action(img, edh_instance, prev_action, img_name, edh_name)``, the action executed with the
    click read as ``[y, x]``, ``prev_action = {"action", "obj_relative_coord"}``; the end at Stop, after
    ``max_steps`` steps or ``max_failures`` failed ones. No pose, no success flag, no depth: TEACh sends RGB
    only, so the service runs learned perception. ``options`` gives the limits and the render noise.
    """
    options = options or RunnerOptions()
    look_step = int(episode.metadata.get("look_step_deg", TEACH_LOOK_STEP_DEG))
    simulator = Simulator(episode.world.copy(), options.camera, look_step_deg=look_step)
    log = EpisodeLog(episode, episode.check(simulator.world), options.max_failures)
    data = instance.edh_instance
    instance_id = str(data.get("instance_id", episode.instance_id))
    created: dict[str, Any] = {"session_id": "", "plan": {"subgoals": [], "text": "", "pointer": 0}}
    try:
        created = model.start_new_edh_instance(data, instance.history_images, instance.edh_name)
        prev_action: dict[str, Any] | None = None
        for step in range(options.max_steps):
            frame = simulator.observe(noise_seed=step if options.noise else None)
            assert frame.rgb is not None, "the simulator renders rgb"
            img_name = f"img__{instance_id}_{step + 1}.jpeg"  # TEACh's InferenceRunner._save_image
            action, coord = model.get_next_action(
                Image.fromarray(frame.rgb), data, prev_action, img_name, instance.edh_name
            )
            record = _execute_teach_action(simulator, step, str(action), coord)
            prev_action = {"action": action, "obj_relative_coord": coord}
            if log.add(record):
                break
            if action == "Stop":
                log.end_reason = "stop"
                break
    except (ServiceError, httpx.HTTPError) as error:
        log.broken(error)
    return log.finished(simulator.world, created, None)


def _execute_teach_action(
    simulator: Simulator, step: int, action: str, coord: Sequence[float] | None
) -> ActionRecord:
    """TEACh's ``InferenceRunner._execute_action``: Stop succeeds; an object action clicks at
    ``x = coord[1], y = coord[0]``; a motion moves."""
    x = y = None
    if action in OBJECT_ACTIONS and coord is not None:
        y, x = float(coord[0]), float(coord[1])
    success, failure = True, None
    if action != "Stop":
        outcome = simulator.step(action, x, y)
        success, failure = outcome.success, outcome.failure.value if outcome.failure is not None else None
    return ActionRecord(step, action, x, y, success, failure, None, 0, 0, "")


# ---- command line ------------------------------------------------------------------------------------


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


class ServiceUnreachable(RuntimeError):
    """Nothing answers ``GET /healthz`` at the URL a command was given (or at its default port)."""


def require_service(base_url: str, timeout_s: float = 5.0) -> None:
    """Fail before any work when no service answers at ``base_url``: one clear line instead of a traceback
    from the first step's connection error."""
    try:
        httpx.get(f"{base_url}/healthz", timeout=timeout_s)
    except httpx.TransportError as error:
        raise ServiceUnreachable(
            f"no service answers at {base_url} ({type(error).__name__}: {error}); "
            "start one (make serve) or pass --start-service"
        ) from None


@contextmanager
def service_url(url: str | None, port: int | None, start: bool) -> Iterator[str]:
    """The service to talk to: a given URL, a port on this machine, or one started for the run."""
    if start:
        with running_service(port) as service:
            yield service.base_url
    else:
        base_url = url or f"http://127.0.0.1:{port or 8000}"
        require_service(base_url)
        yield base_url


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m harness run", description=plain(main.__doc__))
    parser.add_argument(
        "--task", choices=BENCHMARK_TASKS, help="only this task (default: task index %% 12, as generated)"
    )
    parser.add_argument("--split", default="valid_unseen", choices=SPLITS)
    parser.add_argument("--index", type=int_at_least(0), default=0, help="episode index within the split")
    parser.add_argument(
        "--instance", default="tfd", help="tfd (whole dialogue) or edh0, edh1... (an EDH cut of the game)"
    )
    parser.add_argument(
        "--file", type=existing_path, help="run this TEACh-format EDH or TfD instance file instead"
    )
    parser.add_argument(
        "--games", type=existing_dir, help="the games folder of --file (default: ../../games)"
    )
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--url", type=http_url, help="base URL of a running service")
    where.add_argument("--start-service", action="store_true", help="start a service for this run")
    parser.add_argument("--port", type=port, help="port of a running service (or for --start-service)")
    parser.add_argument(
        "--camera", type=int_at_least(32), default=DEFAULT_CAMERA.width, help="square frame side, px"
    )
    parser.add_argument(
        "--hfov", type=positive_float, default=TEACH_HFOV_DEG, help="horizontal field of view, deg"
    )
    parser.add_argument("--planner", default="oracle", choices=("oracle", "model"))
    parser.add_argument("--perception", default="oracle", choices=("oracle", "learned"))
    parser.add_argument("--navigator", default="fmm", choices=("fmm", "vin"))
    parser.add_argument("--explorer", choices=get_args(ExplorerName), help="default: the service's")
    parser.add_argument("--no-pose", action="store_true", help="do not send the world pose")
    parser.add_argument(
        "--give-success", action="store_true", help="tell the agent if its last action worked"
    )
    parser.add_argument("--no-noise", action="store_true", help="render without light/sensor noise")
    parser.add_argument("--multipart", action="store_true", help="send frames as multipart file parts")
    parser.add_argument(
        "--frames",
        choices=("png", "arrays"),
        default="png",
        help="png: PNG images as AI2-THOR runners send; arrays: .npy RGB and ids, float32 depth",
    )
    parser.add_argument("--out", type=Path, help="write the run's summary (metrics, actions) here (JSON)")
    return parser


def _chosen_episode(args: argparse.Namespace, camera: CameraSpec) -> Episode:
    """The instance file given with --file, else the generated game's --instance."""
    if args.file is not None:
        games = args.games or args.file.resolve().parents[2] / "games"
        if ".edh" in args.file.name:
            return load_edh(args.file, games)
        return load_tfd(args.file, games)
    tasks = (args.task,) if args.task else BENCHMARK_TASKS
    return generated_episode(args.split, args.index, camera, tasks, instance=args.instance)


def main(argv: Sequence[str] | None = None) -> int:
    """Run one EDH or TfD episode (generated, or from a file) through the agent service; print its metrics."""
    args = _parser().parse_args(argv)
    camera = CameraSpec(args.camera, args.camera, args.hfov)
    options = RunnerOptions(
        camera=camera,
        perception=args.perception,
        planner=args.planner,
        navigator=args.navigator,
        explorer=args.explorer,
        give_pose=not args.no_pose,
        give_success=args.give_success,
        noise=not args.no_noise,
        transport="multipart" if args.multipart else "json",
        frames=args.frames,
    )
    try:  # the service is asked first, so a wrong --url fails before the episode is built
        with service_url(args.url, args.port, args.start_service) as url, AgentClient(url) as client:
            episode = _chosen_episode(args, camera)
            print(f"{episode.benchmark} episode {episode.instance_id}: {episode.task.describe()}")
            for speaker, text in episode.dialogue:
                print(f"  {speaker}: {text}")
            if episode.history_subgoals:
                print(f"history subgoals: {format_subgoals(episode.history_subgoals)}")
            print(f"oracle plan: {format_subgoals(episode.future_subgoals)}")
            run = run_episode(episode, client, options)
    except ServiceUnreachable as error:
        fail("python -m harness run", str(error))
    except EpisodeUnavailable as error:
        print(f"no episode: {error}", file=sys.stderr)
        return 1
    print(f"service plan: {run.initial_plan['text']}")
    print("subgoals:")
    print("\n".join(describe_subgoals(run)))
    print("metrics:")
    print("\n".join(describe_metrics(run)))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(run.summary(), indent=2))
        print(f"wrote {args.out}")
    return 0
