"""How often the expert solves what the harness poses, and why it fails when it does not (issue 3 §5).

TEACh: for each of the 12 benchmark tasks, ``seeds`` (world, task) pairs drawn the way the episode
generator draws them (``harness.episodes.sample.sample_task_world``: parameters from the task's parameter
space, a room that can hold them, a generated world); success is TEACh's goal check. ALFRED: the
valid_seen trajectories' worlds and tasks (``harness.world.alfred``, needs the shared data directory);
success is ALFRED's goal check. The bar is 95 % per task. Results are grouped per task with a histogram of
failure reasons (object ids reduced to types), trajectory lengths and the expert's time.

``harness.expert.cli`` is its command line (``python -m harness expert``).
"""

from __future__ import annotations

import json
import statistics
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from harness.episodes.sample import TaskSamplingError, sample_task_world
from harness.expert.expert import ExpertConfig, ExpertTrajectory, run_expert
from harness.expert.recipes import Task
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.model import World
from symbolic.data_dir import default_data_dir
from symbolic.ontology import load_ontology

SUCCESS_BAR = 0.95
"""The issue's bar: the expert solves at least this share of each TEACh task's episodes, and of the ALFRED
valid_seen trajectories' tasks (all of them together; each task type's share is reported too)."""


@dataclass(frozen=True)
class EpisodeResult:
    """One expert run, as the report counts it."""

    suite: str
    """"teach" or "alfred"."""
    task: str
    """TEACh task name or ALFRED task type."""
    params: str
    source: str
    """Where the episode came from: the seed, or the ALFRED trajectory's task_id."""
    success: bool
    failure: str | None
    actions: int
    failed_actions: int
    plans: int
    seconds: float


def _result(
    suite: str, task_name: str, params: str, source: str, trajectory: ExpertTrajectory
) -> EpisodeResult:
    return EpisodeResult(
        suite=suite,
        task=task_name,
        params=params,
        source=source,
        success=trajectory.success,
        failure=trajectory.failure_reason,
        actions=len(trajectory.actions),
        failed_actions=sum(not a.success for a in trajectory.actions),
        plans=trajectory.plans,
        seconds=round(trajectory.seconds, 3),
    )


def teach_episodes(
    seeds: int, tasks: Sequence[str] = BENCHMARK_TASKS
) -> Iterator[tuple[str, str, World, Task]]:
    """(task name, source, world, task) for seeds 0..seeds-1 of every task, as the generator samples them."""
    for task_name in tasks:
        for seed in range(seeds):
            try:
                sampled = sample_task_world(task_name, world_seed=seed, task_seed=seed)
            except TaskSamplingError as error:
                raise RuntimeError(f"{task_name} seed {seed}: {error}") from error
            yield task_name, f"seed {seed}", sampled.world, sampled.task


def alfred_episodes(
    split: str = "valid_seen", limit: int | None = None
) -> Iterator[tuple[str, str, World, Task]]:
    """(task type, task_id, world, task) of an ALFRED split (needs the shared data directory)."""
    from harness.world.alfred.build import alfred_task_world_pairs

    for traj, world, task in alfred_task_world_pairs(split, limit):
        yield task.task_type, str(traj["task_id"]), world, task


def run_episodes(
    suite: str,
    episodes: Iterable[tuple[str, str, World, Task]],
    config: ExpertConfig,
    progress: Callable[[EpisodeResult], None] | None = None,
) -> list[EpisodeResult]:
    ontology = load_ontology()
    results = []
    for task_name, source, world, task in episodes:
        params = " ".join(task.params) if hasattr(task, "params") else task.describe()
        result = _result(suite, task_name, params, source, run_expert(world, task, config, ontology))
        results.append(result)
        if progress is not None:
            progress(result)
    return results


FAILURE_CATEGORIES: tuple[tuple[str, str], ...] = (
    ("in sight", "world: an object is out of sight or reach from every reachable pose"),
    ("cannot be seen from anywhere", "world: an object is out of sight or reach from every reachable pose"),
    ("does not boil", "task: the object cannot boil under the simulator's rules"),
    ("no room", "world: no receptacle has room"),
    ("no faucet", "world: a fixture the task needs is missing"),
    ("no sink", "world: a fixture the task needs is missing"),
)
"""Substrings of a failure reason and the category a histogram counts it under (first match wins)."""


def failure_category(reason: str) -> str:
    """Who is to blame, roughly: the world, the task, or the expert itself (its failure prefix)."""
    for pattern, category in FAILURE_CATEGORIES:
        if pattern in reason:
            return category
    return "expert: " + reason.split(":")[0]


def summarize(results: Sequence[EpisodeResult]) -> dict[str, Any]:
    """Per task: episodes, success rate, failure reasons (most common first), lengths and times."""
    by_task: dict[str, list[EpisodeResult]] = {}
    for result in results:
        by_task.setdefault(result.task, []).append(result)
    summary: dict[str, Any] = {}
    for task, runs in by_task.items():
        solved = [r for r in runs if r.success]
        failures = Counter(r.failure or "unknown" for r in runs if not r.success)
        summary[task] = {
            "episodes": len(runs),
            "solved": len(solved),
            "success_rate": round(len(solved) / len(runs), 4),
            "meets_bar": len(solved) / len(runs) >= SUCCESS_BAR,
            "failure_reasons": dict(failures.most_common()),
            "failure_categories": dict(
                Counter((r.failure or "unknown").split(":")[0] for r in runs if not r.success)
            ),
            "mean_actions": round(statistics.fmean(r.actions for r in solved), 1) if solved else None,
            "failed_actions_per_episode": round(statistics.fmean(r.failed_actions for r in runs), 3),
            "mean_seconds": round(statistics.fmean(r.seconds for r in runs), 3),
            "median_seconds": round(statistics.median(r.seconds for r in runs), 3),
            "max_seconds": round(max(r.seconds for r in runs), 3),
        }
    return summary


def run_expert_report(
    seeds: int = 25,
    tasks: Sequence[str] = BENCHMARK_TASKS,
    alfred_limit: int | None = None,
    with_alfred: bool = True,
    out: Path | None = None,
    progress: Callable[[EpisodeResult], None] | None = None,
) -> dict[str, Any]:
    """Run the expert on ``seeds`` episodes of each TEACh task and (when the data directory is present and
    ``with_alfred``) on ALFRED valid_seen (``alfred_limit`` trajectories, all if None); write JSON to ``out``.
    """
    teach = run_episodes("teach", teach_episodes(seeds, tasks), ExpertConfig(), progress)
    report: dict[str, Any] = {
        "bar": SUCCESS_BAR,
        "teach": {"seeds": seeds, "tasks": summarize(teach)},
        "episodes": [asdict(r) for r in teach],
    }
    if with_alfred and (default_data_dir() / "alfred").is_dir():
        alfred = run_episodes(
            "alfred", alfred_episodes("valid_seen", alfred_limit), ExpertConfig.alfred(), progress
        )
        rate = sum(r.success for r in alfred) / len(alfred) if alfred else None
        report["alfred"] = {
            "split": "valid_seen",
            "trajectories": len(alfred),
            "success_rate": round(rate, 4) if rate is not None else None,
            "meets_bar": rate is not None and rate >= SUCCESS_BAR,
            "tasks": summarize(alfred),
        }
        report["episodes"] += [asdict(r) for r in alfred]
    else:
        report["alfred"] = {
            "skipped": f"no ALFRED data under {default_data_dir()}" if with_alfred else "not asked"
        }
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return report
