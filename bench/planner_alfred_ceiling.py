"""How far a planner that reads only ALFRED's task description can go on valid_seen, measured on the data.

Issue #5 asks for ALFRED valid_seen ``task_desc`` -> subgoals exact match ≥ 60% and ≥ 75% after dropping the
Open/Close of a container something is fetched from. A reference plan is what ALFRED's expert did in its
scene: which knife it took, where it put the knife down after slicing, which lamp, table or ladle it used.
The sentence an annotator wrote afterwards says little of that. Three measurements say how much:

- parameter oracle: told each task's exact ``pddl_params`` (task type, object, receptacle, movable
  receptacle, lamp, sliced), answer with the plan ALFRED train most often has for those parameters. No
  reader of the sentence can know more of the task than its parameters, and a plan is a function of them
  only as far as the expert's choices repeat.
- sentence oracle: for the valid_seen sentences that occur verbatim in train (lower-cased, punctuation
  dropped), answer with the plan train most often pairs with that exact sentence; and how often the
  parameters train most often pairs with a sentence are the task's own (in valid_seen, and within train's
  repeated sentences themselves, which is an in-sample, optimistic figure).
- the checkpoint's own plans, scored on the same subsets.

Run: ``.venv/bin/python -m bench.planner_alfred_ceiling [--checkpoint DIR]``; writes
``bench/results/planner_alfred_ceiling.json``. Needs the shared data directory.
"""

from __future__ import annotations

import json
import re
from collections import Counter, defaultdict
from collections.abc import Callable, Hashable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from bench.cli import bench_parser
from bench.stamp import BenchRun
from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.data import alfred_plan, read_jsonl_gz
from models.planner.text import format_instruction
from symbolic.data_dir import require_data_dir
from symbolic.ontology import Ontology, load_ontology
from symbolic.subgoals import format_subgoals

BAR_EXACT, BAR_NORMALISED = 0.60, 0.75
_NOT_LETTERS = re.compile(r"[^a-z ]+")


@dataclass(frozen=True)
class Task:
    """One annotation of an ALFRED trajectory: its sentence, the task's parameters and its plan."""

    sentence: str
    words: str
    parameters: tuple[str, ...]
    plan: str
    normalised: str


def _words(sentence: str) -> str:
    return " ".join(_NOT_LETTERS.sub(" ", sentence.lower()).split())


def tasks(path: Path, ontology: Ontology) -> Iterator[Task]:
    from models.planner.evaluate import drop_fetch_container_open_close  # loads torch and transformers

    for record in read_jsonl_gz(path):
        try:
            plan = alfred_plan(record, ontology)
        except ValueError:  # a plan outside the ontology (SubgoalSyntaxError, UnknownObjectType)
            continue
        p = record["pddl_params"]
        parameters = (
            str(record["task_type"]),
            *(str(p[key]) for key in ("object_target", "parent_target", "mrecep_target", "toggle_target")),
            str(bool(p["object_sliced"])),
        )
        for annotation in record["turk_annotations"]["anns"]:
            sentence = str(annotation.get("task_desc", "")).strip()
            if sentence:
                yield Task(
                    sentence,
                    _words(sentence),
                    parameters,
                    format_subgoals(plan),
                    format_subgoals(drop_fetch_container_open_close(plan)),
                )


def commonest(
    train: Sequence[Task], key: Callable[[Task], Hashable], value: Callable[[Task], Hashable]
) -> dict[Hashable, Hashable]:
    """For each key, the value train pairs with it most often."""
    counts: defaultdict[Hashable, Counter[Hashable]] = defaultdict(Counter)
    for task in train:
        counts[key(task)][value(task)] += 1
    return {k: c.most_common(1)[0][0] for k, c in counts.items()}


def share(hits: Sequence[bool]) -> float | None:
    return round(sum(hits) / len(hits), 4) if hits else None


