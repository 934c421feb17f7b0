"""Goal transformer vs frontier exploration: on the same search episodes, and inside the whole agent.

The issue: the JARVIS seed's Goal Transformer explores when the target is not in the map; compare it with
HLSM's frontier exploration on the same episodes (steps to first sight of the target, success rate) and
make the better one the default (``agent.explorers.DEFAULT_EXPLORER``). Two comparisons:

1. Search phases. Each episode is a valid_unseen search phase from
``harness.perception_data.search_episodes`` (a start pose from which the target is out of view; the
expert's shortest search is reported for scale). Both explorers drive the agent's own semantic map with
oracle perception (so only the exploration differs), the simulator executes their actions, and the episode
succeeds when the target comes into view (the expert's sighting rule) within ``--max-steps`` actions.
2. Whole episodes (``--tfd N``): the agent service on the first N generated valid_unseen TfD games with
the expert's subgoals and oracle perception, once per explorer (the session's ``explorer`` option); the
explorer only acts while a target is unmapped, between the agent's look-around and its container search,
so this is what the choice is worth to a user. Task SR decides the default, then goal-condition SR (also
what a user sees), then search success.

Run: ``.venv/bin/python -m bench.goal_transformer_vs_frontier [--episodes 30] [--tfd 60] [--workers 2]``;
writes ``bench/results/goal_transformer_vs_frontier.json``.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agent.exploration_gt import GoalTransformerExplorer
from agent.geometry import Camera, Pose
from agent.mapping import SemanticMap
from agent.navigation import make_navigator
from agent.navigation.base import NavGrids
from agent.navigation.exploration import ExploreInput, FrontierExplorer
from agent.perception import OraclePerception
from agent.perception.base import Observation
from bench.cli import bench_parser
from bench.stamp import BenchRun, runs_for_commit
from bench.tatc_commander import level_summary
from harness.drive.evaluate import EvalConfig, evaluate
from harness.drive.runner import DEFAULT_CAMERA, ExplorerName
from harness.drive.service import service_url
from harness.perception_data import SearchConfig, SightingCheck, search_episodes
from harness.render.camera import CameraSpec
from harness.sim.simulator import Simulator
from harness.world.model import World
from symbolic.thor import TEACH_HFOV_DEG

SEED = 7
SIDE = 300
EXPLORERS: tuple[ExplorerName, ...] = ("frontier", "goal_transformer")


def run_search(
    world: World, record: dict[str, Any], explorer_name: str, max_steps: int, seed: int
) -> dict[str, Any]:
    """One explorer on one episode: steps until the target is in view (None if it never is)."""
    spec = CameraSpec(SIDE, SIDE, TEACH_HFOV_DEG)
    camera = Camera(SIDE, SIDE, TEACH_HFOV_DEG)
    sim = Simulator(world, spec)
    target = str(record["target"])
    target_ids = {world.instance_ids[o.object_id] for o in world.of_type(target)}
    sighted = SightingCheck(world.copy(), target_ids, world.agent.horizon, SearchConfig())
    agent = world.agent
    semantic_map = SemanticMap(camera, Pose(agent.x, agent.z, float(agent.yaw), agent.horizon))
    perception = OraclePerception(camera)
    rng = np.random.default_rng(seed)
    frontier = FrontierExplorer(make_navigator("fmm"), rng) if explorer_name == "frontier" else None
    learned = GoalTransformerExplorer(rng) if explorer_name == "goal_transformer" else None
    subgoals = [(str(a), str(o)) for a, o in record["subgoals"]]
    last_success: bool | None = None
    for step in range(max_steps + 1):
        state = (*world.room.cell_of(agent.x, agent.z), (agent.yaw // 90) % 4)
        if sighted(state):
            return {"found": True, "steps": step}
        if step == max_steps:
            break
        frame = sim.observe(noise_seed=seed * 1000 + step)
        pose = Pose(agent.x, agent.z, float(agent.yaw), agent.horizon)
        obs = Observation(rgb=frame.rgb, depth=frame.depth, instances=frame.instances, legend=frame.legend)
        semantic_map.update(perception.perceive(obs, target_type=target), pose)
        grids = NavGrids(
            obstacles=semantic_map.obstacles(),
            explored=semantic_map.explored() | semantic_map.visited(),
            collisions=semantic_map.collisions(),
        )
        if frontier is not None:
            decision = frontier.next_action(ExploreInput(grids, semantic_map.frame, pose))
        else:
            assert learned is not None and frame.rgb is not None
            decision = learned.next_action(
                ExploreInput(
                    grids,
                    semantic_map.frame,
                    pose,
                    rgb=frame.rgb,
                    subgoals=subgoals,
                    last_action_success=last_success,
                )
            )
        if decision.action is None:
            break
        result = sim.step(decision.action)
        last_success = result.success
        if not result.success:
            semantic_map.record_collision(pose, decision.action)
    return {"found": False, "steps": None}


def summarize(rows: list[dict[str, Any]], name: str) -> dict[str, Any]:
    found = [r[name]["steps"] for r in rows if r[name]["found"]]
    return {
        "success_rate": len(found) / len(rows),
        "mean_steps_to_sight_when_found": float(np.mean(found)) if found else None,
        "median_steps_to_sight_when_found": float(np.median(found)) if found else None,
    }


def _rank(summary: dict[str, Any]) -> tuple[float, float]:
    """Higher success rate first, then fewer steps to first sight."""
    steps = summary["mean_steps_to_sight_when_found"]
    return summary["success_rate"], -(steps if steps is not None else float("inf"))


def whole_episodes(n: int, workers: int, runs: Path, commit: str) -> dict[str, Any]:
    """Task SR of the agent with each explorer on the first n generated valid_unseen TfD games (run folders
    of ``commit``'s code)."""
    results: dict[str, Any] = {}
    with service_url(None, None, start=True) as url:
        for name in EXPLORERS:
            config = EvalConfig(
                benchmark="tfd",
                split="valid_unseen",
                n=n,
                camera_side=DEFAULT_CAMERA.width,
                hfov_deg=DEFAULT_CAMERA.hfov_deg,
                explorer=name,
            )
            summary = level_summary(evaluate(config, runs_for_commit(runs / name, commit), url, workers))
            results[name] = {k: summary[k] for k in ("n", "sr", "gc", "mean_steps", "per_task_sr")}
    return results


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("goal_transformer_vs_frontier", __doc__)
    parser.add_argument("--episodes", type=int, default=30)
    parser.add_argument("--steps", type=int, default=100, help="steps each search episode may take")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--tfd", type=int, default=0, help="also run this many TfD games per explorer")
    parser.add_argument("--workers", type=int, default=2, help="episodes in parallel for --tfd")
    parser.add_argument(
        "--run-dir", type=Path, default=Path("runs/bench/explorers"), help="--tfd run folders"
    )
    args = parser.parse_args(argv)
    run = BenchRun.start("goal_transformer_vs_frontier", argv)
    import torch  # after parsing: --help loads no torch

    torch.set_num_threads(args.threads)
    rows = []
    for n, (world, record, expert) in enumerate(search_episodes("valid_unseen", args.episodes, SEED)):
        row: dict[str, Any] = {
            "target": record["target"],
            "room": record["room_kind"],
            "expert_steps": len(expert),
        }
        for name in EXPLORERS:
            row[name] = run_search(world.copy(), record, name, args.steps, SEED + n)
        rows.append(row)
        print(f"{n:3d} {record['target']:<16} expert {len(expert):3d}  " + "  ".join(
            f"{name} {row[name]['steps'] if row[name]['found'] else '-'}" for name in EXPLORERS
        ))  # fmt: skip
    result: dict[str, Any] = {
        "episodes": len(rows),
        "max_steps": args.steps,
        "split": "valid_unseen",
        "perception": "oracle (only exploration differs)",
        "expert_mean_steps": float(np.mean([r["expert_steps"] for r in rows])),
        **{name: summarize(rows, name) for name in EXPLORERS},
        "rows": rows,
    }
    searches = {name: _rank(result[name]) for name in EXPLORERS}
    if args.tfd:
        tasks = whole_episodes(args.tfd, args.workers, args.run_dir, run.commit)
        result["tfd_oracle_subgoals"] = tasks
        result["better"] = max(
            EXPLORERS, key=lambda name: (tasks[name]["sr"], tasks[name]["gc"], *searches[name])
        )
    else:
        result["better"] = max(EXPLORERS, key=lambda name: searches[name])
    return run.finish(
        args.out, result, [json.dumps({k: v for k, v in result.items() if k != "rows"}, indent=2)]
    )


if __name__ == "__main__":
    sys.exit(main())
