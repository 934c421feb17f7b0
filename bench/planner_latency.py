"""Language planner latency on CPU, both engines side by side (DESIGN.md §8: a planner call takes a median
≤ 100 ms and a p90 ≤ 150 ms on one thread while 32 sessions step).

Times ``ModelPlanner.plan`` as a session calls it (format the dialogue and history, beam search of 4,
validate against the ontology, task-level repair) with each decoding engine of the one loaded checkpoint:
"torch" (transformers' ``generate``, what the planner ran before) and "onnx" (``models/planner/
onnx_engine.py``). The fixed inputs are the 30 hand-written dialogues of
``tests/data/handwritten_dialogues.jsonl`` and five ALFRED-style instructions, each planned ``REPEATS``
times after one warm-up pass, the two engines alternating on every input so both see the same machine.
Wall and CPU (this thread's) milliseconds per call are recorded, first alone, then while ``--sessions``
sessions step on a service that another process starts and drives (``bench.step_latency``'s concurrency
driver: oracle perception, 300x300 frames), which is the budget's condition. The machine is shared: the
load average is recorded.

Agreement: how often the two engines' generated plans are identical, on the fixed inputs and on the
evaluation sets of ``--data`` folders (``python -m models.planner build-data``), with each engine's exact
match and F1 there.

Run: ``.venv/bin/python -m bench.planner_latency [--data DIR ...] [--sessions 32]``; writes
``bench/results/planner_latency.json``.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from multiprocessing.queues import Queue
from multiprocessing.synchronize import Event
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agent.model_planner import ModelPlanner
from agent.planning import DialogueTurn, PlannerConfig, PlanningContext
from bench.cli import bench_parser
from bench.stamp import BenchRun
from bench.step_latency import episodes, measure_concurrency
from harness.drive.runner import RunnerOptions
from harness.drive.service import running_service
from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.config import GenerationConfig
from models.planner.data import DatasetFiles, PlannerExample, handwritten_examples, read_examples
from symbolic.data_dir import REPO_ROOT
from symbolic.ontology import load_ontology
from symbolic.subgoals import parse_subgoals

if TYPE_CHECKING:
    from models.planner.predict import SubgoalGenerator

HANDWRITTEN = REPO_ROOT / "tests" / "data" / "handwritten_dialogues.jsonl"
INSTRUCTIONS = (
    "Put a clean mug in the coffee machine.",
    "Place a chilled apple on the kitchen table.",
    "Put two spray bottles in the cabinet.",
    "Look at the alarm clock under the lamp.",
    "Put a heated slice of potato in the fridge.",
)
REPEATS = 3
BUDGET_MEDIAN_MS = 100.0
BUDGET_P90_MS = 150.0
ENGINES = ("torch", "onnx")
LOAD_STEPS_PER_ROUND = 20  # steps per session in one round of the background load (rounds repeat)


def contexts() -> list[PlanningContext]:
    """The fixed inputs: hand-written dialogues (with their history) and instructions."""
    ontology = load_ontology()
    cases = []
    for line in HANDWRITTEN.read_text(encoding="utf-8").splitlines():
        record = json.loads(line)
        turns = tuple(DialogueTurn(speaker, text) for speaker, text in record["dialogue"])
        history = tuple(parse_subgoals(record.get("history_subgoals") or [], ontology))
        cases.append(PlanningContext(dialogue=turns, history_subgoals=history))
    cases += [PlanningContext(instruction=text) for text in INSTRUCTIONS]
    return cases


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def summary(wall_ms: list[float], cpu_ms: list[float]) -> dict[str, float]:
    return {
        "median_ms": round(statistics.median(wall_ms), 2),
        "p90_ms": round(percentile(wall_ms, 0.9), 2),
        "max_ms": round(max(wall_ms), 2),
        "cpu_median_ms": round(statistics.median(cpu_ms), 2),
        "cpu_p90_ms": round(percentile(cpu_ms, 0.9), 2),
    }


def time_engines(planners: dict[str, ModelPlanner], cases: Sequence[PlanningContext]) -> dict[str, Any]:
    """Every case planned by each engine in turn, ``REPEATS`` times; per-engine wall and CPU times and the
    torch/onnx ratio of medians."""
    wall: dict[str, list[float]] = {name: [] for name in planners}
    cpu: dict[str, list[float]] = {name: [] for name in planners}
    for _ in range(REPEATS):
        for context in cases:
            for name, planner in planners.items():
                started, started_cpu = time.perf_counter(), time.thread_time()
                planner.plan(context)
                cpu[name].append((time.thread_time() - started_cpu) * 1000)
                wall[name].append((time.perf_counter() - started) * 1000)
    result: dict[str, Any] = {name: summary(wall[name], cpu[name]) for name in planners}
    torch_ms, onnx_ms = result["torch"], result["onnx"]
    result["torch_over_onnx"] = {
        "median": round(torch_ms["median_ms"] / onnx_ms["median_ms"], 2),
        "p90": round(torch_ms["p90_ms"] / onnx_ms["p90_ms"], 2),
        "cpu_median": round(torch_ms["cpu_median_ms"] / onnx_ms["cpu_median_ms"], 2),
    }
    result["onnx_within_budget"] = (
        onnx_ms["median_ms"] <= BUDGET_MEDIAN_MS and onnx_ms["p90_ms"] <= BUDGET_P90_MS
    )
    return result


def _step_sessions(sessions: int, ready: Event, stop: Event, reports: Queue) -> None:
    """The load, in a process of its own (its client threads render frames and would otherwise hold the
    timed process's interpreter lock): a service started here and ``sessions`` sessions stepping on it in
    rounds of ``LOAD_STEPS_PER_ROUND`` steps until ``stop``; each round's throughput and errors are put on
    ``reports``, then None."""
    options = RunnerOptions()
    batch = episodes(12, options)
    round_options = replace(options, max_steps=LOAD_STEPS_PER_ROUND)
    with running_service() as service:
        ready.set()
        while not stop.is_set():
            report = measure_concurrency(service, batch, sessions, round_options)
            reports.put({key: report[key] for key in ("throughput_steps_per_s", "errors")})
    reports.put(None)


@contextmanager
def stepping_sessions(sessions: int) -> Iterator[list[dict[str, Any]]]:
    """``sessions`` sessions stepping (``_step_sessions``) from before the block starts until it ends;
    yields the rounds' reports, filled when the block ends."""
    context = multiprocessing.get_context("spawn")
    ready, stop, reports = context.Event(), context.Event(), context.Queue()
    load = context.Process(target=_step_sessions, args=(sessions, ready, stop, reports), daemon=True)
    load.start()
    ready.wait()
    time.sleep(10.0)  # the sessions' first steps are under way
    rounds: list[dict[str, Any]] = []
    try:
        yield rounds
    finally:
        stop.set()
        while (report := reports.get()) is not None:
            rounds.append(report)
        load.join()


def agreement(
    generators: dict[str, SubgoalGenerator], sets: dict[str, list[PlannerExample]]
) -> dict[str, Any]:
    """Per set: how many inputs the two engines give the identical generated plan, and each engine's exact
    match and F1 against the references."""
    from models.planner.evaluate import report_for  # loads torch and transformers

    ontology = load_ontology()
    result: dict[str, Any] = {}
    for name, examples in sets.items():
        predictions = {
            engine: [generator.predict(example.source) for example in examples]
            for engine, generator in generators.items()
        }
        same = sum(a.text == b.text for a, b in zip(predictions["torch"], predictions["onnx"], strict=True))
        scores = {
            engine: report_for(name, examples, plans, ontology).overall
            for engine, plans in predictions.items()
        }
        result[name] = {
            "n": len(examples),
            "identical_plans": same,
            "agreement": round(same / len(examples), 4),
            **{
                engine: {"exact_match": round(s.exact_match, 4), "f1": round(s.f1, 4)}
                for engine, s in scores.items()
            },
        }
    total = sum(r["n"] for r in result.values())
    same = sum(r["identical_plans"] for r in result.values())
    result["all"] = {"n": total, "identical_plans": same, "agreement": round(same / max(total, 1), 4)}
    return result


def evaluation_sets(folders: Sequence[Path]) -> dict[str, list[PlannerExample]]:
    """The hand-written dialogues and every evaluation set in ``folders``."""
    sets = {"handwritten": handwritten_examples(HANDWRITTEN, load_ontology())}
    for folder in folders:
        sets |= {name: read_examples(path) for name, path in DatasetFiles(folder).evaluation_sets().items()}
    return sets


def _timed(label: str, run: Callable[[], Any]) -> Any:
    started = time.perf_counter()
    value = run()
    print(f"{label}: {time.perf_counter() - started:.0f} s", file=sys.stderr)
    return value


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("planner_latency", __doc__)
    parser.add_argument("--checkpoint", type=Path, default=DEFAULT_CHECKPOINT_DIR)
    parser.add_argument(
        "--threads", type=int, default=1, help="torch and ONNX Runtime threads (one per worker)"
    )
    parser.add_argument("--sessions", type=int, default=32, help="sessions stepping meanwhile (0: none)")
    parser.add_argument("--data", type=Path, nargs="*", default=[], help="build-data folders for agreement")
    args = parser.parse_args(argv)
    run = BenchRun.start("planner_latency", argv)
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    import torch  # torch and transformers load after parsing, so --help answers at once

    from models.planner.predict import SubgoalGenerator

    torch.set_num_threads(args.threads)
    ontology = load_ontology()
    base = SubgoalGenerator.from_directory(args.checkpoint, ontology, GenerationConfig(engine="torch"))
    started = time.perf_counter()
    fast = SubgoalGenerator(base.planner, ontology, GenerationConfig(engine="onnx"))
    build_s = time.perf_counter() - started
    generators = {"torch": base, "onnx": fast}
    planners = {name: ModelPlanner(ontology, PlannerConfig(), generator=g) for name, g in generators.items()}
    cases = contexts()
    for context in cases:  # warm-up: first calls allocate caches
        for planner in planners.values():
            planner.plan(context)
    alone = _timed("alone", lambda: time_engines(planners, cases))
    under_load: dict[str, Any] | None = None
    if args.sessions:
        with stepping_sessions(args.sessions) as rounds:
            under_load = _timed("under load", lambda: time_engines(planners, cases))
            load_during = os.getloadavg()[0]  # at the end: the 1-minute average lags
        under_load |= {
            "sessions": args.sessions,
            "load_average_1min_at_end": round(load_during, 2),
            "rounds_of_steps": len(rounds),
            "steps_per_s_median": statistics.median(r["throughput_steps_per_s"] for r in rounds),
            "session_errors": sum(r["errors"] for r in rounds),
        }
    agreed = _timed("agreement", lambda: agreement(generators, evaluation_sets(args.data)))
    result = {
        "checkpoint": str(args.checkpoint),
        "threads": args.threads,
        "num_beams": base.generation.num_beams,
        "calls_per_engine": len(cases) * REPEATS,
        "onnx_build_s": round(build_s, 2),
        "budget": {"median_ms": BUDGET_MEDIAN_MS, "p90_ms": BUDGET_P90_MS},
        "alone": alone,
        "under_load": under_load,
        "agreement": agreed,
    }
    return run.finish(args.out, result, [json.dumps(result, indent=2)])


if __name__ == "__main__":
    raise SystemExit(main())
