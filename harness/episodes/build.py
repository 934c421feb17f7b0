"""World + task + expert trajectory -> a TEACh game, its EDH cuts, its TfD instance and an ALFRED instruction.

The expert's actions are replayed in a fresh Simulator (the same camera, so every click resolves as it did
for the expert), which checks them and gives the states the files need: the world where each instruction
starts (for where-questions, EDH goal-condition counts and state diffs) and, with images on, the driver's
view before every action. The dialogue (``harness.episodes.dialogue``) is woven between the actions:
each instruction's turns come right before the actions that carry it out.

EDH instances are cut as TEACh cuts them, at a dialogue turn: prediction starts at the first action after
an instruction, the history is everything before it, and the future runs to the next utterance. Their
subgoals follow the §5 rule (``subgoals_from_teach_actions``) on the history and future actions.
"""

from __future__ import annotations

import hashlib
import io
import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from PIL import Image

from harness.episodes.dialogue import (
    Chunk,
    Dialogue,
    DialogueConfig,
    Turn,
    alfred_instruction,
    chunk_steps,
    plan_steps,
    visible_object_ids,
    write_dialogue,
)
from harness.episodes.phrases import PhraseBank
from harness.episodes.teach_format import (
    COMMANDER,
    DRIVER,
    GAME_VERSION,
    SPEAKERS,
    WORLD_TYPES,
    action_entry,
    camera_dict,
    goal_counts,
    history_action,
    image_name,
    state_dict,
    state_diff,
    teach_definitions,
    utterance_entry,
)
from harness.expert.expert import ExpertAction, ExpertTrajectory
from harness.render.camera import TEACH_CAMERA, CameraSpec
from harness.render.renderer import Renderer
from harness.sim.simulator import Simulator
from harness.tasks.teach import TaskInstance
from harness.world.model import World
from harness.world.splits import Split
from symbolic.ontology import Ontology
from symbolic.subgoals import subgoals_from_teach_actions, to_teach_words
from symbolic.thor import TEACH_LOOK_STEP_DEG


@dataclass(frozen=True)
class BuildConfig:
    """How a game is turned into files."""

    camera: CameraSpec = TEACH_CAMERA
    """The driver's camera; must be the one the expert's clicks were computed for."""
    look_step_deg: int = TEACH_LOOK_STEP_DEG  # degrees per Look Up/Down (TEACh)
    edh_per_game: int = 3  # EDH instances cut from one game at most
    visibility_side_px: int = 96  # width of the render that decides what the driver can see, pixels
    images: bool = False  # keep JPEGs of the driver's view before every action
    jpeg_quality: int = 90  # JPEG quality of kept frames (1-95)
    dialogue: DialogueConfig = field(default_factory=DialogueConfig)


class BuildError(RuntimeError):
    """The trajectory cannot be made into a game (it failed, or does not replay as recorded).

    ``kind`` is a short category for the generator's failure histogram ("expert: no plan").
    """

    def __init__(self, kind: str, detail: str) -> None:
        super().__init__(f"{kind}: {detail}")
        self.kind = kind


@dataclass(frozen=True)
class GameSource:
    """Where a game comes from: split, index within it, and the seeds of its world and task."""

    split: Split
    index: int
    world: World
    task: TaskInstance
    world_seed: int
    task_seed: int

    @property
    def game_id(self) -> str:
        """TEACh-shaped id (16 hex digits, underscore, a number), stable for the same source."""
        key = f"{self.split}|{self.index}|{self.world_seed}|{self.task_seed}|{self.task.task_name}"
        return f"{hashlib.sha1(key.encode()).hexdigest()[:16]}_{self.index:04d}"


@dataclass(frozen=True)
class BuiltGame:
    """Everything written for one game (file contents, not yet on disk)."""

    game_id: str
    split: Split
    task_name: str
    game: dict[str, Any]
    edh: tuple[dict[str, Any], ...]
    tfd: dict[str, Any]
    instruction: dict[str, Any]
    frames: dict[str, bytes]
    """Image file name -> JPEG bytes (empty unless images were asked for)."""
    dialogue: Dialogue
    chunks: tuple[Chunk, ...]
    chunk_worlds: tuple[World, ...]
    """The world when each chunk (instruction) starts."""


@dataclass
class _Replay:
    snapshots: dict[int, World]
    """Action index -> world before that action (index len(actions): the final world)."""
    frames: list[bytes]


