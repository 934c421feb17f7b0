"""TEACh's file formats: game files, EDH and TfD instances — the pieces to write them and the readers.

Field names are TEACh's (``../shared/data/teach/FORMATS.md``), so the readers take real TEACh files too. Our
files add three keys real TEACh files lack, all prefixed ``harness_`` so nobody mistakes them for TEACh's:

- ``initial_state.harness_world`` / ``final_state.harness_world``: ``World.to_dict()``, the state our
  simulator rebuilds exactly (TEACh games name an AI2-THOR floor plan instead; the objects' metadata,
  ``World.metadata()``, is under ``objects`` as TEACh has it);
- ``episodes[0].harness_camera``: the camera the click points were computed for (width, height, hfov,
  look step), so a replay resolves every click exactly as the expert's did.

Readers: ``read_game`` / ``read_instance`` read any TEACh-shaped file; ``load_game``, ``load_edh``,
``load_tfd`` and ``load_instructions`` rebuild runnable ``Episode``s and say clearly when a file is a real
TEACh one whose scene only AI2-THOR can rebuild. State diffs compare objects' metadata properties (position
and bounding box left out: a carried object's position changes at every step).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast, get_args

from harness.episodes.model import Benchmark, Episode
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.tasks.teach import TaskInstance, check_task
from harness.world.model import AgentState, RoomKind, World
from harness.world.splits import SPLITS, Split
from symbolic.ontology import load_ontology
from symbolic.subgoals import Subgoal, parse_subgoals
from symbolic.thor import (
    MOTION_ACTIONS,
    OBJECT_ACTIONS,
    TEACH_ACTION_IDS,
    TEACH_ACTION_IDX,
    TEACH_HFOV_DEG,
    TEACH_IMAGE_SIDE,
    TEACH_LOOK_STEP_DEG,
)

GAME_VERSION = "2.0"
"""TEACh's game-file version string."""
COMMANDER, DRIVER = 0, 1
"""TEACh's agent ids."""
TEXT_ACTION = "Text"
SPEAKERS: dict[int, str] = {COMMANDER: "Commander", DRIVER: "Driver"}

GAME_KEYS = ("version", "task_type", "comments", "definitions", "tasks")
TASK_KEYS = (
    "task_id",
    "task_name",
    "task_params",
    "task_nparams",
    "task_anchor_object",
    "desc",
    "components",
    "relations",
    "comments",
    "episodes",
)
EPISODE_KEYS = (
    "episode_id",
    "world",
    "world_type",
    "commander_embodied",
    "initial_state",
    "interactions",
    "final_state",
)
STATE_KEYS = ("time_start", "agents", "objects", "custom_object_metadata")
UTTERANCE_KEYS = (
    "agent_id",
    "action_id",
    "time_start",
    "duration",
    "success",
    "utterance",
    "corrected_utterance",
)
ACTION_KEYS = ("agent_id", "action_id", "time_start", "duration", "success", "x", "y", "oid")
HISTORY_ACTION_KEYS = (
    "action_id",
    "action_name",
    "action_idx",
    "time_start",
    "obj_interaction_action",
    "oid",
    "x",
    "y",
)
EDH_KEYS = (
    "game_id",
    "instance_id",
    "interactions",
    "pred_start_idx",
    "dialog_history",
    "dialog_history_cleaned",
    "driver_action_history",
    "driver_image_history",
    "driver_actions_future",
    "driver_images_future",
    "history_subgoals",
    "future_subgoals",
    "expected_init_goal_conditions_total",
    "expected_init_goal_conditions_satisfied",
    "init_state_diff",
    "final_state_diff",
    "state_changes",
)
TFD_KEYS = tuple(key for key in EDH_KEYS if key != "instance_id")
"""TEACh's TfD instances have no instance_id: it is the file's base name."""
HARNESS_EPISODE_KEYS = ("harness_camera",)
HARNESS_STATE_KEYS = ("harness_world",)

WORLD_TYPES: dict[RoomKind, str] = {
    "kitchen": "Kitchen",
    "living_room": "LivingRoom",
    "bedroom": "Bedroom",
    "bathroom": "Bathroom",
}
"""AI2-THOR's room-kind names, as TEACh's ``world_type`` gives them."""

DIFF_IGNORED = frozenset({"position", "axisAlignedBoundingBox"})
_CUSTOM_PROPERTIES = (
    "simbotIsCooked",
    "simbotIsBoiled",
    "simbotIsFilledWithCoffee",
    "simbotIsFilledWithWater",
    "simbotPickedUp",
)
"""TEACh's own object properties (kept in ``custom_object_metadata`` besides AI2-THOR's metadata)."""


class NotAHarnessFile(ValueError):
    """A TEACh-format file without our ``harness_`` keys (a real TEACh file): its scene needs AI2-THOR."""


