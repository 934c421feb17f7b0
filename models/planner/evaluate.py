"""Metrics of a planner on evaluation sets: exact match, per-subgoal P/R/F1, edit distance, per task type.

Plans are compared as subgoal sequences after both are parsed through the ontology, so spelling and case do
not matter. One more exact match drops the Open/Close of the container an object is fetched from: ALFRED's
and TEACh's reference plans open a fridge or a drawer because the expert found the apple in it, which no
instruction says, so language alone cannot know it (``drop_fetch_container_open_close``). A third ignores
Navigate: the §5 rule writes one only where the expert happened to walk between two interactions, which
the dialogue does not say, and the agent's repair puts a Navigate before every object out of reach anyway,
so what the agent does depends on the interactions alone (``interactions_only``).

Each miss is also given one reason (``miss_kind``), so a report says how much of the gap to a bar is where
the expert walked, which container it found things in, where the reference stops, or what is acted on.
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Literal

from tqdm import tqdm

from models.planner.data import PlannerExample
from models.planner.predict import PlanPrediction
from symbolic.ontology import Ontology
from symbolic.subgoals import Subgoal, SubgoalAction, parse_subgoals

A = SubgoalAction


def edit_distance(a: Sequence[Subgoal], b: Sequence[Subgoal]) -> int:
    """Levenshtein distance over subgoals (insert, delete, substitute a whole subgoal cost 1 each)."""
    previous = list(range(len(b) + 1))
    for i, x in enumerate(a, start=1):
        current = [i]
        for j, y in enumerate(b, start=1):
            current.append(min(previous[j] + 1, current[j - 1] + 1, previous[j - 1] + (x != y)))
        previous = current
    return previous[-1]


def drop_fetch_container_open_close(plan: Sequence[Subgoal]) -> list[Subgoal]:
    """The plan without the Open C ... Close C pairs that only fetch something out of container C.

    A pair is dropped when something other than C is acted on between them and nothing is placed in C
    (putting the apple *into* the fridge is what the instruction asked; taking it out is where the expert
    happened to find it). The ``Navigate C`` just before such an Open becomes ``Navigate X`` for the first
    object X acted on inside, and repeated Navigates to the same object collapse to one.
    """
    drop: set[int] = set()
    renamed: dict[int, Subgoal] = {}
    for i, subgoal in enumerate(plan):
        if subgoal.action is not A.OPEN or i in drop:
            continue
        container = subgoal.obj
        close = next(
            (k for k in range(i + 1, len(plan)) if plan[k] == Subgoal(A.CLOSE, container) and k not in drop),
            None,
        )
        if close is None:
            continue
        inside = plan[i + 1 : close]
        if any(s == Subgoal(A.PLACE, container) for s in inside):
            continue
        fetched = [s for s in inside if s.action is not A.NAVIGATE and s.obj != container]
        if not fetched:
            continue
        drop |= {i, close}
        if i > 0 and plan[i - 1] == Subgoal(A.NAVIGATE, container):
            renamed[i - 1] = Subgoal(A.NAVIGATE, fetched[0].obj)
    kept: list[Subgoal] = []
    for i, subgoal in enumerate(plan):
        if i in drop:
            continue
        subgoal = renamed.get(i, subgoal)
        if subgoal.action is A.NAVIGATE and kept and kept[-1] == subgoal:
            continue
        kept.append(subgoal)
    return kept


def interactions_only(plan: Sequence[Subgoal]) -> list[Subgoal]:
    """The plan's subgoals other than Navigate, in order."""
    return [s for s in plan if s.action is not A.NAVIGATE]


MissKind = Literal["navigate", "fetch_container", "stops_early", "runs_on", "other_objects", "other_steps"]
MISS_KINDS: tuple[MissKind, ...] = (
    "navigate",
    "fetch_container",
    "stops_early",
    "runs_on",
    "other_objects",
    "other_steps",
)
"""Why a plan missed, first that applies: only Navigate steps differ; only the Open/Close of a container
something is fetched from (and Navigate). The rest compare the interactions with those fetching Open/Close
left out: the plan's are a beginning of the reference's, or the reference's a beginning of the plan's; the
same actions in the same order on some other objects (Knife for ButterKnife, FloorLamp for DeskLamp);
anything else (other or reordered actions)."""


