"""Plans before and after the request passes (``symbolic.request_corrections``, ``symbolic.request_cover``) on
words not written for the model.

Issue 62: the planner handles one object where people ask for several ("clean two plates and two cups",
"clean a mug and a pan") and keeps the word a commander took back ("sorry, not the desk, the sofa"). The
service repairs the model's plan and, since issue 62, first makes it follow the corrections and cover the
counts and "x and y" of the commander's words. This bench decodes every dialogue once with the default
checkpoint and scores three plans against the reference: the model's validated plan against the reference
as written ("model"), the repaired plan against the repaired reference ("repaired", the service before the
passes), and the plan after the passes and repair against the same ("covered", the service now). It lists
every dialogue the passes changed, and whether that gained or lost an exact match.

Sets: the 30 hand-written dialogues (``tests/data/handwritten_dialogues.jsonl``), the 40 dialogues with
counts and conjunctions (``tests/data/quantity_dialogues.jsonl``), the 100 held-out dialogues of a second
writer (``tests/data/heldout_dialogues.jsonl``; both per phenomenon too), ALFRED valid_seen
``task_desc`` (the shared data), and generated valid_unseen EDH/TfD instances when ``--teach`` names a
folder ``python -m harness generate --split valid_unseen`` wrote.

Run: ``.venv/bin/python -m bench.planner_requests [--teach DIR] [--out FILE]``.
"""

from __future__ import annotations

import json
import statistics
import time
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agent.planning import belief_after
from bench.cli import bench_parser
from bench.stamp import BenchRun
from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.data import alfred_plan, read_jsonl_gz, teach_instance_files, teach_task_type
from models.planner.text import format_planner_input
from symbolic.cli_args import existing_dir
from symbolic.data_dir import default_data_dir
from symbolic.ontology import Ontology, UnknownObjectType, load_ontology
from symbolic.repair import repair_plan
from symbolic.request_corrections import follow_corrections, read_corrections
from symbolic.request_cover import cover_request
from symbolic.request_words import object_words, read_request
from symbolic.subgoals import (
    Subgoal,
    SubgoalSyntaxError,
    format_subgoals,
    parse_subgoals,
    subgoals_from_teach_actions,
)

TESTS_DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
REPO_ROOT = Path(__file__).resolve().parent.parent
BATCH = 32


@dataclass(frozen=True)
class Dialogue:
    """One input as a session gets it, its reference future plan, and the phenomena it shows."""

    id: str
    turns: tuple[tuple[str, str], ...]
    instruction: str | None
    history: tuple[Subgoal, ...]
    reference: tuple[Subgoal, ...]
    phenomena: tuple[str, ...] = ()

    @property
    def source(self) -> str:
        return format_planner_input(list(self.turns), list(self.history), self.instruction)

    @property
    def commander_words(self) -> list[str]:
        said = [text for speaker, text in self.turns if speaker == "Commander"]
        return [self.instruction, *said] if self.instruction else said


def jsonl_dialogues(path: Path, ontology: Ontology) -> list[Dialogue]:
    """The hand-written format: ``{"id", "dialogue": [[speaker, text]...], "history_subgoals",
    "future_subgoals", "phenomena"?}``."""
    dialogues = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.strip():
            record = json.loads(line)
            dialogues.append(
                Dialogue(
                    id=str(record["id"]),
                    turns=tuple((str(s), str(t)) for s, t in record["dialogue"]),
                    instruction=None,
                    history=tuple(parse_subgoals(record.get("history_subgoals") or [], ontology)),
                    reference=tuple(parse_subgoals(record["future_subgoals"], ontology)),
                    phenomena=tuple(record.get("phenomena", ())),
                )
            )
    return dialogues


def alfred_dialogues(path: Path, ontology: Ontology) -> list[Dialogue]:
    """Every annotation's ``task_desc`` of ALFRED valid_seen as an instruction session's input."""
    dialogues = []
    for trajectory in read_jsonl_gz(path):
        try:
            plan = tuple(alfred_plan(trajectory, ontology))
        except (SubgoalSyntaxError, UnknownObjectType):
            continue
        for number, annotation in enumerate(trajectory["turk_annotations"]["anns"]):
            text = str(annotation.get("task_desc", "")).strip()
            if text:
                dialogues.append(Dialogue(f"{trajectory['task_id']}:{number}", (), text, (), plan))
    return dialogues


def teach_dialogues(root: Path, kind: str, ontology: Ontology) -> list[Dialogue]:
    """Generated valid_unseen EDH or TfD instances (what ``build-data`` makes its sets of)."""
    dialogues = []
    for path in teach_instance_files(root, "valid_unseen", (kind,)):
        instance = json.loads(path.read_text(encoding="utf-8"))
        try:
            future = instance.get("future_subgoals") or subgoals_from_teach_actions(
                instance.get("driver_actions_future") or []
            )
            reference = tuple(parse_subgoals(future, ontology))
            history = tuple(parse_subgoals(instance.get("history_subgoals") or [], ontology))
        except (SubgoalSyntaxError, UnknownObjectType):
            continue
        turns = tuple((str(s), str(t)) for s, t in instance.get("dialog_history", []))
        game = str(instance.get("game_id") or path.stem.split(".")[0])
        task = teach_task_type(instance, root, "valid_unseen", game)
        dialogues.append(Dialogue(path.stem, turns, None, history, reference, (task,)))
    return dialogues


def _scores(pairs: Sequence[tuple[Sequence[Subgoal], Sequence[Subgoal]]]) -> dict[str, float]:
    from models.planner.evaluate import score_plans  # it imports torch, which --help must not

    scores = score_plans([p for p, _ in pairs], [r for _, r in pairs])
    return {"n": scores.count, "exact": round(scores.exact_match, 4), "f1": round(scores.f1, 4)}


