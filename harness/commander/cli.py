"""``python -m harness commander``: one TATC episode, the commander here and the follower over HTTP."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import get_args

from harness.commander.bot import InfoLevel
from harness.commander.episode import run_tatc_episode
from harness.drive.client import AgentClient
from harness.drive.generated import EpisodeUnavailable, generated_tfd_episode
from harness.drive.run_cli import print_run
from harness.drive.runner import DEFAULT_CAMERA, RunnerOptions
from harness.drive.service import ServiceUnreachable, add_service_arguments, service_url
from harness.render.camera import CameraSpec
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import SPLITS
from symbolic.cli_args import Parser, fail, int_at_least, plain
from symbolic.thor import TEACH_HFOV_DEG


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m harness commander", description=plain(main.__doc__))
    parser.add_argument("--task", choices=BENCHMARK_TASKS, help="only this task (default: index %% 12)")
    parser.add_argument("--split", default="valid_unseen", choices=SPLITS)
    parser.add_argument("--index", type=int_at_least(0), default=0, help="generated game within the split")
    parser.add_argument(
        "--info", default="full", choices=get_args(InfoLevel), help="what the commander may tell"
    )
    add_service_arguments(parser, "follower service")
    parser.add_argument(
        "--camera", type=int_at_least(32), default=DEFAULT_CAMERA.width, help="square frame side, px"
    )
    parser.add_argument("--perception", default="oracle", choices=("oracle", "learned"))
    parser.add_argument("--out", type=Path, help="write the run's summary here (JSON)")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one TATC episode: the commander bot converses with the follower service; print the dialogue."""
    args = _parser().parse_args(argv)
    camera = CameraSpec(args.camera, args.camera, TEACH_HFOV_DEG)
    tasks = (args.task,) if args.task else BENCHMARK_TASKS
    try:
        episode = generated_tfd_episode(args.split, args.index, camera, tasks)
    except EpisodeUnavailable as error:
        print(f"no episode: {error}", file=sys.stderr)
        return 1
    print(f"TATC episode {episode.instance_id}: {episode.task.describe()} (commander info: {args.info})")
    options = RunnerOptions(camera=camera, perception=args.perception, delete_session=False)
    try:
        with (
            service_url(args.url, args.port, args.start_service) as url,
            AgentClient(url, timeout=120) as client,
        ):
            run = run_tatc_episode(episode, client, options, args.info)
            dialogue = client.get_session(run.session_id)["dialogue"]
            client.delete(run.session_id)
    except ServiceUnreachable as error:
        fail("python -m harness commander", str(error))
    for turn in dialogue:
        print(f"  {turn['speaker']}: {turn['text']}")
    print_run(run, args.out, {"dialogue": dialogue})
    return 0