def scores(pairs: Sequence[tuple[str, str, str, str]]) -> dict[str, object]:
    """(answer, answer normalised, reference, reference normalised) -> n, exact and normalised match."""
    return {
        "n": len(pairs),
        "exact_match": share([a == r for a, _, r, _ in pairs]),
        "normalised_match": share([an == rn for _, an, _, rn in pairs]),
    }


def main(argv: Sequence[str] | None = None) -> int:
    parser = bench_parser("planner_alfred_ceiling", __doc__)
    parser.add_argument("--checkpoint", type=Path, default=DEFAULT_CHECKPOINT_DIR)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args(argv)
    run = BenchRun.start("planner_alfred_ceiling", argv)
    import torch  # torch and transformers load after parsing, so --help answers at once

    from models.planner.evaluate import drop_fetch_container_open_close
    from models.planner.predict import SubgoalGenerator

    torch.set_num_threads(args.threads)
    ontology = load_ontology()
    alfred = require_data_dir() / "alfred"
    train = list(tasks(alfred / "train.jsonl.gz", ontology))
    seen = list(tasks(alfred / "valid_seen.jsonl.gz", ontology))

    parameters_of_sentence = commonest(train, lambda t: t.words, lambda t: t.parameters)

    def oracle(key: Callable[[Task], Hashable], subset: Sequence[Task]) -> dict[str, object]:
        """Told ``key`` of each task: the commonest train plan for it, and (for the normalised match) the
        commonest normalised plan, which may belong to other trajectories than the commonest plan."""
        plan = commonest(train, key, lambda t: t.plan)
        normalised = commonest(train, key, lambda t: t.normalised)
        return scores(
            [
                (str(plan.get(key(t), "")), str(normalised.get(key(t), "")), t.plan, t.normalised)
                for t in subset
            ]
        )

    repeated = Counter(t.words for t in train)
    in_train = [t for t in seen if t.words in parameters_of_sentence]
    rest = [t for t in seen if t.words not in parameters_of_sentence]
    train_repeats = [t for t in train if repeated[t.words] >= 2]

    generator = SubgoalGenerator.from_directory(args.checkpoint, ontology)
    plans: dict[str, tuple[str, str]] = {}
    sentences = sorted({t.sentence for t in seen})
    for start in range(0, len(sentences), 32):
        batch = sentences[start : start + 32]
        for sentence, prediction in zip(
            batch, generator.predict_many([format_instruction(s) for s in batch]), strict=True
        ):
            subgoals = list(prediction.subgoals)
            plans[sentence] = (
                format_subgoals(subgoals),
                format_subgoals(drop_fetch_container_open_close(subgoals)),
            )

    def model(subset: Sequence[Task]) -> dict[str, object]:
        return scores([(*plans[t.sentence], t.plan, t.normalised) for t in subset])

    parameter_oracle = oracle(lambda t: t.parameters, seen)
    result = {
        "set": "alfred valid_seen task_desc",
        "checkpoint": str(args.checkpoint),
        "bars": {"exact_match": BAR_EXACT, "normalised_match": BAR_NORMALISED},
        "parameter_oracle": parameter_oracle,
        "parameters_a_reader_must_get_right_for_the_normalised_bar": round(
            BAR_NORMALISED / float(str(parameter_oracle["normalised_match"])), 4
        ),
        "sentences_in_train": {
            "n": len(in_train),
            "sentence_oracle": oracle(lambda t: t.words, in_train),
            "parameters_of_the_sentence_are_the_tasks": share(
                [parameters_of_sentence[t.words] == t.parameters for t in in_train]
            ),
            "model": model(in_train),
        },
        "sentences_not_in_train": {"n": len(rest), "model": model(rest)},
        "train_repeated_sentences_in_sample": {
            "n": len(train_repeats),
            "parameters_of_the_sentence_are_the_tasks": share(
                [parameters_of_sentence[t.words] == t.parameters for t in train_repeats]
            ),
        },
        "model": model(seen),
    }
    return run.finish(args.out, result, [json.dumps(result, indent=2)])


if __name__ == "__main__":
    raise SystemExit(main())
