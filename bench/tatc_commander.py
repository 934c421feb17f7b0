"""TATC success rate at the commander's three information levels (the JARVIS seed's Table 2), and what the
commander's instructions are worth by themselves.

The issue's bar: with full information, SR ≥ 70% on 100 generated valid_unseen episodes. Each level is a
``python -m harness eval --benchmark tatc`` run (``harness.drive.evaluate``: episode i is the generated game
i, task i % 12; the commander bot in the harness process, the follower a real service subprocess reached over
HTTP; frames at 300x300 with depth and segmentation, as ``harness eval`` defaults). The runs go to
``--run-dir DIR/<level>`` and resume when started again by the same commit. Beside them, the same commander
with a follower that carries out each instruction to the letter
(``harness.commander.episode.run_obedient_episode``) gives the upper bound the instructions allow: what the
follower loses is the difference.

Run: ``.venv/bin/python -m bench.tatc_commander [--n 100] [--n-other 24] [--workers 2]``; writes
``bench/results/tatc_commander.json``. It takes about an hour on the shared 2-core machine.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any, get_args

from tqdm import tqdm

from bench.cli import bench_parser
from bench.stamp import BenchRun, runs_for_commit
from harness.commander.bot import InfoLevel
from harness.commander.episode import run_obedient_episode
from harness.drive.evaluate import EvalConfig, evaluate
from harness.drive.generated import EpisodeUnavailable, generated_tfd_episode
from harness.drive.runner import DEFAULT_CAMERA
from harness.drive.service import service_url
from harness.world.splits import Split
from symbolic.cli_args import http_url

SPLIT: Split = "valid_unseen"
SR_BAR = 0.70  # the bar on SR with full information


def level_summary(result: dict[str, Any]) -> dict[str, Any]:
    """The numbers of one level's metrics file that the report compares."""
    metrics = result["metrics"]
    return {
        "n": result["episodes_run"],
        "sr": metrics["success"]["success_rate"],
        "gc": metrics["goal_condition_success"]["goal_condition_success_rate"],
        "tlw_sr": metrics["path_length_weighted_success_rate"],
        "tlw_gc": metrics["path_length_weighted_goal_condition_success_rate"],
        "mean_steps": metrics["mean_steps"],
        "mean_wall_s": metrics["mean_wall_s"],
        "per_task_sr": {task: m["success"]["success_rate"] for task, m in metrics["per_task"].items()},
        "episode_failures": result["episode_failures"].get("overall", {}),
        "failed_actions_percent": metrics["failure_histogram"],
        "unavailable": result["unavailable"],
    }


def obedient(n: int) -> dict[str, Any]:
    """The full-information commander with a follower that obeys to the letter, on the same slots."""
    runs, stuck = [], Counter[str]()
    for slot in tqdm(range(n), desc="obedient follower", unit="episode"):
        try:
            episode = generated_tfd_episode(SPLIT, slot, DEFAULT_CAMERA)
        except EpisodeUnavailable:
            continue
        run = run_obedient_episode(episode, DEFAULT_CAMERA, "full")
        runs.append(run)
        if not run.success:
            stuck[(run.stuck or "wrong final state").split(" (")[0]] += 1
    return {
        "n": len(runs),
        "sr": sum(r.success for r in runs) / len(runs) if runs else None,
        "mean_turns": sum(r.turns for r in runs) / len(runs) if runs else None,
        "failures": dict(stuck.most_common()),
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("tatc_commander", __doc__)
    parser.add_argument("--n", type=int, default=100, help="episodes with full information")
    parser.add_argument("--n-other", type=int, default=24, help="episodes at the two other levels")
    parser.add_argument("--levels", nargs="+", default=list(get_args(InfoLevel)), choices=get_args(InfoLevel))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument(
        "--run-dir", type=Path, default=Path("runs/bench_tatc"), help="run folders (resumable)"
    )
    parser.add_argument("--url", type=http_url, help="a running service (default: start one)")
    parser.add_argument("--no-obedient", action="store_true", help="skip the obedient-follower upper bound")
    args = parser.parse_args(argv)

    levels: dict[str, Any] = {}
    run = BenchRun.start("tatc_commander", argv)
    runs = runs_for_commit(args.run_dir, run.commit)
    with service_url(args.url, None, start=args.url is None) as url:
        for level in args.levels:
            n = args.n if level == "full" else args.n_other
            config = EvalConfig(
                benchmark="tatc",
                split=SPLIT,
                n=n,
                camera_side=DEFAULT_CAMERA.width,
                hfov_deg=DEFAULT_CAMERA.hfov_deg,
                info=level,
            )
            level_started = time.perf_counter()
            result = evaluate(config, runs / level, url, args.workers)
            levels[level] = {**level_summary(result), "wall_s": round(time.perf_counter() - level_started, 1)}
    bound = None if args.no_obedient else obedient(args.n)
    report = {
        "benchmark": "tatc_commander",
        "split": SPLIT,
        "camera": {"width": DEFAULT_CAMERA.width, "height": DEFAULT_CAMERA.height, "hfov_deg": 90.0},
        "follower": {"perception": "oracle", "planner": "model (reads the commander's instructions)"},
        "levels": levels,
        "bar": {
            "full_sr_at_least": SR_BAR,
            "met": levels["full"]["sr"] >= SR_BAR if "full" in levels else None,
        },
        "obedient_follower": bound,
    }
    for level, row in levels.items():
        print(
            f"{level:<18} n={row['n']:>3}  SR {row['sr']:.3f}  GC {row['gc']:.3f}  TLW-SR {row['tlw_sr']:.3f}"
        )
    if bound is not None:
        print(f"obedient follower  n={bound['n']:>3}  SR {bound['sr']:.3f}")
    run.write(args.out, report)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
