"""``python -m harness demo`` (``make demo``): one multi-step kitchen TEACh task through the HTTP service.

Starts the service as a subprocess, drives one generated TfD episode with oracle perception and oracle
subgoals over real HTTP (``harness.drive.runner``), prints the dialogue, the oracle plan, the plan the service
repaired (JARVIS Alg. 2, with its repair log), each subgoal's outcome and SR/GC/TLW, writes the agent's
semantic map (``map.png``), a GIF of the egocentric frames (``episode.gif``), the service's per-step trace
(``trace.ndjson``) and the run summary (``summary.json``), then stops the service. The exit code is 0
whenever the run completed, whether or not the agent solved the task: the printout says which.
"""

from __future__ import annotations

import argparse
import io
import json
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from harness.drive.client import AgentClient, ServiceError
from harness.drive.generated import EpisodeUnavailable, generated_tfd_episode
from harness.drive.gif import StepPicture, write_episode_gif
from harness.drive.runner import (
    DEFAULT_CAMERA,
    ActionRecord,
    EpisodeRun,
    RunnerOptions,
    describe_metrics,
    describe_subgoals,
    run_episode,
)
from harness.drive.service import ServiceStartError, port_is_free, running_service
from harness.render.camera import CameraSpec
from harness.render.renderer import Frame
from harness.tasks.teach import BENCHMARK_TASKS
from symbolic.cli_args import Parser, int_at_least, plain, port
from symbolic.subgoals import format_subgoals
from symbolic.thor import TEACH_HFOV_DEG

DEMO_TASK = "N Cooked Slices Of X In Y"
"""A multi-step kitchen task: find a knife, slice, cook the slices in the microwave, serve them on a plate."""
DEMO_INDEX = 44
"""The generator's valid_unseen game of the demo (a world never used for training), chosen among games the
agent solves; nothing about it is scripted: the whole pipeline runs."""
DEFAULT_OUT = Path("out/demo")
GIF_MAX_FRAMES = 200  # a long episode's GIF keeps every k-th frame so it stays a few MB


def _say(text: str) -> None:
    """The demo's output, for the person who typed ``make demo``."""
    sys.stdout.write(text + "\n")
    sys.stdout.flush()


def _caption(record: ActionRecord, plan: Sequence[str]) -> tuple[str, ...]:
    """Step, action, click point and outcome; the subgoal it served; the service's reason."""
    click = f" at ({record.x:.2f}, {record.y:.2f})" if record.x is not None and record.y is not None else ""
    status = "ok" if record.success else f"failed: {record.failure}"
    where = f"{record.pointer + 1}/{len(plan)}" if record.pointer < len(plan) else "done"
    return (
        f"step {record.step}: {record.action}{click}  {status}",
        f"subgoal {where}: {record.subgoal or '-'}",
        f"why: {record.reason}",
    )


def _end_caption(run: EpisodeRun) -> tuple[str, ...]:
    verdict = "SUCCESS" if run.outcome.success else f"FAILED: {run.failure}"
    return (f"end after {len(run.actions)} actions", verdict)


class MapRecordingClient(AgentClient):
    """An AgentClient that also fetches the session's map after every answered step (for the GIF)."""

    def __init__(self, base_url: str) -> None:
        super().__init__(base_url)
        self.maps: list[bytes] = []

    def step(self, session_id: str, frame: Frame, **options: Any) -> dict[str, Any]:
        """``AgentClient.step`` (same options), then the session's map as it stands after that step."""
        result = super().step(session_id, frame, **options)
        self.maps.append(self.map_png(session_id))
        return result


def _png_rgb(data: bytes) -> np.ndarray:
    with Image.open(io.BytesIO(data)) as picture:
        return np.asarray(picture.convert("RGB"))


def episode_pictures(run: EpisodeRun, maps: Sequence[bytes]) -> list[StepPicture]:
    """Frame i (seen before action i) with action i's click, the map after step i, and its caption; the
    last frame (after the last action) with the last map and the outcome."""
    pictures = []
    for frame, record, map_png in zip(run.frames, run.actions, maps, strict=False):
        click = (record.x, record.y) if record.x is not None and record.y is not None else None
        caption = _caption(record, run.plans[record.plan_version])
        pictures.append(StepPicture(frame, _png_rgb(map_png), click, caption))
    if len(run.frames) > len(pictures):
        last_map = _png_rgb(maps[-1]) if maps else None
        pictures.append(StepPicture(run.frames[-1], last_map, None, _end_caption(run)))
    return pictures


def _print_plan(plan: Mapping[str, Any], title: str) -> None:
    _say(f"\n{title} ({len(plan['subgoals'])} subgoals):\n  {plan['text']}")
    if plan["repair_log"]:
        _say("Repair log:")
        for event in plan["repair_log"]:
            inserted = ", ".join(s["text"] for s in event["inserted"]) or "-"
            removed = ", ".join(s["text"] for s in event["removed"]) or "-"
            _say(f"  [{event['rule']}] at {event['index']}: +[{inserted}] -[{removed}]  ({event['reason']})")


