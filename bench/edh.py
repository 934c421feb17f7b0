"""The EDH benchmark (TEACh's first): SR, GC and their length-weighted forms beside the JARVIS seed's Table 1.

Our numbers are printed and written in the seed's Table 1 layout, under the seed's own rows.

Each slot is one ``python -m harness eval --benchmark edh`` episode: the generated valid_unseen game i
(task i % 12, as the other benches), cut at edh0 or edh1 (alternating over the task cycles), its history
replayed into the session, then the agent predicts the rest. The planner is the service's default language
planner (``model``: the default checkpoint, re-planning and symbolic repair as in ``bench.planner_tfd``);
perception is oracle by default, ``--perception learned`` runs the depth and segmentation networks instead
(much slower). The metrics are TEACh's (``harness.drive.metrics``: ``evaluate_traj`` per instance,
``aggregate_metrics`` over the split), computed by ``harness.drive.evaluate`` from the run folder's episode
files.

Our episodes are worlds of our own simulator with generated dialogues, not TEACh's AI2-THOR games with human
dialogue, so the seed's numbers sit beside ours for the layout and scale, not as a like-for-like comparison.

Run: ``.venv/bin/python -m bench.edh [--n 100] [--workers 2] [--perception oracle|learned]``; writes
``bench/results/edh.json`` (learned: ``edh_learned.json``). The run folder (``--run-dir``, default
``runs/bench/edh_<perception>``) resumes when started again by the same commit.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, cast

from bench.cli import add_episode_options, bench_parser
from bench.planner_tfd import checkpoint_summary
from bench.stamp import BenchRun, results_path, runs_for_commit
from harness.drive.evaluate import EvalConfig, evaluate
from harness.drive.runner import DEFAULT_CAMERA
from harness.drive.service import ServiceUnreachable, service_url
from harness.tasks.teach_definitions import BENCHMARK_TASKS
from harness.world.splits import Split
from symbolic.cli_args import Parser, fail

Perception = Literal["oracle", "learned"]
SPLIT: Split = "valid_unseen"

# The JARVIS seed (../shared/seeds/002_8e70e6116768ed12.txt), Table 1, EDH columns: "Results in percentages on
# the EDH and TfD validation sets, where trajectory length weighted (TLW) metrics are included in [brackets]".
# Each row as the table prints it, in percent: Seen SR [TLW], GC [TLW], Unseen SR [TLW], GC [TLW].
_SEED_TABLE_1_EDH_ROWS: dict[str, tuple[float, ...]] = {
    "E.T. (Padmakumar et al., 2021)": (8.4, 0.8, 14.9, 3.0, 6.1, 0.9, 6.4, 1.1),
    "JARVIS (Ours)": (15.1, 3.3, 22.6, 8.7, 15.8, 2.6, 16.6, 8.2),
    "E.T. (few-shot)": (6.1, 1.0, 4.7, 2.8, 6.0, 0.9, 4.8, 3.6),
    "JARVIS (Ours, few-shot)": (10.7, 1.5, 15.3, 5.3, 13.7, 1.7, 12.7, 5.4),
}
SEED_TABLE_1_EDH: dict[str, dict[str, dict[str, tuple[float, float]]]] = {
    name: {
        split: {"sr": (row[at], row[at + 1]), "gc": (row[at + 2], row[at + 3])}
        for split, at in (("seen", 0), ("unseen", 4))
    }
    for name, row in _SEED_TABLE_1_EDH_ROWS.items()
}
"""The rows by model, split ("seen", "unseen") and metric ("sr", "gc"): (value, TLW value), percent."""
# The same seed, Table 3, EDH row: "Success Rates of 12 different task categories in the validation set"
# (percent; its columns are TEACh's 12 tasks in BENCHMARK_TASKS order).
SEED_TABLE_3_EDH_SR: dict[str, float] = dict(
    zip(
        BENCHMARK_TASKS, (21.0, 21.3, 14.5, 15.2, 15.5, 12.8, 22.1, 19.6, 15.8, 15.5, 10.3, 14.0), strict=True
    )
)
COMPARABILITY = (
    "ours: generated valid_unseen EDH cuts of our own simulator's games (generated dialogue, 300x300 frames, "
    "model planner); the seed: TEACh's EDH validation instances in AI2-THOR (human dialogue, learned "
    "perception). Same metric definitions, different episodes: read the seed's rows as scale, not as a "
    "like-for-like comparison."
)


def edh_config(n: int, perception: Perception) -> EvalConfig:
    """The bench's evaluation: generated valid_unseen EDH slots, model planner, TEACh's camera at 300x300."""
    return EvalConfig(
        benchmark="edh",
        split=SPLIT,
        n=n,
        camera_side=DEFAULT_CAMERA.width,
        hfov_deg=DEFAULT_CAMERA.hfov_deg,
        planner="model",
        perception=perception,
    )


def metric_row(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """One group's SR, GC, TLW-SR and TLW-GC as fractions (``harness.drive.metrics`` summary fields).

    ``gc`` is TEACh's aggregate (completed over total goal conditions, summed over episodes), the number its
    evaluation reports; ``gc_mean_per_episode`` is the per-episode mean the JARVIS seed's text describes.
    """
    gc = metrics["goal_condition_success"]
    return {
        "n": metrics["n"],
        "sr": metrics["success"]["success_rate"],
        "gc": gc["goal_condition_success_rate"],
        "tlw_sr": metrics["path_length_weighted_success_rate"],
        "tlw_gc": metrics["path_length_weighted_goal_condition_success_rate"],
        "gc_mean_per_episode": gc["mean_goal_condition_success"],
        "successes": metrics["success"]["num_successes"],
        "completed_goal_conditions": gc["completed_goal_conditions"],
        "total_goal_conditions": gc["total_goal_conditions"],
        "mean_steps": metrics["mean_steps"],
    }


def edh_summary(result: Mapping[str, Any]) -> dict[str, Any]:
    """The numbers of ``harness.drive.evaluate``'s metrics file that the report keeps: overall and per task,
    each task beside the seed's Table 3 EDH success rate, and how failed episodes ended."""
    metrics = result["metrics"]
    if metrics is None:
        raise ValueError("no EDH episode ran: every slot was unavailable")
    return {
        "overall": metric_row(metrics),
        "per_task": {
            task: metric_row(group) | {"seed_table_3_edh_sr_percent": SEED_TABLE_3_EDH_SR.get(task)}
            for task, group in metrics["per_task"].items()
        },
        "episode_failures": result["episode_failures"].get("overall", {}),
        "failed_actions_percent": metrics["failure_histogram"],
        "num_fails_by_api_limit": metrics["num_fails_by_api_limit"],
        "num_fails_by_traj_len_limit": metrics["num_fails_by_traj_len_limit"],
        "num_fails_by_error": metrics["num_fails_by_error"],
        "unavailable": result["unavailable"],
    }


