"""The 40 dialogues with counts and conjunctions (``tests/data/quantity_dialogues.jsonl``, issue 62) load as
the hand-written set does, with valid plans and the phenomena each one shows."""

from __future__ import annotations

import json
from pathlib import Path

from models.planner.data import handwritten_examples
from symbolic.ontology import load_ontology

QUANTITY = Path(__file__).resolve().parents[1] / "data" / "quantity_dialogues.jsonl"
PHENOMENA = {"count", "conjunction", "all", "back_reference", "history", "none", "distractor", "one"}


def test_the_quantity_dialogues_load_with_valid_plans_and_known_phenomena() -> None:
    examples = handwritten_examples(QUANTITY, load_ontology())  # raises on a plan outside the ontology
    assert len(examples) == 40 and len({e.example_id for e in examples}) == 40
    records = [json.loads(line) for line in QUANTITY.read_text(encoding="utf-8").splitlines()]
    tags = [set(record["phenomena"]) for record in records]
    assert all(t and t <= PHENOMENA for t in tags), [t - PHENOMENA for t in tags]
    assert sum("count" in t for t in tags) >= 15 and sum("conjunction" in t for t in tags) >= 10
    assert sum("none" in t for t in tags) >= 5  # look-alikes that ask for no more than the model plans