class LiveProgress:
    """Prints the plan the service works from, then a line whenever it moves on to another subgoal."""

    def __init__(self) -> None:
        self._plan_text: str | None = None
        self._at: tuple[str, int] | None = None

    def __call__(self, record: ActionRecord, result: Mapping[str, Any]) -> None:
        plan = result["plan"]
        if plan["text"] != self._plan_text:
            title = (
                "Service plan after repair"
                if self._plan_text is None
                else f"Re-planned at step {record.step}"
            )
            _print_plan(plan, title)
            _say("Progress:")
            self._plan_text = plan["text"]
        at = (plan["text"], record.pointer)
        if at != self._at and record.subgoal is not None:
            _say(f"  step {record.step:>4}: {record.subgoal}  ({record.reason})")
        self._at = at


def _write_outputs(run: EpisodeRun, client: MapRecordingClient, out: Path, gif_every: int) -> list[Path]:
    """map.png and trace.ndjson from the service, episode.gif and summary.json from the run."""
    out.mkdir(parents=True, exist_ok=True)
    map_path = out / "map.png"
    map_path.write_bytes(client.map_png(run.session_id))
    trace_path = out / "trace.ndjson"
    trace_path.write_text("".join(json.dumps(line) + "\n" for line in client.trace(run.session_id)))
    pictures = episode_pictures(run, client.maps)
    every = max(gif_every, math.ceil(len(pictures) / GIF_MAX_FRAMES))
    gif_path = write_episode_gif(pictures, out / "episode.gif", every=every)
    summary_path = out / "summary.json"
    summary_path.write_text(json.dumps(run.summary(), indent=2))
    return [map_path, gif_path, trace_path, summary_path]


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m harness demo", description=plain(__doc__.splitlines()[0]))
    parser.add_argument("--port", type=port, help="port for the service (a free one if absent or busy)")
    parser.add_argument("--out-dir", type=Path, default=DEFAULT_OUT, help="where map.png, episode.gif... go")
    parser.add_argument("--task", default=DEMO_TASK, choices=BENCHMARK_TASKS)
    parser.add_argument(
        "--index", type=int_at_least(0), default=DEMO_INDEX, help="valid_unseen episode index"
    )
    parser.add_argument(
        "--camera", type=int_at_least(32), default=DEFAULT_CAMERA.width, help="square frame side, px"
    )
    parser.add_argument(
        "--gif-every",
        type=int_at_least(1),
        default=1,
        help=f"keep every k-th frame (at most {GIF_MAX_FRAMES} frames)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    port = args.port
    if port is not None and not port_is_free(port):
        _say(f"port {port} is busy; the demo's service takes a free port instead")
        port = None
    camera = CameraSpec(args.camera, args.camera, TEACH_HFOV_DEG)
    _say(
        f"Building the episode: {args.task!r}, valid_unseen #{args.index} (world, task, expert, dialogue)..."
    )
    try:
        episode = generated_tfd_episode("valid_unseen", args.index, camera, tasks=(args.task,))
    except EpisodeUnavailable as error:
        _say(f"No demo episode: {error}; try another --index")
        return 1
    _say(f"\nTask: {episode.task.describe()}  [{episode.instance_id}, {episode.world.room.kind}]")
    _say("Dialogue:")
    for speaker, text in episode.dialogue:
        _say(f"  {speaker}: {text}")
    _say(f"\nOracle plan ({len(episode.future_subgoals)} subgoals, the expert's):")
    _say(f"  {format_subgoals(episode.future_subgoals)}")
    options = RunnerOptions(camera=camera, record_frames=True, delete_session=False)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    try:
        with running_service(port, log_path=args.out_dir / "service.log") as service:
            _say(f"\nService ready at {service.base_url}; running the episode over HTTP...")
            client = MapRecordingClient(service.base_url)
            with client:
                run = run_episode(episode, client, options, on_step=LiveProgress())
                _say("\nSubgoals:")
                _say("\n".join(describe_subgoals(run)))
                _say("\nResult:")
                _say("\n".join(describe_metrics(run)))
                _say(f"  {'SUCCESS' if run.outcome.success else 'FAILED'}: {run.failure or 'task complete'}")
                written = _write_outputs(run, client, args.out_dir, args.gif_every)
                client.delete(run.session_id)
    except (ServiceStartError, ServiceError) as error:
        _say(f"\nThe demo could not complete: {error}")
        return 1
    _say("\nWrote:")
    for path in [*written, args.out_dir / "service.log"]:
        _say(f"  {path}")
    _say("Service stopped.")
    return 0
