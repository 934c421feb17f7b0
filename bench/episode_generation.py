"""Episode generation speed: games (and EDH/TfD episodes) per second of `python -m harness generate`.

Generates N games of the train split (index i -> TEACh task i % 12, the generator's own rule) into a
temporary directory and times each stage of one game: sampling the world and task, the expert's
trajectory, building the files (replay, dialogue, EDH cuts), and writing them. Games whose expert fails
count in the time but not in the output, as in a real run. TEACh's 900x900 camera by default.

Run: ``.venv/bin/python -m bench.episode_generation [--n 24] [--camera 900]``; writes
``bench/results/episode_generation.json``.
"""

from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from bench.cli import bench_parser
from bench.stamp import BenchRun
from harness.episodes.build import BuildConfig, BuildError, build_game
from harness.episodes.generate import GenerateConfig, game_source, write_game
from harness.episodes.phrases import load_phrase_bank
from harness.episodes.sample import TaskSamplingError
from harness.expert.expert import ExpertConfig, run_expert
from harness.render.camera import CameraSpec
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import Split
from symbolic.ontology import load_ontology
from symbolic.thor import TEACH_HFOV_DEG, TEACH_IMAGE_SIDE

SPLIT: Split = "train"


def _median_ms(values: list[float]) -> float:
    return round(statistics.median(values) * 1000.0, 1) if values else 0.0


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("episode_generation", __doc__)
    parser.add_argument("--n", type=int, default=24, help="games to attempt (default 24: two per task)")
    parser.add_argument("--camera", type=int, default=TEACH_IMAGE_SIDE, help="square camera side, pixels")
    args = parser.parse_args(argv)
    run = BenchRun.start("episode_generation", argv)
    camera = CameraSpec(args.camera, args.camera, TEACH_HFOV_DEG)
    bank, ontology = load_phrase_bank(), load_ontology()
    stages: dict[str, list[float]] = {"sample": [], "expert": [], "build": [], "write": []}
    games = episodes = 0
    failures: dict[str, int] = {}
    with tempfile.TemporaryDirectory() as tmp, (Path(tmp) / "instructions.jsonl").open("w") as instructions:
        out = Path(tmp)
        config = GenerateConfig(out, (SPLIT,), args.n, BENCHMARK_TASKS, 0, BuildConfig(camera=camera))
        started = time.perf_counter()
        for index in range(args.n):
            task_name = BENCHMARK_TASKS[index % len(BENCHMARK_TASKS)]
            t0 = time.perf_counter()
            try:
                source = game_source(SPLIT, index, config.tasks)
                t1 = time.perf_counter()
                trajectory = run_expert(source.world, source.task, ExpertConfig(camera=camera), ontology)
                t2 = time.perf_counter()
                built = build_game(source, trajectory, config.build, bank, ontology)
            except (TaskSamplingError, BuildError) as error:
                kind = error.kind if isinstance(error, BuildError) else "no feasible world"
                failures[f"{task_name}: {kind}"] = failures.get(f"{task_name}: {kind}", 0) + 1
                continue
            t3 = time.perf_counter()
            write_game(out, built, instructions)
            t4 = time.perf_counter()
            for stage, seconds in zip(stages, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
                stages[stage].append(seconds)
            games += 1
            episodes += len(built.edh) + 1
        total = time.perf_counter() - started
    result = {
        "split": SPLIT,
        "camera": {"width": camera.width, "height": camera.height, "hfov_deg": camera.hfov_deg},
        "attempted": args.n,
        "games": games,
        "edh_and_tfd_episodes": episodes,
        "failures": failures,
        "seconds": round(total, 2),
        "games_per_second": round(games / total, 3) if total else 0.0,
        "episodes_per_second": round(episodes / total, 3) if total else 0.0,
        "median_ms_per_successful_game": {stage: _median_ms(values) for stage, values in stages.items()},
    }
    return run.finish(args.out, result, [json.dumps(result, indent=2)])


if __name__ == "__main__":
    sys.exit(main())