# ---- writing pieces --------------------------------------------------------------------------------


def teach_definitions() -> dict[str, Any]:
    """The game file's ``definitions``: TEACh's two agents and the actions our files use."""
    kinds = {name: "Motion" for name in ("Stop", *MOTION_ACTIONS)} | {
        name: "ObjectInteraction" for name in OBJECT_ACTIONS
    }
    kinds[TEXT_ACTION] = "Keyboard"
    return {
        "agents": [
            {"agent_id": agent_id, "agent_name": name, "agent_type": agent_id}
            for agent_id, name in SPEAKERS.items()
        ],
        "actions": [
            {"action_id": TEACH_ACTION_IDS[name], "action_name": name, "action_type": kind}
            for name, kind in kinds.items()
        ],
    }


def camera_dict(camera: CameraSpec, look_step_deg: int) -> dict[str, Any]:
    return {
        "width": camera.width,
        "height": camera.height,
        "hfov_deg": camera.hfov_deg,
        "look_step_deg": look_step_deg,
    }


def agent_dict(agent: AgentState) -> dict[str, Any]:
    """An agent's pose as AI2-THOR's metadata reports it."""
    return {
        "position": {"x": agent.x, "y": agent.camera_height, "z": agent.z},
        "rotation": {"x": 0.0, "y": float(agent.yaw), "z": 0.0},
        "cameraHorizon": agent.horizon,
        "inventoryObjects": [{"objectId": agent.held}] if agent.held else [],
    }


def state_dict(world: World, time_start: float, commander: AgentState) -> dict[str, Any]:
    """A game state (``initial_state``/``final_state``); the commander is disembodied at ``commander``."""
    objects = world.metadata()
    return {
        "time_start": time_start,
        "agents": [agent_dict(commander), agent_dict(world.agent)],
        "objects": objects,
        "custom_object_metadata": {
            o["objectId"]: {key: o[key] for key in _CUSTOM_PROPERTIES} for o in objects
        },
        "harness_world": world.to_dict(),
    }


def utterance_entry(
    agent_id: int, text: str, corrected: str, time_start: float, duration: float
) -> dict[str, Any]:
    return {
        "agent_id": agent_id,
        "action_id": TEACH_ACTION_IDS[TEXT_ACTION],
        "time_start": time_start,
        "duration": duration,
        "success": 1,
        "utterance": text,
        "corrected_utterance": corrected,
    }


def action_entry(
    action: str,
    x: float | None,
    y: float | None,
    oid: str | None,
    success: bool,
    time_start: float,
    duration: float,
) -> dict[str, Any]:
    """A driver action in a game's ``interactions``."""
    clicks = action in OBJECT_ACTIONS
    return {
        "agent_id": DRIVER,
        "action_id": TEACH_ACTION_IDS[action],
        "time_start": time_start,
        "duration": duration,
        "success": int(success),
        "x": x if clicks else None,
        "y": y if clicks else None,
        "oid": oid,
    }


def history_action(entry: Mapping[str, Any]) -> dict[str, Any]:
    """A game interaction as an EDH ``driver_action_history``/``driver_actions_future`` entry."""
    name = _action_name(int(entry["action_id"]))
    return {
        "action_id": entry["action_id"],
        "action_name": name,
        "action_idx": TEACH_ACTION_IDX[name],
        "time_start": entry["time_start"],
        "obj_interaction_action": int(name in OBJECT_ACTIONS),
        "oid": entry.get("oid"),
        "x": entry.get("x"),
        "y": entry.get("y"),
    }


def image_name(time_start: float) -> str:
    """TEACh's name for the driver's view at an action's start."""
    return f"driver.frame.{time_start}.jpeg"


def _action_name(action_id: int) -> str:
    for name, known in TEACH_ACTION_IDS.items():
        if known == action_id:
            return name
    raise ValueError(f"action_id {action_id} is not a driver action we know: {TEACH_ACTION_IDS}")


