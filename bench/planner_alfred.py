"""The agent's success rate on ALFRED instructions when the language planner reads the sentence.

The planner issue measures ALFRED by exact match of the plan against the expert's (``models.planner
evaluate``), and that counts a plan wrong for fetching a Knife where the expert took a ButterKnife or for
not opening the fridge the apple happened to be in, though the agent would finish either. What a user of an
ALFRED-style benchmark sees is whether the episode ends with the goal met. So this bench runs the same
ALFRED valid_seen episodes twice through a real service (``harness eval --benchmark alfred``: the
trajectory's floor plan and objects, its first annotation's ``task_desc`` as the one instruction, 300x300
at 60°, oracle perception, ALFRED's goal conditions): once with the expert's subgoals (``planner:
oracle``, what the rest of the agent can do) and once with the default planner checkpoint (``planner:
model``, re-planning and repair as in every session). The difference is what reading the sentence costs.
Episodes the model run loses or gains against the oracle run are listed with their instruction and first
plan, which is where to look.

Run: ``.venv/bin/python -m bench.planner_alfred [--n 70] [--workers 2]`` (slots take ALFRED's seven task
types in turn); writes ``bench/results/planner_alfred.json``. Needs the shared data directory.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

from bench.planner_tfd import checkpoint_summary, episode_bench_parser, write_report
from bench.stamp import BenchRun, runs_for_commit
from bench.tatc_commander import level_summary
from harness.drive.evaluate import ALFRED_CAMERA_SIDE, EvalConfig, episode_for, evaluate, finished_records
from harness.drive.service import service_url
from symbolic.thor import ALFRED_HFOV_DEG

SPLIT = "valid_seen"  # the only ALFRED validation split in the shared data


def alfred_config(planner: Literal["oracle", "model"], n: int) -> EvalConfig:
    """``harness eval --benchmark alfred`` as this bench runs it, with one planner or the other."""
    return EvalConfig(
        benchmark="alfred",
        split=SPLIT,
        n=n,
        camera_side=ALFRED_CAMERA_SIDE,
        hfov_deg=ALFRED_HFOV_DEG,
        planner=planner,
    )


def changed_episodes(runs: Path, n: int) -> dict[str, list[dict[str, Any]]]:
    """The slots whose outcome differs between the two runs in ``runs`` (their episode files), with the
    sentence, the model's first plan and how its episode ended."""
    oracle = finished_records(runs / "oracle", n)
    model = finished_records(runs / "model", n)
    config = alfred_config("model", n)
    lost: list[dict[str, Any]] = []
    gained: list[dict[str, Any]] = []
    for slot, record in sorted(model.items()):
        if "outcome" not in record or "outcome" not in oracle.get(slot, {}):
            continue  # unavailable in either run
        success = record["outcome"]["success"]
        if success == oracle[slot]["outcome"]["success"]:
            continue
        row = {
            "slot": slot,
            "instance_id": record["instance_id"],
            "task_type": record["task_name"],
            "instruction": episode_for(config, slot).instruction,
            "first_plan": ", ".join(record["plans"][0]) if record["plans"] else "",
            "end_reason": record["end_reason"],
            "failure": record["failure"],
        }
        (gained if success else lost).append(row)
    return {"lost": lost, "gained": gained}


def main(argv: Sequence[str] | None = None) -> int:
    parser = episode_bench_parser(
        "planner_alfred", __doc__, 70, "episodes (slots take the 7 task types in turn)"
    )
    args = parser.parse_args(argv)

    run = BenchRun.start("planner_alfred", argv)
    runs = runs_for_commit(args.run_dir, run.commit)
    with service_url(args.url, None, start=args.url is None) as url:
        oracle = evaluate(alfred_config("oracle", args.n), runs / "oracle", url, args.workers)
        model = evaluate(alfred_config("model", args.n), runs / "model", url, args.workers)
    oracle_summary, model_summary = level_summary(oracle), level_summary(model)
    report: dict[str, Any] = {
        "benchmark": "alfred_instruction_model_planner",
        "split": SPLIT,
        "instruction": "the trajectory's first annotation's task_desc",
        "camera": {"width": ALFRED_CAMERA_SIDE, "height": ALFRED_CAMERA_SIDE, "hfov_deg": ALFRED_HFOV_DEG},
        "agent": {"perception": "oracle", "planner": "model (default checkpoint) + symbolic repair"},
        "planner_checkpoint": checkpoint_summary(),
        "result": model_summary,
        "oracle_planner": oracle_summary,
        "sr_cost_of_reading": round(oracle_summary["sr"] - model_summary["sr"], 4),
        "changed": changed_episodes(runs, args.n),
    }
    headline = (
        f"SR {model_summary['sr']:.3f} with the model planner, {oracle_summary['sr']:.3f} with the expert's "
        f"subgoals (n={model_summary['n']})"
    )
    write_report(run, args.out, report, headline)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
