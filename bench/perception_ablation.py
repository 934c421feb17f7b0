"""The JARVIS seed's perception ablation: SR with oracle / learned depth / learned segmentation / both.

The issue's bar: on 100 generated valid_unseen TfD episodes with oracle subgoals, SR with learned perception
(``learned``: RGB only) is at least half the SR with oracle perception. Every episode runs through a real
service subprocess over HTTP (``harness.drive.runner``), at 300x300 with TEACh's 90° camera, once per setting.
Episode i is the generator's valid_unseen game i (task i % 12); games the generator cannot make are skipped
and listed.

- ``oracle``: the service's oracle back-end (true depth and instance segmentation with every frame).
- ``learned``: the service's learned back-end (``agent/perception/learned.py``), RGB only.
- ``learned_depth`` / ``learned_segmentation``: one half learned, the other true. The harness runner drives
  only the service's ``oracle`` and ``learned`` back-ends, so these run the same networks
  (``LearnedPerception``) in the bench process and send their output through the oracle channels: the
  expected depth with the width of its 90% interval as ``depth_uncertainty`` (the service then applies HLSM
  eq. (5) with the current target's looser threshold and judges reach on the interval's far end, as its
  learned back-end does), or learned classes split into instances at the true depth's discontinuities with
  their legend, marked ``segmentation_ids_persistent: false`` (numbered afresh each frame, as the learned
  back-end's are). The service's clicks still hit whatever object is under the pixel.

Run: ``.venv/bin/python -m bench.perception_ablation [--n 100] [--workers 2]``; ``--settings A B
--keep-other-settings`` measures some settings now and keeps the others the file holds for the same
episodes when the same committed code measured them (a file never mixes code versions). Writes
``bench/results/perception_ablation.json`` (24 games, all four settings); the 100-game grid with the
language planner's cells as well is ``bench/table4.py``. ``--task NAME --out FILE`` runs only that task's
episodes among the ``--n`` (to re-run one task after a change aimed at it).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Literal

import numpy as np
from tqdm import tqdm

from agent.geometry import Camera
from agent.perception.learned import LearnedConfig, LearnedPerception
from bench.cli import bench_parser
from bench.stamp import BenchRun, results_path
from harness.drive.client import AgentClient, ServiceError
from harness.drive.generated import EpisodeUnavailable, generated_tfd_episode
from harness.drive.metrics import EpisodeOutcome, aggregate
from harness.drive.runner import DEFAULT_CAMERA, Perception, RunnerOptions, episode_task_name, run_episode
from harness.drive.service import running_service
from harness.render.renderer import Frame
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import Split
from symbolic.cli_args import http_url

RESULTS = results_path("perception_ablation")
SPLIT: Split = "valid_unseen"
SETTINGS: tuple[str, ...] = ("oracle", "learned_depth", "learned_segmentation", "learned")
SR_RATIO_MIN = 0.5  # the issue: learned SR >= 50% of oracle SR
CLIENT_TIMEOUT_S = 300.0
Half = Literal["depth", "segmentation"]


class HalfLearnedClient(AgentClient):
    """An AgentClient that replaces one oracle channel of every frame with the learned networks' output."""

    def __init__(self, base_url: str, timeout: float, half: Half) -> None:
        super().__init__(base_url, timeout=timeout)
        camera = Camera(DEFAULT_CAMERA.width, DEFAULT_CAMERA.height, DEFAULT_CAMERA.hfov_deg)
        self.half = half
        self.perception = LearnedPerception(camera, LearnedConfig())

    def step(self, session_id: str, frame: Frame, **options: Any) -> dict[str, Any]:
        """The base client's step (same options) with the frame's one half replaced."""
        rgb = frame.rgb
        assert rgb is not None, "the runner renders rgb for every setting"
        if self.half == "depth":
            depth, width90 = self.perception.estimate_depth(rgb)
            frame = dataclasses.replace(frame, depth=depth, depth_uncertainty=width90)
        else:
            seen = self.perception.estimate_classes(rgb, frame.depth, None)
            legend = {
                i: name for i, name in seen.instance_types.items() if name in self.perception.classes.types
            }
            frame = dataclasses.replace(
                frame, instances=seen.instances.astype(np.int32), legend=legend, instance_ids_persistent=False
            )
        return super().step(session_id, frame, **options)


def run_one(setting: str, index: int, base_url: str) -> dict[str, Any]:
    """One episode of one setting (in a worker process): its outcome row, or the service's refusal."""
    import torch

    torch.set_num_threads(1)
    episode = generated_tfd_episode(SPLIT, index, DEFAULT_CAMERA)
    service_perception: Perception = "learned" if setting == "learned" else "oracle"
    options = RunnerOptions(camera=DEFAULT_CAMERA, perception=service_perception)
    client: AgentClient
    if setting in ("learned_depth", "learned_segmentation"):
        half: Half = "depth" if setting == "learned_depth" else "segmentation"
        client = HalfLearnedClient(base_url, CLIENT_TIMEOUT_S, half)
    else:
        client = AgentClient(base_url, timeout=CLIENT_TIMEOUT_S)
    started = time.perf_counter()
    with client:
        try:
            run = run_episode(episode, client, options)
        except ServiceError as error:
            return {"index": index, "refused": str(error)}
    return {
        "index": index,
        "outcome": run.outcome,
        "instance_id": run.outcome.instance_id,
        "task": run.outcome.task_name,
        "success": run.outcome.success,
        "steps": run.outcome.steps,
        "end_reason": run.end_reason,
        "failure": run.failure,
        "wall_s": round(time.perf_counter() - started, 1),
    }


