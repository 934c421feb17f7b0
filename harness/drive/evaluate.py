"""``python -m harness eval``: run a benchmark's episodes against the service and score them as TEACh does.

What a benchmark run needs beyond ``harness run``: many episodes in parallel workers, a progress bar, and
runs that survive being killed. Each finished episode is written to ``OUT/episodes/<slot>.json`` at once
(write to a temporary name, then rename), so a killed run loses at most the episodes in flight; started
again with the same ``--out``, it skips the slots already on disk and runs the rest. Metrics are always
computed from the episode files, one per slot, so no episode is lost or counted twice. ``OUT/run.json``
records what was asked; a second run into the same folder must ask the same (or use a new ``--out``).

Episodes (slot i of ``--n``):
- ``tfd``: the generated game i of the split (task i % 12, as ``harness generate`` makes it); with
  ``--data DIR`` (a folder ``harness generate`` wrote, or real TEACh files in the same layout), the i-th
  file of ``DIR/tfd_instances/<split>/``.
- ``edh``: the generated game i's EDH cut ``edh<k>`` (k alternating 0, 1 over the task cycles, falling back to
  edh0), or the i-th file of ``DIR/edh_instances/<split>/``.
- ``tatc``: the tfd episode's world and task, run by the commander bot (``harness.commander``) talking to
  the follower service, with the commander's information level ``--info`` (full, no_segmentation,
  no_goal_location); the follower plans with the model planner, which reads the commander's instructions.
- ``alfred``: ALFRED trajectory i of the split (train or valid_seen in the shared data; slots take the seven
  task types in turn, ``alfred_order``), its world, its first annotation's ``task_desc`` as the instruction
  (session mode ``instruction``), 300x300 at 60°, 15° looks, scored with ALFRED's goal conditions; the
  oracle plan is ``plan.low_actions`` turned into subgoals.
With ``--protocol teach`` (edh), each instance goes through TEACh's RemoteModel routes the way TEACh's own
inference runner sends it (the instance file, its history frames and each frame as JPEG, nothing else), so
the service runs learned perception and the model planner.
A generated game the expert cannot solve does not exist (the generator skips it); its slot is recorded as
unavailable, reported, and left out of the metrics.

The metrics file (``OUT/metrics.json``) has TEACh's layout (success, goal_condition_success, path-length
weighted SR and GC, per task type; ``per_instance`` is TEACh's inference metrics file, each instance's
``evaluate_traj`` fields by instance id), the failed actions by reason (the JARVIS seed's Table 8), how failed
episodes ended, and steps and wall time per episode.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
from collections import Counter, defaultdict
from collections.abc import Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Literal, cast, get_args

from tqdm import tqdm

from harness.commander.bot import InfoLevel
from harness.commander.episode import run_tatc_episode
from harness.drive.client import AgentClient, TeachRemoteModel
from harness.drive.generated import EpisodeUnavailable, generated_episode, generated_teach_instance
from harness.drive.metrics import EpisodeOutcome, aggregate, episode_metrics
from harness.drive.runner import EpisodeRun, ExplorerName, RunnerOptions, run_episode
from harness.drive.service import ServiceUnreachable, add_service_arguments, service_url
from harness.drive.teach_remote import load_teach_instance, run_teach_episode
from harness.episodes.model import Episode
from harness.episodes.teach_format import load_edh, load_tfd
from harness.render.camera import CameraSpec
from harness.tasks.teach import BENCHMARK_TASKS
from harness.world.splits import SPLITS, Split
from symbolic.cli_args import Parser, existing_dir, fail, int_at_least, plain
from symbolic.subgoals import subgoals_from_alfred_low_actions
from symbolic.thor import ALFRED_HFOV_DEG, TEACH_HFOV_DEG

BenchmarkName = Literal["edh", "tfd", "tatc", "alfred"]
Protocol = Literal["native", "teach"]
ALFRED_SPLITS = ("train", "valid_seen")  # the ALFRED splits in the shared data
ALFRED_CAMERA_SIDE = 300  # ALFRED's frames: 300x300 at 60° (DESIGN.md, issue 6 §4)
DEFAULT_CAMERA_SIDE = 300  # TEACh renders 900x900; 300 keeps an episode fast (``--camera 900`` restores it)
CLIENT_TIMEOUT_S = 120.0  # a step can queue behind other workers' steps on a busy machine
RUN_FILE = "run.json"
METRICS_FILE = "metrics.json"
EPISODES_DIR = "episodes"


class RunMismatch(ValueError):
    """The output folder holds a run that asked for something else; resuming it would mix two runs."""


@dataclass(frozen=True)
class EvalConfig:
    """What one evaluation run asks for; stored as ``run.json`` and compared on resume."""

    benchmark: BenchmarkName
    split: str
    n: int
    camera_side: int
    hfov_deg: float
    planner: Literal["oracle", "model"] = "oracle"
    perception: Literal["oracle", "learned"] = "oracle"
    navigator: Literal["fmm", "vin"] = "fmm"
    explorer: ExplorerName | None = None  # None: the service's default
    tasks: tuple[str, ...] = BENCHMARK_TASKS
    data: str | None = None  # folder of TEACh-format instances, instead of generating them
    info: InfoLevel = "full"  # TATC: what the commander may tell (the JARVIS seed's Table 2)
    protocol: Protocol = "native"  # EDH: the native API, or TEACh's RemoteModel routes (RGB, learned)

    def __post_init__(self) -> None:
        if self.n < 1:
            raise ValueError(f"--n must be at least 1, got {self.n}")
        if self.benchmark == "alfred" and self.split not in ALFRED_SPLITS:
            raise ValueError(f"ALFRED episodes come from {ALFRED_SPLITS}; split {self.split!r} has none")
        if self.benchmark != "alfred" and self.split not in SPLITS:
            raise ValueError(f"split must be one of {SPLITS}, got {self.split!r}")
        if self.protocol == "teach" and self.benchmark != "edh":
            raise ValueError(
                f"--protocol teach runs EDH instances (TEACh's RemoteModel); not {self.benchmark}"
            )
        if self.protocol == "teach" and (self.perception, self.planner) != ("learned", "model"):
            raise ValueError(
                "--protocol teach sends RGB only and no plan, as TEACh does: it needs --perception learned "
                "--planner model"
            )
        unknown = [t for t in self.tasks if t not in BENCHMARK_TASKS]
        if unknown:
            raise ValueError(f"unknown task(s) {unknown}; known: {', '.join(BENCHMARK_TASKS)}")

    @property
    def camera(self) -> CameraSpec:
        return CameraSpec(self.camera_side, self.camera_side, self.hfov_deg)

    def options(self) -> RunnerOptions:
        return RunnerOptions(
            camera=self.camera,
            planner=self.planner,
            perception=self.perception,
            navigator=self.navigator,
            explorer=self.explorer,
        )

    def to_json(self) -> dict[str, Any]:
        return {**asdict(self), "tasks": list(self.tasks)}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> EvalConfig:
        known = {f.name for f in fields(cls)}
        return cls(**{**{k: v for k, v in data.items() if k in known}, "tasks": tuple(data["tasks"])})


# ---- episodes ----------------------------------------------------------------------------------------


def _instance_files(config: EvalConfig) -> list[Path]:
    assert config.data is not None
    kind = "edh_instances" if config.benchmark == "edh" else "tfd_instances"
    folder = Path(config.data) / kind / config.split
    files = sorted(folder.glob("*.json"))
    if not files:
        raise FileNotFoundError(f"no {kind} in {folder} (write some with `python -m harness generate`)")
    return files


@functools.lru_cache(maxsize=2)
def alfred_order(split: str) -> tuple[int, ...]:
    """File positions of the split's ALFRED trajectories in slot order: the task types in turn (the files
    group them, so the first slots would otherwise all be one type), each type in file order."""
    from harness.world.alfred.data import load_alfred_trajectories

    by_type: dict[str, list[int]] = {}
    for index, traj in enumerate(load_alfred_trajectories(split)):
        by_type.setdefault(str(traj["task_type"]), []).append(index)
    queues = list(by_type.values())
    longest = max((len(queue) for queue in queues), default=0)
    return tuple(queue[depth] for depth in range(longest) for queue in queues if depth < len(queue))


def _alfred_episode(config: EvalConfig, slot: int) -> Episode:
    from harness.tasks.alfred import alfred_task_from_pddl
    from harness.world.alfred.build import alfred_world
    from harness.world.alfred.data import load_alfred_trajectories

    order = alfred_order(config.split)
    if slot >= len(order):
        raise EpisodeUnavailable(f"ALFRED {config.split} has {len(order)} trajectories, no slot {slot}")
    wanted = order[slot]
    traj = next(t for index, t in enumerate(load_alfred_trajectories(config.split)) if index == wanted)
    low_actions = traj["plan"]["low_actions"]
    return Episode(
        instance_id=f"{traj['task_id']}.{slot}",
        benchmark="alfred",
        split=cast(Split, config.split),
        world=alfred_world(traj),
        task=alfred_task_from_pddl(traj["pddl_params"], traj["task_type"]),
        instruction=str(traj["turk_annotations"]["anns"][0]["task_desc"]).strip(),
        future_subgoals=tuple(subgoals_from_alfred_low_actions(low_actions)),
        reference_actions=tuple({"action_name": action["api_action"]["action"]} for action in low_actions),
        metadata={"task_id": traj["task_id"], "scene": traj["scene"].get("floor_plan"), "file_index": wanted},
    )


def _edh_cut(config: EvalConfig, slot: int) -> str:
    """The EDH cut of a generated slot: edh0 and edh1 alternate over the task cycles."""
    return f"edh{(slot // len(config.tasks)) % 2}"


def episode_for(config: EvalConfig, slot: int) -> Episode:
    """The episode of ``slot`` (module docstring)."""
    if config.benchmark == "alfred":
        return _alfred_episode(config, slot)
    split = cast(Split, config.split)  # checked in EvalConfig
    if config.data is not None:
        files = _instance_files(config)
        if slot >= len(files):
            raise EpisodeUnavailable(f"{config.data} holds {len(files)} instances, no slot {slot}")
        path = files[slot]
        games = Path(config.data) / "games"
        return load_edh(path, games, split) if config.benchmark == "edh" else load_tfd(path, games, split)
    if config.benchmark in ("tfd", "tatc"):
        return generated_episode(split, slot, config.camera, config.tasks, instance="tfd")
    cut = _edh_cut(config, slot)
    try:
        return generated_episode(split, slot, config.camera, config.tasks, instance=cut)
    except EpisodeUnavailable:
        if cut == "edh0":
            raise
        return generated_episode(split, slot, config.camera, config.tasks, instance="edh0")


def run_slot(config: EvalConfig, slot: int, base_url: str) -> dict[str, Any]:
    """One slot's record: the episode's outcome and summary, or why it has no episode (worker process)."""
    try:
        episode = episode_for(config, slot)
    except EpisodeUnavailable as error:
        return {"slot": slot, "unavailable": str(error)}
    if config.protocol == "teach":
        return _record(slot, _run_teach_slot(config, slot, episode, base_url))
    with AgentClient(base_url, timeout=CLIENT_TIMEOUT_S) as client:
        if config.benchmark == "tatc":
            run = run_tatc_episode(episode, client, config.options(), config.info)
        else:
            run = run_episode(episode, client, config.options())
    return _record(slot, run)


def _record(slot: int, run: EpisodeRun) -> dict[str, Any]:
    failed = next((s.subgoal for s in run.subgoals if s.status == "failed"), None)
    return {
        "slot": slot,
        "outcome": asdict(run.outcome),
        "failed_subgoal": failed,
        **run.summary(),
    }


def _run_teach_slot(config: EvalConfig, slot: int, episode: Episode, base_url: str) -> EpisodeRun:
    """The slot's EDH instance through TEACh's RemoteModel routes, as TEACh's inference runner drives them
    (``harness.drive.teach_remote.run_teach_episode``): its file, its history frames, the frames as JPEG, no
    pose."""
    split = cast(Split, config.split)
    if config.data is not None:
        path = _instance_files(config)[slot]
        instance = load_teach_instance(path, Path(config.data) / "images" / split)
    else:
        cut = episode.instance_id.rsplit(".", 1)[-1]  # the cut episode_for settled on (edh1, else edh0)
        _, instance = generated_teach_instance(split, slot, config.camera, config.tasks, cut)
    with TeachRemoteModel(base_url, timeout=CLIENT_TIMEOUT_S) as model:
        return run_teach_episode(episode, instance, model, config.options())


# ---- the run folder ----------------------------------------------------------------------------------


def _write_json(path: Path, data: Any) -> None:
    """Whole or not at all: a killed run never leaves half a file that a resume would trust."""
    scratch = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    scratch.write_text(json.dumps(data, indent=1), encoding="utf-8")
    scratch.replace(path)


def prepare_run(out: Path, config: EvalConfig) -> None:
    """Create the run folder, or check that the one there was started with the same config."""
    (out / EPISODES_DIR).mkdir(parents=True, exist_ok=True)
    run_file = out / RUN_FILE
    if run_file.exists():
        previous = EvalConfig.from_json(json.loads(run_file.read_text(encoding="utf-8")))
        if previous != config:
            names = [f.name for f in fields(EvalConfig)]
            changed = [name for name in names if getattr(previous, name) != getattr(config, name)]
            raise RunMismatch(
                f"{out} holds a run with different {', '.join(changed)}; resume it with the same options "
                "or choose another --out"
            )
        return
    _write_json(run_file, config.to_json())


def finished_records(out: Path, n: int) -> dict[int, dict[str, Any]]:
    """The slots below ``n`` whose episode file is on disk (a resumed run skips them)."""
    records = {}
    for path in (out / EPISODES_DIR).glob("*.json"):
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except ValueError:
            continue  # not ours or damaged: the slot runs again and overwrites it
        slot = record.get("slot")
        if isinstance(slot, int) and 0 <= slot < n and path.name == episode_file_name(slot):
            records[slot] = record
    return records


def episode_file_name(slot: int) -> str:
    return f"{slot:05d}.json"


def report(records: dict[int, dict[str, Any]], config: EvalConfig) -> dict[str, Any]:
    """The metrics file: TEACh's aggregate over the episodes run, episode-level failures, per-episode rows."""
    ran = [records[s] for s in sorted(records) if "outcome" in records[s]]
    outcomes = [EpisodeOutcome(**r["outcome"]) for r in ran]
    episode_failures: defaultdict[str, Counter[str]] = defaultdict(Counter)
    for record in ran:
        if record["failure"] is not None:
            episode_failures[record["task_name"]][record["failure"]] += 1
            episode_failures["overall"][record["failure"]] += 1
    return {
        "config": config.to_json(),
        "episodes_run": len(ran),
        "unavailable": {str(s): r["unavailable"] for s, r in sorted(records.items()) if "unavailable" in r},
        "metrics": aggregate(outcomes) if outcomes else None,
        "per_instance": {o.instance_id: episode_metrics(o) for o in outcomes},
        "episode_failures": {task: dict(counts.most_common()) for task, counts in episode_failures.items()},
        "episodes": [
            {
                "slot": r["slot"],
                "instance_id": r["instance_id"],
                "task_name": r["task_name"],
                "success": r["outcome"]["success"],
                "gc": f"{r['outcome']['gc_satisfied']}/{r['outcome']['gc_total']}",
                "steps": r["outcome"]["steps"],
                "ref_len": r["outcome"]["ref_len"],
                "wall_s": round(r["outcome"]["wall_s"], 2),
                "failure": r["failure"],
                "failed_subgoal": r["failed_subgoal"],
                "unsatisfied": r["unsatisfied"],
            }
            for r in ran
        ],
    }