def _comparable(objects: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    return {o["objectId"]: {k: v for k, v in o.items() if k not in DIFF_IGNORED} for o in objects}


def state_diff(before: World, after: World) -> dict[str, Any]:
    """Object properties that changed from ``before`` to ``after`` (new objects: all of theirs; objects that
    disappeared: ``{"removed": true}``), and the driver's changed pose fields under ``agents["1"]``."""
    old, new = _comparable(before.metadata()), _comparable(after.metadata())
    objects: dict[str, Any] = {}
    for oid, props in new.items():
        changed = {k: v for k, v in props.items() if oid not in old or old[oid].get(k) != v}
        if changed:
            objects[oid] = changed
    objects.update({oid: {"removed": True} for oid in old if oid not in new})
    a, b = agent_dict(before.agent), agent_dict(after.agent)
    agent = {k: v for k, v in b.items() if a[k] != v}
    return {"agents": {str(DRIVER): agent} if agent else {}, "objects": objects}


def write_json(path: Path, data: Mapping[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, separators=(",", ":")), encoding="utf-8")


# ---- reading -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GameFile:
    """A TEACh game file's contents, real or ours."""

    game_id: str
    task: TaskInstance
    interactions: tuple[dict[str, Any], ...]
    world_name: str
    world_type: str
    initial_objects: tuple[dict[str, Any], ...]
    """The initial state's object metadata (AI2-THOR's field names)."""
    harness_world: dict[str, Any] | None
    """Our ``World.to_dict()`` of the initial state; None in real TEACh games."""
    camera: CameraSpec
    look_step_deg: int

    def world(self) -> World:
        """The initial world; a real TEACh game (no ``harness_world``) raises NotAHarnessFile."""
        if self.harness_world is None:
            raise NotAHarnessFile(
                f"game {self.game_id} has no initial_state.harness_world: it is a real TEACh game whose "
                f"scene ({self.world_name}) only AI2-THOR can rebuild; read its task, dialogue and actions "
                "with read_game/read_instance, or generate episodes with `python -m harness generate`"
            )
        return World.from_dict(self.harness_world)


def _load_json(path: Path) -> dict[str, Any]:
    with path.open(encoding="utf-8") as handle:
        data = json.load(handle)
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data


def _require(data: Mapping[str, Any], keys: Iterable[str], where: str) -> None:
    missing = [key for key in keys if key not in data]
    if missing:
        raise ValueError(f"{where}: missing TEACh field(s) {missing}; present: {sorted(data)}")


def game_id_of(path: Path) -> str:
    """TEACh's rule: the game id is the file name up to the first dot."""
    return path.name.split(".", 1)[0]


def read_game(path: Path) -> GameFile:
    """Read a TEACh game file (``games/<split>/<game_id>.game.json``), ours or TEACh's."""
    data = _load_json(path)
    _require(data, GAME_KEYS, str(path))
    if not data["tasks"]:
        raise ValueError(f"{path}: 'tasks' is empty")
    task_data = data["tasks"][0]
    _require(task_data, ("task_id", "task_name", "task_params", "episodes"), f"{path} tasks[0]")
    episode = task_data["episodes"][0]
    _require(episode, EPISODE_KEYS, f"{path} tasks[0].episodes[0]")
    camera = episode.get("harness_camera") or {}
    return GameFile(
        game_id=game_id_of(path),
        task=TaskInstance.from_game_task(task_data),
        interactions=tuple(episode["interactions"]),
        world_name=str(episode["world"]),
        world_type=str(episode["world_type"]),
        initial_objects=tuple(episode["initial_state"].get("objects", ())),
        harness_world=episode["initial_state"].get("harness_world"),
        camera=CameraSpec(
            int(camera.get("width", TEACH_IMAGE_SIDE)),
            int(camera.get("height", TEACH_IMAGE_SIDE)),
            float(camera.get("hfov_deg", TEACH_HFOV_DEG)),
        ),
        look_step_deg=int(camera.get("look_step_deg", TEACH_LOOK_STEP_DEG)),
    )


def load_game(path: Path) -> tuple[World, TaskInstance, list[dict[str, Any]]]:
    """(initial world, task, interactions) of one of our game files."""
    game = read_game(path)
    return game.world(), game.task, list(game.interactions)


def read_instance(path: Path, benchmark: Benchmark) -> dict[str, Any]:
    """An EDH or TfD instance file's fields, checked against TEACh's field names."""
    data = _load_json(path)
    required = {
        "edh": ("game_id", "instance_id", "dialog_history", "driver_action_history", "pred_start_idx"),
        "tfd": ("game_id",),
    }.get(benchmark)
    if required is None:
        raise ValueError(f"benchmark {benchmark!r} has no instance files; known: edh, tfd")
    _require(data, required, str(path))
    return data


def replay(
    world: World, actions: Sequence[Mapping[str, Any]], camera: CameraSpec, look_step_deg: int
) -> World:
    """The world after TEACh action entries (``action_name``, ``x``, ``y``) are executed in our Simulator."""
    simulator = Simulator(world, camera, look_step_deg=look_step_deg)
    for entry in actions:
        simulator.step(str(entry["action_name"]), entry.get("x"), entry.get("y"))
    return simulator.world


def _subgoals(words: Sequence[str]) -> tuple[Subgoal, ...]:
    return tuple(parse_subgoals(list(words), load_ontology())) if words else ()


def _dialogue(history: Sequence[Sequence[str]]) -> tuple[tuple[str, str], ...]:
    return tuple((str(speaker), str(text)) for speaker, text in history)


def _split_of(path: Path, split: Split | None) -> Split:
    if split is not None:
        return split
    folder = path.parent.name
    if folder not in get_args(Split):
        raise ValueError(
            f"{path}: cannot tell the split from folder {folder!r}; pass split= one of {list(SPLITS)}"
        )
    return cast(Split, folder)


def _game_path(games_dir: Path, game_id: str, split: Split) -> Path:
    for candidate in (games_dir / f"{game_id}.game.json", games_dir / split / f"{game_id}.game.json"):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"game {game_id}.game.json is neither in {games_dir} nor in {games_dir / split}")


