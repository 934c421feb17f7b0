"""The agent's success rate when the whole dialogue is one bare request ("make a cup of coffee").

A curl user or a commander bot often states the task once, with no greeting and nothing after it; the
generated games never do (their commanders greet, frame the task and then guide step by step). This bench
takes the same generated valid_unseen games as ``bench/planner_tfd.py`` (indices 0..n-1, task i % 12),
keeps of each TfD dialogue only the commander's first request with its greeting and frame taken off
(``models.planner.data.bare_request``: "Hi there! Today make coffee. First ..." -> "make coffee. First
..."), and runs them through a real service with the model planner and oracle perception. Without the later
turns the agent is not told where things are, so it must search; the gap to ``planner_tfd.json`` is what
the missing dialogue costs.

Run: ``.venv/bin/python -m bench.planner_bare_request [--n 100] [--workers 2]``; writes
``bench/results/planner_bare_request.json``. Games are generated into ``--run-dir`` (about 3 s each) unless
``--teach`` names a folder ``python -m harness generate --split valid_unseen`` wrote. A candidate checkpoint
runs with ``JARVIS_PLANNER_CHECKPOINT=<dir>`` (the service reads it; the report says which ran).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.planner_tfd import SPLIT, checkpoint_summary, episode_bench_parser, write_report
from bench.stamp import BenchRun, results_path, runs_for_commit
from bench.tatc_commander import level_summary
from harness.drive.evaluate import EvalConfig, evaluate
from harness.drive.runner import DEFAULT_CAMERA
from harness.drive.service import service_url
from harness.episodes.generate import GenerateConfig, generate
from models.planner.data import bare_request

WHOLE_DIALOGUE = results_path("planner_tfd")
GAME_INDEX = re.compile(r"index (\d+)")


def write_bare_instances(teach: Path, out: Path, n: int) -> dict[str, Any]:
    """``out`` as a TEACh-format folder: the games of ``teach`` with index < n, each TfD instance's dialogue
    cut to its bare first request; games whose request has nothing to take off are left out and counted."""
    games = teach / "games" / SPLIT
    (out / "games").mkdir(parents=True, exist_ok=True)
    link = out / "games" / SPLIT
    if not link.exists():
        link.symlink_to(games.resolve())
    instances = out / "tfd_instances" / SPLIT
    instances.mkdir(parents=True, exist_ok=True)
    kept: dict[str, str] = {}
    already_bare: list[str] = []
    for path in sorted((teach / "tfd_instances" / SPLIT).glob("*.json")):
        data = json.loads(path.read_text(encoding="utf-8"))
        game = json.loads((games / f"{data['game_id']}.game.json").read_text(encoding="utf-8"))
        index = GAME_INDEX.search(game.get("comments", ""))
        if index is None or int(index.group(1)) >= n:
            continue
        bare = bare_request([(str(speaker), str(text)) for speaker, text in data["dialog_history"]])
        if bare is None:
            already_bare.append(path.stem)
            continue
        data["dialog_history"] = [["Commander", bare]]
        (instances / path.name).write_text(json.dumps(data), encoding="utf-8")
        kept[path.stem] = bare
    return {"games": len(kept), "left_out_nothing_to_take_off": already_bare, "requests": kept}


def main(argv: Sequence[str] | None = None) -> int:
    parser = episode_bench_parser("planner_bare_request", __doc__, 100, "game indices 0..n-1 of valid_unseen")
    parser.add_argument("--teach", type=Path, help="generated valid_unseen games (default: generate them)")
    args = parser.parse_args(argv)

    run = BenchRun.start("planner_bare_request", argv)
    runs = runs_for_commit(args.run_dir, run.commit)
    teach = args.teach
    if teach is None:
        teach = runs / "teach"
        if not (teach / "manifest.json").is_file():
            generate(GenerateConfig(out=teach, splits=(SPLIT,), n=args.n))
    bare = write_bare_instances(teach, runs / "bare", args.n)
    config = EvalConfig(
        benchmark="tfd",
        split=SPLIT,
        n=bare["games"],
        data=str((runs / "bare").resolve()),
        camera_side=DEFAULT_CAMERA.width,
        hfov_deg=DEFAULT_CAMERA.hfov_deg,
        planner="model",
    )
    with service_url(args.url, None, start=args.url is None) as url:
        result = evaluate(config, runs / "episodes", url, args.workers)
    summary = level_summary(result)
    whole = json.loads(WHOLE_DIALOGUE.read_text(encoding="utf-8")) if WHOLE_DIALOGUE.is_file() else None
    report: dict[str, Any] = {
        "benchmark": "tfd_bare_request_model_planner",
        "split": SPLIT,
        "dialogue": "the commander's first request alone, greeting and frame taken off",
        "camera": {"width": DEFAULT_CAMERA.width, "height": DEFAULT_CAMERA.height, "hfov_deg": 90.0},
        "agent": {"perception": "oracle", "planner": "model + symbolic repair"},
        "planner_checkpoint": checkpoint_summary(),
        "result": summary,
        "whole_dialogue_sr": whole["result"]["sr"] if whole else None,
        "whole_dialogue_commit": whole.get("stamp", {}).get("commit") if whole else None,
        "games_left_out": bare["left_out_nothing_to_take_off"],
        "requests": bare["requests"],
    }
    write_report(
        run,
        args.out,
        report,
        f"SR {summary['sr']:.3f} GC {summary['gc']:.3f} (n={summary['n']}) with bare requests",
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
