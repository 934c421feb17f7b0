"""``python -m harness expert``: the expert's success rate per task, with failure reasons (issue 3 §5).

``python -m harness expert [--n 25] [--task Coffee ...] [--alfred-limit N] [--no-alfred] [--quiet]
[--out FILE]`` runs ``harness.expert.report.run_expert_report``, prints a line per episode and a table per
suite, and exits 0 only when the bar is met: 95 % of each TEACh task's episodes, and of ALFRED valid_seen
as a whole. ``bench.expert_success`` is the same command writing ``bench/results/expert_success.json``.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from harness.expert.report import SUCCESS_BAR, EpisodeResult, run_expert_report
from harness.tasks.teach import BENCHMARK_TASKS
from symbolic.cli_args import Parser, int_at_least


def _show(result: EpisodeResult) -> None:
    status = "ok  " if result.success else "FAIL"
    detail = "" if result.success else f"  {result.failure}"
    print(
        f"{status} {result.suite:6s} {result.task:28s} {result.source:12s} {result.actions:4d} actions "
        f"{result.seconds:6.2f} s{detail}",
        flush=True,
    )


def _table(title: str, tasks: dict[str, dict[str, Any]]) -> None:
    print(f"\n{title}")
    for name, row in tasks.items():
        worst = next(iter(row["failure_reasons"]), "")
        mark = "  " if row["meets_bar"] else "<<"
        print(
            f"{mark} {name:34s} {row['solved']:3d}/{row['episodes']:<3d} {100 * row['success_rate']:5.1f} %"
            f"  {row['mean_actions']} actions  {row['mean_seconds']} s  {worst}"
        )


def main(argv: Sequence[str] | None = None, default_out: Path | None = None) -> int:
    """The expert's success rate per task with failure reasons; 0 when the bar is met, else 1."""
    parser = Parser(
        prog="python -m harness expert", description="The expert's success rate per task (issue 3 §5)."
    )
    parser.add_argument("--n", type=int_at_least(0), default=25, help="episodes (seeds) per TEACh task")
    parser.add_argument(
        "--task",
        action="append",
        choices=BENCHMARK_TASKS,
        help="a TEACh task to run (repeat for several; default: all 12)",
    )
    parser.add_argument(
        "--alfred-limit", type=int_at_least(0), default=None, help="ALFRED trajectories (default: all)"
    )
    parser.add_argument("--no-alfred", action="store_true", help="skip ALFRED valid_seen")
    parser.add_argument("--quiet", action="store_true", help="no line per episode")
    parser.add_argument("--out", type=Path, default=default_out, help="write the JSON report here")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    report = run_expert_report(
        seeds=args.n,
        tasks=args.task or list(BENCHMARK_TASKS),
        alfred_limit=args.alfred_limit,
        with_alfred=not args.no_alfred,
        out=args.out,
        progress=None if args.quiet else _show,
    )
    teach = report["teach"]["tasks"]
    _table(f"TEACh, {args.n} seeds per task (bar {100 * SUCCESS_BAR:.0f} %)", teach)
    if "tasks" in report["alfred"]:
        _table(
            f"ALFRED valid_seen: {report['alfred']['success_rate']} over {report['alfred']['trajectories']}",
            report["alfred"]["tasks"],
        )
    else:
        print(f"\nALFRED: {report['alfred']['skipped']}")
    wrote = f"wrote {args.out} " if args.out is not None else ""
    print(f"\n{wrote}after {time.perf_counter() - started:.0f} s")
    alfred_ok = report["alfred"].get("meets_bar", True)
    return 0 if alfred_ok and all(row["meets_bar"] for row in teach.values()) else 1