def load_edh(path: Path, games_dir: Path, split: Split | None = None) -> Episode:
    """An EDH instance as a runnable episode: the game's world with the history actions replayed."""
    data = read_instance(path, "edh")
    split = _split_of(path, split)
    game = read_game(_game_path(games_dir, data["game_id"], split))
    history = tuple(data["driver_action_history"])
    world = replay(game.world(), history, game.camera, game.look_step_deg)
    return Episode(
        instance_id=str(data["instance_id"]),
        benchmark="edh",
        split=split,
        world=world,
        task=game.task,
        dialogue=_dialogue(data["dialog_history"]),
        history_actions=history,
        history_subgoals=_subgoals(data.get("history_subgoals", ())),
        future_subgoals=_subgoals(data.get("future_subgoals", ())),
        reference_actions=tuple(data.get("driver_actions_future", ())),
        metadata=_metadata(data, game),
    )


def _metadata(data: Mapping[str, Any], game: GameFile) -> dict[str, Any]:
    keys = (
        "pred_start_idx",
        "expected_init_goal_conditions_total",
        "expected_init_goal_conditions_satisfied",
    )
    return {
        "game_id": game.game_id,
        "world_name": game.world_name,
        "world_type": game.world_type,
        "camera": game.camera,
        "look_step_deg": game.look_step_deg,
        **{key: data[key] for key in keys if key in data},
    }


def _game_dialogue(interactions: Iterable[Mapping[str, Any]]) -> tuple[tuple[str, str], ...]:
    return tuple(
        (SPEAKERS[int(i["agent_id"])], str(i["utterance"])) for i in interactions if "utterance" in i
    )


def _game_actions(interactions: Iterable[Mapping[str, Any]]) -> tuple[dict[str, Any], ...]:
    text_id = TEACH_ACTION_IDS[TEXT_ACTION]
    return tuple(
        history_action(i)
        for i in interactions
        if int(i["agent_id"]) == DRIVER and int(i["action_id"]) != text_id
    )


def load_tfd(path: Path, games_dir: Path, split: Split | None = None) -> Episode:
    """A TfD instance as a runnable episode: the game's initial world and the whole dialogue.

    The instance id is the file's base name (TEACh's TfD files carry none); dialogue and reference actions
    come from the instance, or from the game's interactions when the instance omits them.
    """
    data = read_instance(path, "tfd")
    split = _split_of(path, split)
    game = read_game(_game_path(games_dir, data["game_id"], split))
    world = game.world()
    dialogue = (
        _dialogue(data["dialog_history"]) if "dialog_history" in data else _game_dialogue(game.interactions)
    )
    reference = tuple(data.get("driver_actions_future") or _game_actions(game.interactions))
    return Episode(
        instance_id=path.name.removesuffix(".json"),
        benchmark="tfd",
        split=split,
        world=world,
        task=game.task,
        dialogue=dialogue,
        future_subgoals=_subgoals(data.get("future_subgoals", ())),
        reference_actions=reference,
        metadata=_metadata(data, game),
    )


def load_instructions(path: Path, games_dir: Path) -> list[Episode]:
    """ALFRED-style instruction episodes of one ``alfred_instructions/<split>.jsonl`` file."""
    split = path.name.removesuffix(".jsonl")
    if split not in get_args(Split):
        raise ValueError(f"{path}: expected <split>.jsonl with split one of {list(SPLITS)}")
    episodes = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        record = json.loads(line)
        game = read_game(_game_path(games_dir, record["game_id"], cast(Split, split)))
        episodes.append(
            Episode(
                instance_id=str(record["instance_id"]),
                benchmark="alfred",
                split=cast(Split, split),
                world=game.world(),
                task=game.task,
                instruction=str(record["instruction"]),
                future_subgoals=_subgoals(record.get("subgoals", ())),
                reference_actions=_game_actions(game.interactions),
                metadata={"game_id": game.game_id, "world_name": game.world_name},
            )
        )
    return episodes


def goal_counts(task: TaskInstance, world: World) -> tuple[int, int]:
    """(total, satisfied) goal conditions, TEACh's ``expected_init_goal_conditions_*`` pair."""
    report = check_task(task, world)
    return report.total, report.satisfied