def format_table(result: dict[str, Any]) -> str:
    """Per task type: n, SR, GC, TLW-SR, TLW-GC, mean steps and seconds, how failed episodes ended."""
    metrics = result["metrics"]
    if metrics is None:
        return "no episode ran"
    failures = result["episode_failures"]
    w = max(30, *(len(name) + 2 for name in metrics["per_task"]))  # ALFRED's task types run to 33 characters
    header = f"{'task':<{w}}{'n':>4}{'SR':>7}{'GC':>7}{'TLW-SR':>8}{'TLW-GC':>8}{'steps':>7}{'s':>6}"
    lines = [f"{header}  failures"]
    for name, m in [*sorted(metrics["per_task"].items()), ("overall", metrics)]:
        why = ", ".join(f"{k} x{v}" for k, v in failures.get(name, {}).items())
        lines.append(
            f"{name:<{w}}{m['n']:>4}{m['success']['success_rate']:>7.3f}"
            f"{m['goal_condition_success']['goal_condition_success_rate']:>7.3f}"
            f"{m['path_length_weighted_success_rate']:>8.3f}"
            f"{m['path_length_weighted_goal_condition_success_rate']:>8.3f}"
            f"{m['mean_steps']:>7.0f}{m['mean_wall_s']:>6.0f}  {why}"
        )
    if metrics["failure_histogram"]:
        lines.append("failed actions (% of all):")
        lines.extend(
            f"  {share:5.1f}%  {reason} (x{metrics['failure_counts'][reason]})"
            for reason, share in metrics["failure_histogram"].items()
        )
    if result["unavailable"]:
        lines.append(f"slots without an episode: {', '.join(result['unavailable'])}")
    return "\n".join(lines)


