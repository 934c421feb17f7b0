"""Language planner latency on CPU (DESIGN.md §8: planner call median ≤ 150 ms).

Times ``ModelPlanner.plan`` as a session calls it (format the dialogue and history, beam search of 4,
validate against the ontology, task-level repair) on fixed inputs: the 30 hand-written dialogues of
``tests/data/handwritten_dialogues.jsonl`` and five ALFRED-style instructions, each planned ``REPEATS``
times after one warm-up pass. Generation alone is timed too, and the generated plan lengths are reported
because beam-search time grows with them.

Run: ``.venv/bin/python -m bench.planner_latency [--checkpoint DIR] [--threads N]``; writes
``bench/results/planner_latency.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from pathlib import Path

import torch

from agent.model_planner import ModelPlanner, planner_source
from agent.planning import DialogueTurn, PlannerConfig, PlanningContext
from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.predict import SubgoalGenerator
from symbolic.data_dir import REPO_ROOT
from symbolic.ontology import load_ontology
from symbolic.subgoals import parse_subgoals

RESULTS = Path(__file__).resolve().parent / "results" / "planner_latency.json"
HANDWRITTEN = REPO_ROOT / "tests" / "data" / "handwritten_dialogues.jsonl"
INSTRUCTIONS = (
    "Put a clean mug in the coffee machine.",
    "Place a chilled apple on the kitchen table.",
    "Put two spray bottles in the cabinet.",
    "Look at the alarm clock under the lamp.",
    "Put a heated slice of potato in the fridge.",
)
REPEATS = 3
TARGET_MEDIAN_MS = 150.0


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


def main() -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.planner_latency", description=__doc__)
    parser.add_argument("--checkpoint", type=Path, default=DEFAULT_CHECKPOINT_DIR)
    parser.add_argument(
        "--threads", type=int, default=1, help="torch threads (a replica serves many sessions)"
    )
    args = parser.parse_args()
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    torch.set_num_threads(args.threads)
    ontology = load_ontology()
    generator = SubgoalGenerator.from_directory(args.checkpoint, ontology)
    planner = ModelPlanner(ontology, PlannerConfig(), generator=generator)
    cases = contexts()
    for context in cases:  # warm-up: first calls allocate caches
        planner.plan(context)
    plan_ms: list[float] = []
    lengths: list[int] = []
    for _ in range(REPEATS):
        for context in cases:
            start = time.perf_counter()
            outcome = planner.plan(context)
            plan_ms.append((time.perf_counter() - start) * 1000)
            lengths.append(len(outcome.plan))
    generate_ms = []
    for context in cases:
        source = planner_source(context)  # the very text the planner gives the model
        start = time.perf_counter()
        generator.generate_texts([source])
        generate_ms.append((time.perf_counter() - start) * 1000)
    median = statistics.median(plan_ms)
    result = {
        "checkpoint": str(args.checkpoint),
        "threads": args.threads,
        "num_beams": generator.generation.num_beams,
        "calls": len(plan_ms),
        "plan_ms": {
            "median": median,
            "p90": percentile(plan_ms, 0.9),
            "max": max(plan_ms),
        },
        "generate_only_ms_median": statistics.median(generate_ms),
        "plan_length": {"median": statistics.median(lengths), "max": max(lengths)},
        "target_median_ms": TARGET_MEDIAN_MS,
        "median_over_target": median / TARGET_MEDIAN_MS,
        "machine": {
            "cpus": os.cpu_count(),
            "load_1min": os.getloadavg()[0],
            "python": platform.python_version(),
        },
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