def run_setting(setting: str, indices: Sequence[int], base_url: str, workers: int) -> dict[str, Any]:
    """SR, GC and failure reasons of one perception setting over the episodes (or the service's refusal)."""
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        rows = list(
            tqdm(
                pool.map(run_one, [setting] * len(indices), indices, [base_url] * len(indices)),
                total=len(indices),
                desc=setting,
                unit="episode",
            )
        )
    refused = [row for row in rows if "refused" in row]
    if refused:
        return {"refused": refused[0]["refused"]}
    outcomes: list[EpisodeOutcome] = [row.pop("outcome") for row in rows]
    metrics = aggregate(outcomes)
    return {
        "success_rate": metrics["success"]["success_rate"],
        "goal_condition_success_rate": metrics["goal_condition_success"]["goal_condition_success_rate"],
        "path_length_weighted_success_rate": metrics["path_length_weighted_success_rate"],
        "failure_histogram": metrics["failure_histogram"],
        "wall_s": round(time.perf_counter() - started, 1),
        "episodes": rows,
    }


def earlier_settings(path: Path, indices: Sequence[int], commit: str) -> dict[str, Any]:
    """The settings a previous run wrote to ``path`` over the same episodes with ``commit``'s code, committed
    (empty if there is no such file, or it holds other episodes, another commit or uncommitted code)."""
    if not path.is_file():
        return {}
    earlier = json.loads(path.read_text())
    stamp = earlier.get("stamp", {})
    rows = earlier.get("settings", {})
    same = all([e["index"] for e in row.get("episodes", [])] == list(indices) for row in rows.values())
    same_code = stamp.get("commit") == commit and stamp.get("dirty") is False
    return dict(rows) if earlier.get("split") == SPLIT and same and same_code else {}


def episode_indices(n: int, task: str | None = None) -> tuple[list[int], list[int]]:
    """The slots among the first ``n`` whose episode the generator makes (of ``task`` only, if given), and
    the slots it cannot make."""
    indices, skipped = [], []
    for index in range(n):
        try:
            episode = generated_tfd_episode(SPLIT, index, DEFAULT_CAMERA)
        except EpisodeUnavailable:
            skipped.append(index)
            continue
        if task is None or episode_task_name(episode) == task:
            indices.append(index)
    return indices, skipped


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("perception_ablation", __doc__)
    parser.add_argument("--n", type=int, default=100, help="episodes (slot i is task i %% 12)")
    parser.add_argument("--settings", nargs="*", default=list(SETTINGS), choices=SETTINGS)
    parser.add_argument("--workers", type=int, default=2, help="episodes driven at once (2 cores)")
    parser.add_argument("--url", type=http_url, help="use a running service instead of starting one")
    parser.add_argument(
        "--keep-other-settings",
        action="store_true",
        help="keep the settings --out already holds for the same episodes (run the settings in turns)",
    )
    parser.add_argument(
        "--task",
        choices=BENCHMARK_TASKS,
        help="only the episodes of this task among the --n (with an --out of its own): to re-run one task",
    )
    args = parser.parse_args(argv)
    if args.task is not None and args.out == RESULTS:
        parser.error("--task writes a part of the episodes: give it an --out of its own")
    run = BenchRun.start("perception_ablation", argv)
    indices, skipped = episode_indices(args.n, args.task)
    results: dict[str, Any] = {}
    if args.url is not None:
        results = {s: run_setting(s, indices, args.url, args.workers) for s in args.settings}
    else:
        with running_service() as service:
            results = {s: run_setting(s, indices, service.base_url, args.workers) for s in args.settings}
    if args.keep_other_settings:
        results = {**earlier_settings(args.out, indices, run.commit), **results}
        results = {s: results[s] for s in SETTINGS if s in results}
    report: dict[str, Any] = {
        "split": SPLIT,
        "camera": [DEFAULT_CAMERA.width, DEFAULT_CAMERA.height, DEFAULT_CAMERA.hfov_deg],
        "planner": "oracle (expert subgoals)",
        "episodes": len(indices),
        "task": args.task or "all",
        "skipped_indices": skipped,
        "workers": args.workers,
        "half_settings_run_in": "bench process, sent through the oracle channels (module docstring)",
        "settings": results,
    }
    oracle, learned = results.get("oracle", {}), results.get("learned", {})
    if "success_rate" in oracle and "success_rate" in learned:
        ratio = learned["success_rate"] / oracle["success_rate"] if oracle["success_rate"] else None
        report["bar"] = {
            "learned_over_oracle_sr": ratio,
            "min": SR_RATIO_MIN,
            "met": ratio is not None and ratio >= SR_RATIO_MIN,
        }
    return run.finish(args.out, report, table(results))


def table(results: dict[str, Any]) -> list[str]:
    """The lines printed at the end: SR, GC and TLW-SR of each setting (or why it was refused)."""
    lines = [f"{'setting':<22}{'SR':>8}{'GC':>8}{'TLW-SR':>8}"]
    for name, row in results.items():
        if "refused" in row:
            lines.append(f"{name:<22} refused: {row['refused']}")
        else:
            lines.append(
                f"{name:<22}{row['success_rate']:>8.3f}{row['goal_condition_success_rate']:>8.3f}"
                f"{row['path_length_weighted_success_rate']:>8.3f}"
            )
    return lines


if __name__ == "__main__":
    raise SystemExit(main())
