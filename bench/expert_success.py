"""Expert success per task: TEACh's 12 benchmark tasks on generated worlds, ALFRED valid_seen when present.

For each TEACh task, ``--seeds`` (world, task) pairs sampled as the episode generator samples them; for
ALFRED, the valid_seen trajectories' worlds and tasks (all 251 unless ``--alfred-limit``). Prints one line
per task (success rate against the 95 % bar, the commonest failure, mean length and time) and writes
everything, failure histograms and every episode, to ``bench/results/expert_success.json``.

Run: ``.venv/bin/python -m bench.expert_success [--seeds 25] [--tasks "Coffee" ...] [--no-alfred]``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from harness.expert.report import SUCCESS_BAR, EpisodeResult, run_expert_report
from harness.tasks.teach import BENCHMARK_TASKS

RESULTS = Path(__file__).resolve().parent / "results" / "expert_success.json"


def _show(result: EpisodeResult) -> None:
    status = "ok  " if result.success else "FAIL"
    detail = "" if result.success else f"  {result.failure}"
    print(
        f"{status} {result.suite:6s} {result.task:28s} {result.source:12s} {result.actions:4d} actions "
        f"{result.seconds:6.2f} s{detail}",
        flush=True,
    )


def _table(title: str, tasks: dict[str, dict[str, object]]) -> None:
    print(f"\n{title}")
    for name, row in tasks.items():
        reasons = row["failure_reasons"]
        worst = next(iter(reasons), "") if isinstance(reasons, dict) else ""
        mark = "  " if row["meets_bar"] else "<<"
        rate = 100 * float(str(row["success_rate"]))
        print(
            f"{mark} {name:34s} {row['solved']:3d}/{row['episodes']:<3d} {rate:5.1f} %"
            f"  {row['mean_actions']} actions  {row['mean_seconds']} s  {worst}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=25, help="episodes per TEACh task (default 25)")
    parser.add_argument("--tasks", nargs="*", default=list(BENCHMARK_TASKS), help="TEACh tasks to run")
    parser.add_argument("--alfred-limit", type=int, default=None, help="ALFRED trajectories (default: all)")
    parser.add_argument("--no-alfred", action="store_true", help="skip ALFRED valid_seen")
    parser.add_argument("--quiet", action="store_true", help="no line per episode")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    unknown = [t for t in args.tasks if t not in BENCHMARK_TASKS]
    if unknown:
        parser.error(f"unknown task(s) {unknown}; known: {list(BENCHMARK_TASKS)}")
    started = time.perf_counter()
    report = run_expert_report(
        seeds=args.seeds,
        tasks=args.tasks,
        alfred_limit=args.alfred_limit,
        with_alfred=not args.no_alfred,
        out=args.out,
        progress=None if args.quiet else _show,
    )
    _table(f"TEACh, {args.seeds} seeds per task (bar {100 * SUCCESS_BAR:.0f} %)", report["teach"]["tasks"])
    if "tasks" in report["alfred"]:
        _table(
            f"ALFRED valid_seen: {report['alfred']['success_rate']} over {report['alfred']['trajectories']}",
            report["alfred"]["tasks"],
        )
    else:
        print(f"\nALFRED: {report['alfred']['skipped']}")
    print(f"\nwrote {args.out} after {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