def _replay(world: World, trajectory: ExpertTrajectory, keep: set[int], config: BuildConfig) -> _Replay:
    """Re-run the expert's actions, keeping the worlds before the actions in ``keep``.

    Without images the replay stops after the last kept index and the final world is the expert's own
    (its actions ran in a Simulator too); with images every action is replayed to render its frame.
    """
    actions = trajectory.actions
    simulator = Simulator(world.copy(), config.camera, look_step_deg=config.look_step_deg)
    snapshots: dict[int, World] = {}
    frames: list[bytes] = []
    stop = len(actions) if config.images else max(keep)
    for i, action in enumerate(actions[:stop]):
        if i in keep:
            snapshots[i] = simulator.world.copy()
        if config.images:
            frames.append(_jpeg(simulator, config.jpeg_quality))
        result = simulator.step(action.action, action.x, action.y)
        if result.success != action.success or (result.success and result.object_id != action.object_id):
            raise BuildError(
                "replay diverged",
                f"action {i} ({action.action} at {action.x}, {action.y}): expert recorded "
                f"success={action.success} on {action.object_id}, replay gave {result.success} on "
                f"{result.object_id} ({result.message})",
            )
    if stop in keep:
        snapshots[stop] = simulator.world.copy()
    snapshots[len(actions)] = (
        simulator.world.copy() if stop == len(actions) else trajectory.final_world.copy()
    )
    return _Replay(snapshots, frames)


def _jpeg(simulator: Simulator, quality: int) -> bytes:
    frame = simulator.observe()
    assert frame.rgb is not None, "observe() renders RGB"
    buffer = io.BytesIO()
    Image.fromarray(frame.rgb).save(buffer, format="JPEG", quality=quality)
    return buffer.getvalue()


class _Clock:
    """TEACh-like timestamps: typing takes time in proportion to length, actions about a second each."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.now = round(rng.uniform(2.0, 8.0), 3)

    def utterance(self, text: str) -> tuple[float, float]:
        start = self.now
        duration = round(1.0 + 0.05 * len(text) + self.rng.uniform(0.0, 1.5), 3)
        self.now = round(start + duration + self.rng.uniform(0.5, 3.0), 3)
        return start, duration

    def action(self) -> tuple[float, float]:
        start = self.now
        duration = 1
        self.now = round(start + self.rng.uniform(0.6, 1.8), 3)
        return start, duration


def _interactions(
    actions: Sequence[ExpertAction], chunks: Sequence[Chunk], dialogue: Dialogue, clock: _Clock
) -> tuple[list[dict[str, Any]], list[int]]:
    """The game's interactions, and for each chunk the index of its first action in them."""
    entries: list[dict[str, Any]] = []
    starts: list[int] = []

    def say(turn: Turn) -> None:
        start, duration = clock.utterance(turn.utterance)
        agent = COMMANDER if turn.speaker == SPEAKERS[COMMANDER] else DRIVER
        entries.append(utterance_entry(agent, turn.utterance, turn.corrected, start, duration))

    for chunk, turns in zip(chunks, dialogue.before, strict=True):
        for turn in turns:
            say(turn)
        starts.append(len(entries))
        for action in actions[chunk.start : chunk.end]:
            start, duration = clock.action()
            entries.append(
                action_entry(
                    action.action, action.x, action.y, action.object_id, action.success, start, duration
                )
            )
    for turn in dialogue.closing:
        say(turn)
    return entries, starts


def _is_utterance(entry: dict[str, Any]) -> bool:
    return "utterance" in entry


def _instance(
    interactions: list[dict[str, Any]],
    pred: tuple[int, int],
    said_until: int,
    counts: tuple[int, int],
    diffs: tuple[dict[str, Any], dict[str, Any], dict[str, Any]],
) -> dict[str, Any]:
    """The fields EDH and TfD instances share: prediction over ``interactions[pred[0]:pred[1]]``, with the
    dialogue up to ``said_until`` (EDH: the prediction start; TfD: the whole game)."""
    start, end = pred
    history = [history_action(e) for e in interactions[:start] if not _is_utterance(e)]
    future = [history_action(e) for e in interactions[start:end] if not _is_utterance(e)]
    said = [e for e in interactions[:said_until] if _is_utterance(e)]
    init_diff, final_diff, changes = diffs
    return {
        "interactions": interactions,
        "pred_start_idx": start,
        "dialog_history": [[SPEAKERS[e["agent_id"]], e["utterance"]] for e in said],
        "dialog_history_cleaned": [[SPEAKERS[e["agent_id"]], e["corrected_utterance"]] for e in said],
        "driver_action_history": history,
        "driver_image_history": [image_name(a["time_start"]) for a in history],
        "driver_actions_future": future,
        "driver_images_future": [image_name(a["time_start"]) for a in future],
        "history_subgoals": to_teach_words(subgoals_from_teach_actions(history)),
        "future_subgoals": to_teach_words(subgoals_from_teach_actions(future)),
        "expected_init_goal_conditions_total": counts[0],
        "expected_init_goal_conditions_satisfied": counts[1],
        "init_state_diff": init_diff,
        "final_state_diff": final_diff,
        "state_changes": changes,
    }


def _edh_instances(
    game_id: str,
    task: TaskInstance,
    chunks: Sequence[Chunk],
    interactions: list[dict[str, Any]],
    pred_starts: Sequence[int],
    snapshots: dict[int, World],
    edh_per_game: int,
) -> list[dict[str, Any]]:
    """Up to ``edh_per_game`` EDH instances, each cut where a (seeded) chunk's actions start."""
    start_world = snapshots[0]
    rng = random.Random(f"{game_id}|edh")
    cuts = sorted(rng.sample(range(len(chunks)), k=min(edh_per_game, len(chunks))))
    instances = []
    for number, c in enumerate(cuts):
        chunk = chunks[c]
        at, after = snapshots[chunk.start], snapshots[chunk.end]
        pred = (pred_starts[c], pred_starts[c] + chunk.end - chunk.start)
        diffs = (state_diff(start_world, at), state_diff(start_world, after), state_diff(at, after))
        fields = _instance(interactions, pred, pred[0], goal_counts(task, at), diffs)
        instances.append({"game_id": game_id, "instance_id": f"{game_id}.edh{number}", **fields})
    return instances