def miss_kind(predicted: Sequence[Subgoal], reference: Sequence[Subgoal]) -> MissKind | None:
    """The first ``MISS_KINDS`` reason that explains why ``predicted`` is not ``reference``; None if equal."""
    if list(predicted) == list(reference):
        return None
    if interactions_only(predicted) == interactions_only(reference):
        return "navigate"
    p = interactions_only(drop_fetch_container_open_close(predicted))
    r = interactions_only(drop_fetch_container_open_close(reference))
    if p == r:
        return "fetch_container"
    if len(p) < len(r) and r[: len(p)] == p:
        return "stops_early"
    if len(p) > len(r) and p[: len(r)] == r:
        return "runs_on"
    if [s.action for s in p] == [s.action for s in r]:
        return "other_objects"
    return "other_steps"


def count_misses(
    predicted: Sequence[Sequence[Subgoal]], reference: Sequence[Sequence[Subgoal]]
) -> dict[str, int]:
    """How many plans missed for each reason, every reason listed (zero included)."""
    counts = Counter(miss_kind(p, r) for p, r in zip(predicted, reference, strict=True))
    return {kind: counts[kind] for kind in MISS_KINDS}


@dataclass(frozen=True)
class Scores:
    """Metrics over a set of (predicted, reference) plans; P/R/F1 are micro-averaged over subgoals."""

    count: int
    exact_match: float
    exact_match_container_normalised: float
    exact_match_interactions: float  # Navigate ignored
    precision: float
    recall: float
    f1: float
    mean_edit_distance: float


def _overlap(predicted: Sequence[Subgoal], reference: Sequence[Subgoal]) -> int:
    """Subgoals in common, counted with multiplicity (a plan may pick up two apples)."""
    return sum((Counter(predicted) & Counter(reference)).values())


