"""``python -m harness run``: one EDH or TfD episode (generated, or from a file) through the agent service,
its subgoals and metrics printed."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, get_args

from harness.drive.client import AgentClient
from harness.drive.generated import EpisodeUnavailable, generated_episode
from harness.drive.runner import (
    DEFAULT_CAMERA,
    EpisodeRun,
    ExplorerName,
    RunnerOptions,
    describe_metrics,
    describe_subgoals,
    run_episode,
)
from harness.drive.service import ServiceUnreachable, add_service_arguments, service_url
from harness.episodes.model import Episode
from harness.episodes.teach_format import load_edh, load_tfd
from harness.render.camera import CameraSpec
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import SPLITS
from symbolic.cli_args import Parser, existing_dir, existing_path, fail, int_at_least, plain, positive_float
from symbolic.subgoals import format_subgoals
from symbolic.thor import TEACH_HFOV_DEG


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
    add_service_arguments(parser)
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
    print_run(run, args.out)
    return 0


def print_run(run: EpisodeRun, out: Path | None, extra: Mapping[str, Any] | None = None) -> None:
    """The run's subgoals and metrics on stdout; with ``out``, its summary (and ``extra``) as JSON there."""
    print("subgoals:")
    print("\n".join(describe_subgoals(run)))
    print("metrics:")
    print("\n".join(describe_metrics(run)))
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps({**run.summary(), **(extra or {})}, indent=2))
        print(f"wrote {out}")
