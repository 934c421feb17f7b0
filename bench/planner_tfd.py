"""The agent's success rate when the language planner, not the expert, turns the dialogue into subgoals.

The planner issue's bar: with the model planner and oracle perception, SR ≥ 60% on 100 generated
valid_unseen TfD episodes. One ``python -m harness eval --benchmark tfd --planner model`` run (episode i is
the generated game i, task i % 12; a real service subprocess over HTTP, frames at 300x300 with depth and
segmentation); the session plans from the game's whole dialogue with the default checkpoint
(``models/checkpoints/planner``), re-plans when the plan runs out or fails, and repairs every plan. Compare
with ``bench/results/agent_oracle_tfd.json`` (the expert's subgoals on the same games): the difference is
what the planner costs.

Run: ``.venv/bin/python -m bench.planner_tfd [--n 100] [--workers 2]``; writes
``bench/results/planner_tfd.json``. The run folder (``--run-dir``) resumes when started again by the same
commit.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from app.settings import Settings
from bench.cli import add_episode_options, bench_parser
from bench.stamp import BenchRun, runs_for_commit
from bench.tatc_commander import level_summary
from harness.drive.evaluate import EvalConfig, evaluate
from harness.drive.runner import DEFAULT_CAMERA
from harness.drive.service import service_url
from harness.world.splits import Split
from symbolic.cli_args import Parser

DEFAULT_CHECKPOINT = Path(__file__).resolve().parents[1] / "models" / "checkpoints" / "planner"
SPLIT: Split = "valid_unseen"
SR_BAR = 0.60  # the planner issue's bar on SR with the model planner and oracle perception


def checkpoint_summary() -> dict[str, Any]:
    """Which planner checkpoint ran (the service's: ``JARVIS_PLANNER_CHECKPOINT`` or the shipped one): its
    recipe, size, training steps and dev loss."""
    folder = Settings().planner_checkpoint or DEFAULT_CHECKPOINT
    meta = json.loads((folder / "planner_meta.json").read_text(encoding="utf-8"))
    keys = ("recipe", "architecture", "parameters", "step", "dev_loss", "data_fingerprint", "navigate_bias")
    return {"folder": "default" if folder == DEFAULT_CHECKPOINT else str(folder)} | {
        key: meta.get(key) for key in keys
    }


def episode_bench_parser(name: str, doc: str | None, n: int, n_help: str) -> Parser:
    """The options every planner SR bench takes (``bench.cli.add_episode_options``), its run folder under
    ``runs/bench/<name>``."""
    parser = bench_parser(name, doc)
    add_episode_options(
        parser, n=n, n_help=n_help, run_dir=Path("runs/bench") / name, run_dir_help="resumable run folder"
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = episode_bench_parser("planner_tfd", __doc__, 100, "episodes (slot i is task i %% 12)")
    args = parser.parse_args(argv)

    run = BenchRun.start("planner_tfd", argv)
    config = EvalConfig(
        benchmark="tfd",
        split=SPLIT,
        n=args.n,
        camera_side=DEFAULT_CAMERA.width,
        hfov_deg=DEFAULT_CAMERA.hfov_deg,
        planner="model",
    )
    with service_url(args.url, None, start=args.url is None) as url:
        result = evaluate(config, runs_for_commit(args.run_dir, run.commit), url, args.workers)
    summary = level_summary(result)
    report: dict[str, Any] = {
        "benchmark": "tfd_model_planner",
        "split": SPLIT,
        "camera": {"width": DEFAULT_CAMERA.width, "height": DEFAULT_CAMERA.height, "hfov_deg": 90.0},
        "agent": {"perception": "oracle", "planner": "model (default checkpoint) + symbolic repair"},
        "planner_checkpoint": checkpoint_summary(),
        "result": summary,
        "bar": {"sr_at_least": SR_BAR, "met": summary["sr"] >= SR_BAR},
    }
    verdict = "met" if report["bar"]["met"] else "NOT met"
    write_report(
        run, args.out, report, f"SR {summary['sr']:.3f} (n={summary['n']}) vs bar {SR_BAR}: {verdict}"
    )
    return 0


def write_report(run: BenchRun, path: Path, report: dict[str, Any], headline: str) -> None:
    """Print a planner SR bench's headline and SR per task, and write its JSON."""
    print(headline)
    per_task = sorted(report["result"]["per_task_sr"].items())
    width = max((len(task) for task, _ in per_task), default=0) + 2
    for task, sr in per_task:
        print(f"  {task:<{width}}{sr:.3f}")
    run.write(path, report)


if __name__ == "__main__":
    raise SystemExit(main())
