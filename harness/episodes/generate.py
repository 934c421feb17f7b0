"""``python -m harness generate``: TEACh-format games, EDH and TfD instances and ALFRED-style instructions.

For each split and each index ``i`` in ``[seed_start, seed_start + n)``: the task is ``tasks[i % len(tasks)]``
(the 12 TEACh benchmark tasks by default), the world and task seeds come from ``harness.world.splits`` (so
valid_unseen only ever uses world seeds train never does), the expert solves it and ``build.build_game``
makes the files. Games whose task cannot be posed or whose expert fails are skipped and counted, with
reasons, in ``manifest.json``. Output, in TEACh's layout::

    OUT/games/<split>/<game_id>.game.json
    OUT/edh_instances/<split>/<game_id>.edh<k>.json
    OUT/tfd_instances/<split>/<game_id>.tfd0.json
    OUT/images/<split>/<game_id>/driver.frame.<time>.jpeg     (only with --images)
    OUT/alfred_instructions/<split>.jsonl
    OUT/manifest.json
"""

from __future__ import annotations

import argparse
import importlib.metadata
import json
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO, cast

from tqdm import tqdm

from harness.episodes.build import BuildConfig, BuildError, BuiltGame, GameSource, build_game
from harness.episodes.phrases import PhraseBank, load_phrase_bank
from harness.episodes.sample import TaskSamplingError, sample_task_world
from harness.episodes.teach_format import GAME_VERSION, camera_dict, write_json
from harness.expert.expert import ExpertConfig, run_expert
from harness.render.camera import CameraSpec
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import SPLITS, Split, task_seed, world_seed
from symbolic.cli_args import Parser, int_at_least
from symbolic.ontology import Ontology, load_ontology
from symbolic.thor import TEACH_HFOV_DEG, TEACH_IMAGE_SIDE, TEACH_LOOK_STEP_DEG

DISTRIBUTION = "jarvis-service"


@dataclass
class SplitTally:
    """What one split produced, for the manifest."""

    requested: int = 0
    games: int = 0
    edh_instances: int = 0
    tfd_instances: int = 0
    per_task: Counter[str] = field(default_factory=Counter)
    failure_kinds: Counter[str] = field(default_factory=Counter)
    failed: list[dict[str, Any]] = field(default_factory=list)
    world_seeds: set[int] = field(default_factory=set)
    seconds: float = 0.0

    def as_json(self) -> dict[str, Any]:
        return {
            "requested": self.requested,
            "games": self.games,
            "edh_instances": self.edh_instances,
            "tfd_instances": self.tfd_instances,
            "per_task": dict(sorted(self.per_task.items())),
            "failures": dict(self.failure_kinds.most_common()),
            "failed": self.failed,
            "world_seeds": sorted(self.world_seeds),
            "seconds": round(self.seconds, 2),
        }


@dataclass(frozen=True)
class GenerateConfig:
    """One generation run."""

    out: Path
    splits: tuple[Split, ...]
    n: int  # indices per split; failures are skipped, not replaced
    tasks: tuple[str, ...] = BENCHMARK_TASKS
    seed_start: int = 0
    build: BuildConfig = field(default_factory=BuildConfig)


def game_source(split: Split, index: int, tasks: Sequence[str]) -> GameSource:
    """The world and task of the split's ``index``-th game (raises TaskSamplingError if none is feasible)."""
    task_name = tasks[index % len(tasks)]
    sampled = sample_task_world(task_name, world_seed(split, index), task_seed(split, index))
    return GameSource(split, index, sampled.world, sampled.task, sampled.world_seed, sampled.task_seed)


def generate_one(
    split: Split, index: int, config: GenerateConfig, bank: PhraseBank, ontology: Ontology
) -> tuple[GameSource, BuiltGame]:
    """Sample, solve and build one game (raises TaskSamplingError or BuildError when it cannot be made)."""
    source = game_source(split, index, config.tasks)
    expert = ExpertConfig(camera=config.build.camera, look_step_deg=config.build.look_step_deg)
    trajectory = run_expert(source.world, source.task, expert, ontology)
    return source, build_game(source, trajectory, config.build, bank, ontology)


def write_game(out: Path, built: BuiltGame, instructions: TextIO) -> None:
    split = built.split
    write_json(out / "games" / split / f"{built.game_id}.game.json", built.game)
    for instance in built.edh:
        write_json(out / "edh_instances" / split / f"{instance['instance_id']}.json", instance)
    write_json(out / "tfd_instances" / split / f"{built.game_id}.tfd0.json", built.tfd)
    for name, jpeg in built.frames.items():
        path = out / "images" / split / built.game_id / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(jpeg)
    instructions.write(json.dumps(built.instruction) + "\n")


