"""Episodes of the games ``python -m harness generate`` writes, made on demand in a temporary folder and
read back through the TEACh-format reader, so a run sees exactly what the files hold."""

from __future__ import annotations

import io
import re
import tempfile
from collections.abc import Sequence
from pathlib import Path

from harness.drive.runner import DEFAULT_CAMERA
from harness.drive.teach_remote import TeachInstance, load_teach_instance
from harness.episodes.build import BuildConfig, BuildError
from harness.episodes.generate import GenerateConfig, generate_one, write_game
from harness.episodes.model import Episode
from harness.episodes.phrases import load_phrase_bank
from harness.episodes.sample import TaskSamplingError
from harness.episodes.teach_format import load_edh, load_tfd
from harness.render.camera import CameraSpec
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import Split
from symbolic.ontology import load_ontology


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