def _cell(value: float, tlw: float) -> str:
    return f"{value:.1f} [{tlw:.1f}]"


def seed_layout_table(overall: Mapping[str, Any], our_name: str) -> str:
    """The seed's Table 1 EDH columns (Seen, Unseen: SR [TLW], GC [TLW], percent), its rows and then ours;
    we run valid_unseen only, so our Seen cells are a dash."""
    width = max(len(our_name), *(len(name) for name in SEED_TABLE_1_EDH)) + 2
    lines = [
        f"{'':<{width}}{'EDH Seen':<28}{'EDH Unseen':<28}",
        f"{'Model':<{width}}{'SR [TLW]':<14}{'GC [TLW]':<14}{'SR [TLW]':<14}{'GC [TLW]':<14}",
    ]
    for name, splits in SEED_TABLE_1_EDH.items():
        cells = [_cell(*splits[split][metric]) for split in ("seen", "unseen") for metric in ("sr", "gc")]
        lines.append(f"{name:<{width}}" + "".join(f"{cell:<14}" for cell in cells))
    ours = [
        "-",
        "-",
        _cell(100 * overall["sr"], 100 * overall["tlw_sr"]),
        _cell(100 * overall["gc"], 100 * overall["tlw_gc"]),
    ]
    lines.append(f"{our_name:<{width}}" + "".join(f"{cell:<14}" for cell in ours))
    return "\n".join(line.rstrip() for line in lines)