# ---- driving -----------------------------------------------------------------------------------------


def evaluate(config: EvalConfig, out: Path, base_url: str, workers: int = 1) -> dict[str, Any]:
    """Run every slot not yet on disk, ``workers`` at a time; write and return the metrics file's content."""
    prepare_run(out, config)
    records = finished_records(out, config.n)
    todo = [slot for slot in range(config.n) if slot not in records]
    bar = tqdm(total=config.n, initial=config.n - len(todo), desc=f"eval {config.benchmark}", unit="episode")
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        pending: set[Future[dict[str, Any]]] = {pool.submit(run_slot, config, s, base_url) for s in todo}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    record = future.result()
                    _write_json(out / EPISODES_DIR / episode_file_name(record["slot"]), record)
                    records[record["slot"]] = record
                    bar.update(1)
                    successes = sum(bool(r.get("outcome", {}).get("success")) for r in records.values())
                    bar.set_postfix(success=f"{successes}/{len(records)}")
        except BaseException:
            for future in pending:
                future.cancel()
            raise
        finally:
            bar.close()
    result = report(records, config)
    _write_json(out / METRICS_FILE, result)
    return result


def _parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m harness eval", description=plain(__doc__.split("\n\n")[0]))
    parser.add_argument("--benchmark", required=True, choices=get_args(BenchmarkName))
    parser.add_argument(
        "--split", default="valid_unseen", choices=SPLITS, help="ALFRED's valid_unseen runs valid_seen"
    )
    parser.add_argument("--n", type=int_at_least(1), required=True, help="episodes (slots 0..n-1)")
    parser.add_argument("--workers", type=int_at_least(1), default=1, help="episodes run in parallel")
    parser.add_argument(
        "--run-dir", type=Path, help="resumable run folder (default: runs/eval/<benchmark>_<split>)"
    )
    parser.add_argument(
        "--data", type=existing_dir, help="TEACh-format instances to run instead of generating"
    )
    parser.add_argument(
        "--task",
        action="append",
        choices=BENCHMARK_TASKS,
        help="only this TEACh task (repeat for several; default: all 12)",
    )
    parser.add_argument(
        "--camera", type=int_at_least(32), help="square frame side (default 300; ALFRED's for alfred)"
    )
    parser.add_argument("--planner", default="oracle", choices=("oracle", "model"))
    parser.add_argument("--perception", default="oracle", choices=("oracle", "learned"))
    parser.add_argument("--navigator", default="fmm", choices=("fmm", "vin"))
    parser.add_argument("--explorer", choices=get_args(ExplorerName), help="default: the service's")
    parser.add_argument("--info", default="full", choices=get_args(InfoLevel), help="TATC commander's info")
    parser.add_argument(
        "--protocol",
        default="native",
        choices=get_args(Protocol),
        help="edh only: teach drives TEACh's RemoteModel routes as TEACh's runner does (RGB JPEG frames)",
    )
    add_service_arguments(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run (or resume) an evaluation and print its table."""
    parser = _parser()
    args = parser.parse_args(argv)
    alfred = args.benchmark == "alfred"
    split = "valid_seen" if alfred and args.split == "valid_unseen" else args.split
    try:
        config = EvalConfig(
            benchmark=args.benchmark,
            split=split,
            n=args.n,
            camera_side=args.camera or (ALFRED_CAMERA_SIDE if alfred else DEFAULT_CAMERA_SIDE),
            hfov_deg=ALFRED_HFOV_DEG if alfred else TEACH_HFOV_DEG,
            planner=args.planner,
            perception=args.perception,
            navigator=args.navigator,
            explorer=args.explorer,
            tasks=tuple(args.task or BENCHMARK_TASKS),
            data=str(args.data.resolve()) if args.data else None,
            info=args.info,
            protocol=args.protocol,
        )
    except ValueError as error:
        parser.error(str(error))
    out = args.run_dir or Path("runs") / "eval" / f"{args.benchmark}_{split}"
    try:
        with service_url(args.url, args.port, args.start_service) as base_url:
            result = evaluate(config, out, base_url, args.workers)
    except (RunMismatch, ServiceUnreachable) as error:
        fail("python -m harness eval", str(error))
    except KeyboardInterrupt:
        done = len(finished_records(out, config.n))
        print(f"\ninterrupted: {done}/{config.n} episodes in {out}; run again to go on", file=sys.stderr)
        return 130
    print(format_table(result))
    print(f"wrote {out / METRICS_FILE} and {len(result['episodes'])} episode files in {out / EPISODES_DIR}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