def generate(config: GenerateConfig, progress: bool = True) -> dict[str, SplitTally]:
    """Write every split's files under ``config.out`` and its manifest; returns the tallies."""
    bank, ontology = load_phrase_bank(), load_ontology()
    tallies: dict[str, SplitTally] = {}
    bar = tqdm(total=len(config.splits) * config.n, unit="game", desc="generate", disable=not progress)
    for split in config.splits:
        tally = tallies.setdefault(split, SplitTally())
        started = time.perf_counter()
        path = config.out / "alfred_instructions" / f"{split}.jsonl"
        path.parent.mkdir(parents=True, exist_ok=True)
        with path.open("w", encoding="utf-8") as instructions:
            for index in range(config.seed_start, config.seed_start + config.n):
                tally.requested += 1
                task_name = config.tasks[index % len(config.tasks)]
                try:
                    source, built = generate_one(split, index, config, bank, ontology)
                except (TaskSamplingError, BuildError) as error:
                    kind = error.kind if isinstance(error, BuildError) else "no feasible world"
                    tally.failure_kinds[f"{task_name}: {kind}"] += 1
                    tally.failed.append({"index": index, "task": task_name, "reason": str(error)[:300]})
                else:
                    write_game(config.out, built, instructions)
                    tally.games += 1
                    tally.edh_instances += len(built.edh)
                    tally.tfd_instances += 1
                    tally.per_task[task_name] += 1
                    tally.world_seeds.add(source.world_seed)
                bar.update(1)
                bar.set_postfix(split=split, ok=tally.games, failed=len(tally.failed))
        tally.seconds = time.perf_counter() - started
    bar.close()
    write_json(config.out / "manifest.json", _manifest(config, tallies))
    return tallies


def _manifest(config: GenerateConfig, tallies: dict[str, SplitTally]) -> dict[str, Any]:
    return {
        "generator": "python -m harness generate",
        "versions": {"harness": importlib.metadata.version(DISTRIBUTION), "teach_game_format": GAME_VERSION},
        "arguments": {
            "splits": list(config.splits),
            "n": config.n,
            "seed_start": config.seed_start,
            "tasks": list(config.tasks),
            "edh_per_game": config.build.edh_per_game,
            "images": config.build.images,
        },
        "camera": camera_dict(config.build.camera, config.build.look_step_deg),
        "splits": {split: tally.as_json() for split, tally in tallies.items()},
    }


def _parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="python -m harness generate",
        description="Write TEACh-format games, EDH and TfD instances and ALFRED-style instructions.",
    )
    parser.add_argument("--out-dir", type=Path, required=True, help="output folder (created if missing)")
    parser.add_argument("--split", choices=[*SPLITS, "all"], default="all", help="which split(s) to write")
    parser.add_argument("--n", type=int_at_least(1), required=True, help="games to attempt per split")
    parser.add_argument(
        "--task",
        action="append",
        choices=BENCHMARK_TASKS,
        help="a TEACh task to generate (repeat for several; index i -> task i %% count; default: all 12)",
    )
    parser.add_argument("--first-index", type=int_at_least(0), default=0, help="first index of each split")
    parser.add_argument("--images", action="store_true", help="also write the driver's JPEG frames")
    parser.add_argument(
        "--camera",
        type=int_at_least(32),
        default=TEACH_IMAGE_SIDE,
        help="square camera side in pixels (TEACh: 900)",
    )
    parser.add_argument(
        "--edh-per-game",
        type=int_at_least(1),
        default=BuildConfig.edh_per_game,
        help="EDH instances per game at most",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    tasks = tuple(args.task or BENCHMARK_TASKS)
    build = BuildConfig(
        camera=CameraSpec(args.camera, args.camera, TEACH_HFOV_DEG),
        look_step_deg=TEACH_LOOK_STEP_DEG,
        edh_per_game=args.edh_per_game,
        images=args.images,
    )
    splits = SPLITS if args.split == "all" else (cast(Split, args.split),)
    config = GenerateConfig(args.out_dir, splits, args.n, tasks, args.first_index, build)
    tallies = generate(config)
    for split, tally in tallies.items():
        tqdm.write(
            f"{split}: {tally.games}/{tally.requested} games, {tally.edh_instances} EDH, "
            f"{tally.tfd_instances} TfD in {tally.seconds:.1f} s; "
            f"failures: {dict(tally.failure_kinds) or 'none'}"
        )
    tqdm.write(f"wrote {config.out} (manifest.json)")
    return 0