def per_task_table(per_task: Mapping[str, Mapping[str, Any]]) -> str:
    """Per task, in TEACh's task order: n, SR [TLW], GC [TLW] in percent, and the seed's Table 3 EDH SR."""
    width = max(len(task) for task in BENCHMARK_TASKS) + 2
    lines = [f"{'task':<{width}}{'n':>4}  {'SR [TLW]':<14}{'GC [TLW]':<14}seed Table 3 SR"]
    for task in BENCHMARK_TASKS:
        if task not in per_task:
            continue
        row = per_task[task]
        lines.append(
            f"{task:<{width}}{row['n']:>4}  {_cell(100 * row['sr'], 100 * row['tlw_sr']):<14}"
            f"{_cell(100 * row['gc'], 100 * row['tlw_gc']):<14}{SEED_TABLE_3_EDH_SR[task]:.1f}"
        )
    return "\n".join(line.rstrip() for line in lines)


def _parser() -> Parser:
    parser = bench_parser("edh", __doc__, out=False)
    add_episode_options(
        parser,
        n=100,
        n_help="EDH instances (slot i is task i %% 12)",
        run_dir=None,
        run_dir_help="resumable run folder (default: runs/bench/edh_<perception>)",
    )
    parser.add_argument(
        "--perception",
        default="oracle",
        choices=("oracle", "learned"),
        help="learned: the depth and segmentation networks, from RGB (several times slower)",
    )
    parser.add_argument(
        "--out", type=Path, help="results file (default: bench/results/edh.json; learned: edh_learned.json)"
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    perception = cast(Perception, args.perception)
    out = args.out or results_path("edh" if perception == "oracle" else f"edh_{perception}")
    run_dir = args.run_dir or Path("runs/bench") / f"edh_{perception}"
    config = edh_config(args.n, perception)

    run = BenchRun.start("edh", argv)
    try:
        with service_url(args.url, None, start=args.url is None) as url:
            result = evaluate(config, runs_for_commit(run_dir, run.commit), url, args.workers)
    except ServiceUnreachable as error:
        fail("python -m bench.edh", str(error))
    summary = edh_summary(result)
    our_name = f"this service (model planner, {perception} perception)"
    report: dict[str, Any] = {
        "benchmark": "edh",
        "split": SPLIT,
        "episodes": f"generated {SPLIT} games cut at edh0/edh1 (alternating by task cycle), history replayed",
        "camera": {"width": DEFAULT_CAMERA.width, "height": DEFAULT_CAMERA.height, "hfov_deg": 90.0},
        "agent": {"perception": perception, "planner": "model (default checkpoint) + symbolic repair"},
        "planner_checkpoint": checkpoint_summary(),
        "workers": args.workers,
        "run_dir": str(run_dir),
        "table_1_edh_unseen_percent": {
            "ours": {
                key: round(100 * summary["overall"][key], 1) for key in ("sr", "tlw_sr", "gc", "tlw_gc")
            },
            "seed": {name: splits["unseen"] for name, splits in SEED_TABLE_1_EDH.items()},
        },
        "result": summary,
        "seed_table_1_edh_percent": SEED_TABLE_1_EDH,
        "seed_source": "JARVIS seed (../shared/seeds/002_8e70e6116768ed12.txt), Table 1 (EDH columns) and "
        "Table 3 (EDH row, per task SR)",
        "comparability": COMPARABILITY,
    }
    run.write(out, report)
    print(json.dumps(report["table_1_edh_unseen_percent"], indent=2))
    print(seed_layout_table(summary["overall"], our_name))
    print(per_task_table(summary["per_task"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