def score_plans(predicted: Sequence[Sequence[Subgoal]], reference: Sequence[Sequence[Subgoal]]) -> Scores:
    """Exact matches, subgoal P/R/F1 and mean edit distance; empty input gives zeros with count 0."""
    if len(predicted) != len(reference):
        raise ValueError(f"{len(predicted)} predictions for {len(reference)} references")
    n = len(reference)
    if n == 0:
        return Scores(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    exact = sum(list(p) == list(r) for p, r in zip(predicted, reference, strict=True))
    normalised = sum(
        drop_fetch_container_open_close(p) == drop_fetch_container_open_close(r)
        for p, r in zip(predicted, reference, strict=True)
    )
    interactions = sum(
        interactions_only(p) == interactions_only(r) for p, r in zip(predicted, reference, strict=True)
    )
    common = sum(_overlap(p, r) for p, r in zip(predicted, reference, strict=True))
    n_predicted = sum(len(p) for p in predicted)
    n_reference = sum(len(r) for r in reference)
    precision = common / n_predicted if n_predicted else 0.0
    recall = common / n_reference if n_reference else 0.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0
    distance = sum(edit_distance(p, r) for p, r in zip(predicted, reference, strict=True)) / n
    return Scores(n, exact / n, normalised / n, interactions / n, precision, recall, f1, distance)


@dataclass(frozen=True)
class EvaluationReport:
    """Scores of one evaluation set, overall and per task type, and how often validation had to step in."""

    name: str
    overall: Scores
    per_task_type: dict[str, Scores]
    mapped_items: int
    dropped_items: int
    misses: dict[str, int]
    """Plans that are not exact matches, by ``miss_kind``."""

    def as_json(self) -> dict[str, object]:
        return {
            "name": self.name,
            "overall": asdict(self.overall),
            "misses": dict(self.misses),
            "per_task_type": {task: asdict(scores) for task, scores in sorted(self.per_task_type.items())},
            "mapped_items": self.mapped_items,
            "dropped_items": self.dropped_items,
        }


def report_for(
    name: str,
    examples: Sequence[PlannerExample],
    predictions: Sequence[PlanPrediction],
    ontology: Ontology,
) -> EvaluationReport:
    """Score predictions against the examples' targets, overall and grouped by task type."""
    references = [parse_subgoals(e.target, ontology) for e in examples]
    predicted = [list(p.subgoals) for p in predictions]
    groups: dict[str, list[int]] = defaultdict(list)
    for index, example in enumerate(examples):
        groups[example.task_type].append(index)
    per_type = {
        task: score_plans([predicted[i] for i in indices], [references[i] for i in indices])
        for task, indices in groups.items()
    }
    notes = [note for p in predictions for note in p.notes]
    return EvaluationReport(
        name=name,
        overall=score_plans(predicted, references),
        per_task_type=per_type,
        mapped_items=sum(note.kind == "mapped" for note in notes),
        dropped_items=sum(note.kind == "dropped" for note in notes),
        misses=count_misses(predicted, references),
    )


def predict_in_batches(
    predict_many: Callable[[Sequence[str]], list[PlanPrediction]],
    examples: Sequence[PlannerExample],
    batch_size: int,
    show_progress: bool = True,
    description: str = "evaluate",
) -> list[PlanPrediction]:
    """Predictions for every example, batched by input length (less padding), returned in input order."""
    order = sorted(range(len(examples)), key=lambda i: len(examples[i].source))
    results: dict[int, PlanPrediction] = {}
    with tqdm(total=len(examples), desc=description, disable=not show_progress) as bar:
        for start in range(0, len(order), batch_size):
            chunk = order[start : start + batch_size]
            for index, prediction in zip(
                chunk, predict_many([examples[i].source for i in chunk]), strict=True
            ):
                results[index] = prediction
            bar.update(len(chunk))
    return [results[i] for i in range(len(examples))]


def write_predictions(
    path: Path, examples: Sequence[PlannerExample], predictions: Sequence[PlanPrediction]
) -> None:
    """One line per example: input, reference, raw generation, validated plan, notes (for error analysis)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", encoding="utf-8") as out:
        for example, prediction in zip(examples, predictions, strict=True):
            record = {
                "id": example.example_id,
                "task_type": example.task_type,
                "source": example.source,
                "reference": example.target,
                "generated": prediction.text,
                "plan": ", ".join(str(s) for s in prediction.subgoals),
                "notes": [f"{n.kind}: {n.item!r}: {n.detail}" for n in prediction.notes],
            }
            out.write(json.dumps(record, ensure_ascii=False) + "\n")


def format_report_table(sets: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of each set's overall scores, from ``EvaluationReport.as_json`` records (what
    ``evaluate --out`` writes and the model card is made from)."""
    lines = [
        "| set | n | exact match | containers normalised | Navigate ignored | P | R | F1 | edit distance |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for report in sets:
        s = report["overall"]
        lines.append(
            f"| {report['name']} | {s['count']} | {s['exact_match']:.1%} | "
            f"{s['exact_match_container_normalised']:.1%} | {s['exact_match_interactions']:.1%} | "
            f"{s['precision']:.3f} | {s['recall']:.3f} | {s['f1']:.3f} | {s['mean_edit_distance']:.2f} |"
        )
    return "\n".join(lines)


def format_miss_table(sets: Sequence[Mapping[str, Any]]) -> str:
    """A Markdown table of each set's misses by reason (``MISS_KINDS``), from ``EvaluationReport.as_json``
    records (what ``evaluate --out`` writes and the model card is made from)."""
    lines = [
        "| set | misses | " + " | ".join(kind.replace("_", " ") for kind in MISS_KINDS) + " |",
        "|---|---|" + "---|" * len(MISS_KINDS),
    ]
    for report in sets:
        misses = report.get("misses") or {}
        cells = " | ".join(str(misses.get(kind, 0)) for kind in MISS_KINDS)
        lines.append(f"| {report['name']} | {sum(misses.values())} | {cells} |")
    return "\n".join(lines)
