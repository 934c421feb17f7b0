"""TEACh's inference runner with ``RemoteModel``: one EDH instance driven as TEACh drives it (RGB frames as
PIL images, ``get_next_action``, the click read as ``[y, x]``), for checking the service against TEACh's
own protocol."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import httpx
from PIL import Image

from harness.drive.client import ServiceError, TeachRemoteModel
from harness.drive.runner import ActionRecord, EpisodeLog, EpisodeRun, RunnerOptions
from harness.episodes.model import Episode
from harness.sim.simulator import Simulator
from symbolic.thor import OBJECT_ACTIONS, TEACH_LOOK_STEP_DEG


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
