"""The JARVIS seed's Table 4 on one commit: expert or language-model subgoals x oracle or learned perception.

The seed ablates its own parts on TEACh's EDH and TfD validation sets: JARVIS whole (learned subgoals,
learned perception), "Executor (w/ gt subgoals)" (learned perception) and "Reasoning (w/ gt subgoals &
visual)" (true perception as well); its "Language (w/ gt executor)" row teleports to the targets, which no
cell here does, so our fourth cell (model subgoals, oracle perception) has no seed row beside it. Each cell
is one ``python -m harness eval`` run on the same generated valid_unseen slots (episode i is game i, task
i % 12; EDH slots cut at edh0 or edh1), through a real service subprocess over HTTP at 300x300 with TEACh's
90° camera:

- ``expert+oracle``: the expert's subgoals, true depth and instance segmentation;
- ``expert+learned``: the expert's subgoals, the learned depth and segmentation networks from RGB only;
- ``model+oracle``: the language planner's subgoals (default checkpoint, symbolic repair, re-plans), true
  perception;
- ``model+learned``: the whole JARVIS configuration.

Run: ``.venv/bin/python -m bench.table4 [--benchmark tfd|edh] [--n 100] [--cells ...] [--workers 2]``;
writes ``bench/results/table4_<benchmark>.json`` with SR, GC and their trajectory-length weighted forms per
cell, each cell's per-task SR, and the seed's rows. Every cell resumes from its run folder
(``runs/bench/table4_<benchmark>/<cell>``) when the same commit started it, so a long run can be stopped and
started again, and a cell run earlier by this commit costs nothing. The learned cells take hours on two
cores (each learned step runs both networks; failed games run to the step limit).
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, cast

from bench.cli import add_episode_options, bench_parser
from bench.edh import metric_row
from bench.planner_tfd import checkpoint_summary
from bench.stamp import BenchRun, results_path, runs_for_commit
from harness.drive.evaluate import EvalConfig, evaluate
from harness.drive.runner import DEFAULT_CAMERA
from harness.drive.service import ServiceUnreachable, service_url
from harness.world.splits import Split
from symbolic.cli_args import Parser, fail

SPLIT: Split = "valid_unseen"
Benchmark = Literal["tfd", "edh"]
CELLS: dict[str, tuple[Literal["oracle", "model"], Literal["oracle", "learned"]]] = {
    "expert+oracle": ("oracle", "oracle"),
    "expert+learned": ("oracle", "learned"),
    "model+oracle": ("model", "oracle"),
    "model+learned": ("model", "learned"),
}
"""Cell -> (the service's planner, its perception); the "oracle" planner follows the expert's subgoals."""

# The JARVIS seed (../shared/seeds/002_8e70e6116768ed12.txt), Table 4, "Ablation studies on the EDH and TfD
# validation sets", Unseen columns in percent: SR [TLW], GC [TLW]. The cell each row corresponds to.
SEED_TABLE_4_UNSEEN: dict[Benchmark, dict[str, tuple[str, tuple[float, float, float, float]]]] = {
    "edh": {
        "model+learned": ("JARVIS", (15.8, 2.6, 16.6, 8.2)),
        "expert+learned": ("Executor (w/ gt subgoals)", (30.5, 8.5, 27.3, 12.1)),
        "expert+oracle": ("Reasoning (w/ gt subgoals & visual)", (60.9, 26.2, 63.6, 35.4)),
    },
    "tfd": {
        "model+learned": ("JARVIS", (1.8, 0.3, 3.1, 1.6)),
        "expert+learned": ("Executor (w/ gt subgoals)", (1.8, 0.2, 4.0, 0.9)),
        "expert+oracle": ("Reasoning (w/ gt subgoals & visual)", (12.6, 4.2, 20.7, 14.6)),
    },
}
COMPARABILITY = (
    "ours: generated valid_unseen games of our own simulator (generated dialogue, 300x300 frames); the seed: "
    "TEACh's validation instances in AI2-THOR with human dialogue. Same metric definitions, different "
    "episodes: compare the cells with each other, and the seed's rows as the shape of the same ablation."
)


def cell_config(benchmark: Benchmark, n: int, cell: str) -> EvalConfig:
    planner, perception = CELLS[cell]
    return EvalConfig(
        benchmark=benchmark,
        split=SPLIT,
        n=n,
        camera_side=DEFAULT_CAMERA.width,
        hfov_deg=DEFAULT_CAMERA.hfov_deg,
        planner=planner,
        perception=perception,
    )


def cell_summary(result: Mapping[str, Any]) -> dict[str, Any]:
    """One cell's overall metrics (``bench.edh.metric_row``), its per-task SR and how failed games ended."""
    metrics = result["metrics"]
    if metrics is None:
        raise ValueError("no episode ran: every slot was unavailable")
    return metric_row(metrics) | {
        "per_task_sr": {
            task: group["success"]["success_rate"] for task, group in metrics["per_task"].items()
        },
        "episode_failures": result["episode_failures"].get("overall", {}),
        "unavailable": result["unavailable"],
    }


def table(benchmark: Benchmark, cells: Mapping[str, Mapping[str, Any]]) -> str:
    """Our cells in percent, SR [TLW] and GC [TLW], each beside the seed's Unseen row it corresponds to."""
    seed = SEED_TABLE_4_UNSEEN[benchmark]
    lines = [f"{'cell':<16}{'SR [TLW]':<15}{'GC [TLW]':<15}seed Unseen SR [TLW], GC [TLW]"]
    for name, row in cells.items():
        ours = (
            f"{100 * row['sr']:.1f} [{100 * row['tlw_sr']:.1f}]",
            f"{100 * row['gc']:.1f} [{100 * row['tlw_gc']:.1f}]",
        )
        theirs = ""
        if name in seed:
            label, (sr, tlw_sr, gc, tlw_gc) = seed[name]
            theirs = f"{sr:.1f} [{tlw_sr:.1f}], {gc:.1f} [{tlw_gc:.1f}]  {label}"
        lines.append(f"{name:<16}{ours[0]:<15}{ours[1]:<15}{theirs}".rstrip())
    return "\n".join(lines)


def _parser() -> Parser:
    parser = bench_parser("table4", __doc__, out=False)
    parser.add_argument("--benchmark", choices=("tfd", "edh"), default="tfd")
    add_episode_options(
        parser,
        n=100,
        n_help="episodes (slot i is task i %% 12)",
        run_dir=None,
        run_dir_help="run folders' parent (default: runs/bench/table4_<benchmark>)",
    )
    parser.add_argument(
        "--cells", nargs="+", choices=tuple(CELLS), default=list(CELLS), help="the cells to run and report"
    )
    parser.add_argument(
        "--out", type=Path, help="results file (default: bench/results/table4_<benchmark>.json)"
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    benchmark = cast(Benchmark, args.benchmark)
    out = args.out or results_path(f"table4_{benchmark}")
    run_dir = args.run_dir or Path("runs/bench") / f"table4_{benchmark}"
    run = BenchRun.start("table4", argv)
    cells: dict[str, dict[str, Any]] = {}
    try:
        with service_url(args.url, None, start=args.url is None) as url:
            for cell in args.cells:
                print(f"{cell}: {benchmark} on {args.n} {SPLIT} slots")
                folder = runs_for_commit(run_dir / cell.replace("+", "_"), run.commit)
                cells[cell] = cell_summary(
                    evaluate(cell_config(benchmark, args.n, cell), folder, url, args.workers)
                )
    except ServiceUnreachable as error:
        fail("python -m bench.table4", str(error))
    report: dict[str, Any] = {
        "benchmark": benchmark,
        "split": SPLIT,
        "n": args.n,
        "camera": {"width": DEFAULT_CAMERA.width, "height": DEFAULT_CAMERA.height, "hfov_deg": 90.0},
        "cells": {
            name: {"planner": CELLS[name][0], "perception": CELLS[name][1]} | row
            for name, row in cells.items()
        },
        "planner_checkpoint": checkpoint_summary(),
        "seed_table_4_unseen_percent": {
            cell: {"row": label, "sr": sr, "tlw_sr": tlw_sr, "gc": gc, "tlw_gc": tlw_gc}
            for cell, (label, (sr, tlw_sr, gc, tlw_gc)) in SEED_TABLE_4_UNSEEN[benchmark].items()
        },
        "seed_source": "JARVIS seed (../shared/seeds/002_8e70e6116768ed12.txt), Table 4, Unseen columns",
        "comparability": COMPARABILITY,
    }
    run.write(out, report)
    print(table(benchmark, cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