def _tfd_instance(
    game_id: str, task: TaskInstance, interactions: list[dict[str, Any]], start: World, final: World
) -> dict[str, Any]:
    """The whole game as one TfD instance: every utterance given, every driver action to predict."""
    whole = len(interactions)
    diffs = (state_diff(start, start), state_diff(start, final), state_diff(start, final))
    return {"game_id": game_id, **_instance(interactions, (0, whole), whole, goal_counts(task, start), diffs)}


def _instruction(game_id: str, source: GameSource, subgoals: list[str], bank: PhraseBank) -> dict[str, Any]:
    """An ALFRED-style record: one high-level sentence, with the game's task, world and reference subgoals."""
    task = source.task
    return {
        "instance_id": f"{game_id}.alfred0",
        "game_id": game_id,
        "instruction": alfred_instruction(task, bank, random.Random(f"{game_id}|instruction")),
        "task": {"task_id": task.task_id, "task_name": task.task_name, "task_params": list(task.params)},
        "world": source.world.name,
        "subgoals": subgoals,
    }


def build_game(
    source: GameSource,
    trajectory: ExpertTrajectory,
    config: BuildConfig,
    bank: PhraseBank,
    ontology: Ontology,
) -> BuiltGame:
    """The files of one game. Raises BuildError if the expert failed or its actions do not replay."""
    if not trajectory.success:
        category, _, detail = (trajectory.failure_reason or "goal not met").partition(":")
        raise BuildError(f"expert: {category}", detail.strip() or category)
    game_id = source.game_id
    actions = trajectory.actions
    steps = plan_steps(actions, source.world, ontology)
    if not steps:
        raise BuildError("nothing to say", "the trajectory has no successful interaction")
    chunks = chunk_steps(steps, random.Random(f"{game_id}|chunks"), config.dialogue.two_steps)
    replayed = _replay(source.world, trajectory, {c.start for c in chunks} | {0}, config)
    snapshots, final = replayed.snapshots, replayed.snapshots[len(actions)]
    chunk_worlds = tuple(snapshots[c.start] for c in chunks)
    camera = config.camera
    side = config.visibility_side_px
    view = Renderer(CameraSpec(side, max(1, round(side * camera.height / camera.width)), camera.hfov_deg))
    visible = [visible_object_ids(world, view) for world in chunk_worlds]
    dialogue_rng = random.Random(f"{game_id}|dialogue")
    dialogue = write_dialogue(
        source.task, chunks, chunk_worlds, visible, bank, ontology, dialogue_rng, config.dialogue
    )
    clock = _Clock(random.Random(f"{game_id}|time"))
    interactions, pred_starts = _interactions(actions, chunks, dialogue, clock)
    last = interactions[-1]
    game = _game_file(
        source, game_id, interactions, final, float(last["time_start"] + last["duration"]), config
    )
    edh = _edh_instances(
        game_id, source.task, chunks, interactions, pred_starts, snapshots, config.edh_per_game
    )
    tfd = _tfd_instance(game_id, source.task, interactions, snapshots[0], final)
    frame_names = [image_name(e["time_start"]) for e in interactions if not _is_utterance(e)]
    return BuiltGame(
        game_id=game_id,
        split=source.split,
        task_name=source.task.task_name,
        game=game,
        edh=tuple(edh),
        tfd=tfd,
        instruction=_instruction(game_id, source, tfd["future_subgoals"], bank),
        frames=dict(zip(frame_names, replayed.frames, strict=True)) if config.images else {},
        dialogue=dialogue,
        chunks=tuple(chunks),
        chunk_worlds=chunk_worlds,
    )


def _game_file(
    source: GameSource,
    game_id: str,
    interactions: list[dict[str, Any]],
    final: World,
    end_time: float,
    config: BuildConfig,
) -> dict[str, Any]:
    world = source.world
    task = source.task.to_game_task()
    task["episodes"] = [
        {
            "episode_id": game_id,
            "world": world.name,
            "world_type": WORLD_TYPES[world.room.kind],
            "commander_embodied": False,
            "initial_state": state_dict(world, 0.0, world.agent),
            "interactions": interactions,
            "final_state": state_dict(final, end_time, world.agent),
            "harness_camera": camera_dict(config.camera, config.look_step_deg),
        }
    ]
    return {
        "version": GAME_VERSION,
        "task_type": source.task.task_name,
        "comments": (
            f"generated by `python -m harness generate`: split {source.split}, index {source.index}, "
            f"world seed {source.world_seed}, task seed {source.task_seed}"
        ),
        "definitions": teach_definitions(),
        "tasks": [task],
    }