def score_set(name: str, dialogues: Sequence[Dialogue], ontology: Ontology) -> dict[str, Any]:
    """Decode once; score the model, repaired and covered plans; list what the pass changed."""
    from agent.model_planner import load_generator  # loads torch when called; imported here for --help

    generator = load_generator(DEFAULT_CHECKPOINT_DIR)
    predictions = []
    for start in range(0, len(dialogues), BATCH):
        predictions += generator.predict_many([d.source for d in dialogues[start : start + BATCH]])
    words = object_words(ontology)
    rows: dict[str, list[tuple[list[Subgoal], list[Subgoal]]]] = defaultdict(list)
    by_phenomenon: dict[str, dict[str, list[tuple[list[Subgoal], list[Subgoal]]]]] = defaultdict(
        lambda: defaultdict(list)
    )
    changed = []
    pass_ms = []
    for dialogue, prediction in zip(dialogues, predictions, strict=True):
        belief = belief_after(dialogue.history, ontology)
        model = list(prediction.subgoals)
        reference = repair_plan(list(dialogue.reference), ontology, belief.copy()).plan
        repaired = repair_plan(model, ontology, belief.copy()).plan
        started = time.perf_counter()
        request = read_request(dialogue.commander_words, words)
        corrections = read_corrections(dialogue.commander_words, words)
        followed, fixes = follow_corrections(model, corrections, request.mentions, ontology)
        extended, events = cover_request(followed, request, ontology, dialogue.history)
        events = [*fixes, *events]
        pass_ms.append((time.perf_counter() - started) * 1000)
        covered = repair_plan(extended, ontology, belief.copy()).plan
        rows["model"].append((model, list(dialogue.reference)))
        rows["repaired"].append((repaired, reference))
        rows["covered"].append((covered, reference))
        for phenomenon in dialogue.phenomena:
            by_phenomenon[phenomenon]["repaired"].append((repaired, reference))
            by_phenomenon[phenomenon]["covered"].append((covered, reference))
        if events:
            changed.append(
                {
                    "id": dialogue.id,
                    "said": dialogue.commander_words,
                    "exact_before": repaired == reference,
                    "exact_after": covered == reference,
                    "rules": [f"{e.rule}: {e.reason}" for e in events],
                    "covered": format_subgoals(covered),
                    "reference": format_subgoals(reference),
                }
            )
    report: dict[str, Any] = {"name": name, **{k: _scores(v) for k, v in rows.items()}}
    if by_phenomenon:
        report["per_phenomenon"] = {
            phenomenon: {k: _scores(v) for k, v in kinds.items()}
            for phenomenon, kinds in sorted(by_phenomenon.items())
        }
    report["changed"] = len(changed)
    report["gained_exact"] = sum(c["exact_after"] and not c["exact_before"] for c in changed)
    report["lost_exact"] = sum(c["exact_before"] and not c["exact_after"] for c in changed)
    report["pass_ms_median"] = round(statistics.median(pass_ms), 3) if pass_ms else None
    report["pass_ms_max"] = round(max(pass_ms), 3) if pass_ms else None
    report["changes"] = changed
    return report


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("planner_requests", __doc__)
    parser.add_argument("--teach", type=existing_dir, help="generated valid_unseen games (harness generate)")
    parser.add_argument("--threads", type=int, default=1, help="torch threads")
    parser.add_argument("--skip-alfred", action="store_true", help="leave out ALFRED valid_seen task_desc")
    args = parser.parse_args(argv)
    run = BenchRun.start("planner_requests", argv)
    import torch

    torch.set_num_threads(args.threads)
    ontology = load_ontology()
    sets: dict[str, list[Dialogue]] = {
        "handwritten": jsonl_dialogues(TESTS_DATA / "handwritten_dialogues.jsonl", ontology),
        "quantity": jsonl_dialogues(TESTS_DATA / "quantity_dialogues.jsonl", ontology),
        "heldout": jsonl_dialogues(TESTS_DATA / "heldout_dialogues.jsonl", ontology),
    }
    alfred = default_data_dir() / "alfred" / "valid_seen.jsonl.gz"
    if alfred.is_file() and not args.skip_alfred:
        sets["alfred_valid_seen_task_desc"] = alfred_dialogues(alfred, ontology)
    if args.teach is not None:
        sets["generated_valid_unseen_edh"] = teach_dialogues(args.teach, "edh", ontology)
        sets["generated_valid_unseen_tfd"] = teach_dialogues(args.teach, "tfd", ontology)
    started = time.perf_counter()
    reports = [score_set(name, dialogues, ontology) for name, dialogues in sets.items()]
    result = {
        "checkpoint": str(DEFAULT_CHECKPOINT_DIR.relative_to(REPO_ROOT)),
        "scored": "model: validated plan vs reference; repaired: repair_plan of both; covered: "
        "follow_corrections, cover_request then repair_plan vs the repaired reference",
        "sets": reports,
        "wall_s": round(time.perf_counter() - started, 1),
    }
    summary = (
        f"{report['name']:<32} n={report['model']['n']:<4} "
        f"model exact {report['model']['exact']:.3f} F1 {report['model']['f1']:.3f} | "
        f"repaired {report['repaired']['exact']:.3f} / {report['repaired']['f1']:.3f} | "
        f"covered {report['covered']['exact']:.3f} / {report['covered']['f1']:.3f} | "
        f"changed {report['changed']} (+{report['gained_exact']} -{report['lost_exact']})"
        for report in reports
    )
    return run.finish(args.out, result, summary)


if __name__ == "__main__":
    raise SystemExit(main())
