"""The plan vocabulary: whole subgoal words, a round trip to §5's text form, and the plan grammar."""

from __future__ import annotations

from pathlib import Path

import pytest

from models.planner.plan_vocab import PlanVocabulary
from symbolic.ontology import load_ontology


@pytest.fixture(scope="module")
def vocab() -> PlanVocabulary:
    return PlanVocabulary.from_ontology(load_ontology())


def test_a_plan_is_two_tokens_a_subgoal_and_an_end(vocab: PlanVocabulary) -> None:
    plan = "Navigate Knife, Pickup Knife, Navigate Bread, Slice Bread"
    ids = vocab.encode(plan, load_ontology())
    assert len(ids) == 9 and ids[-1] == vocab.end_id
    assert vocab.decode([vocab.start_id, *ids]) == plan


def test_type_names_are_made_canonical_on_encoding(vocab: PlanVocabulary) -> None:
    ids = vocab.encode("navigate countertop, pickup glassbottle", load_ontology())
    assert vocab.decode(ids) == "Navigate CounterTop, Pickup Glassbottle"


def test_decoding_drops_a_dangling_action_and_padding(vocab: PlanVocabulary) -> None:
    ids = vocab.encode("Pickup Mug", load_ontology())[:-1] + [vocab.words.index("Place"), vocab.pad_id]
    assert vocab.decode(ids) == "Pickup Mug"


def test_the_grammar_alternates_actions_and_types_then_pads(vocab: PlanVocabulary) -> None:
    start = [vocab.start_id]
    assert set(vocab.allowed_next(start)) == {*vocab.action_ids(), vocab.end_id}
    pickup = vocab.words.index("Pickup")
    assert vocab.allowed_next([*start, pickup]) == vocab.type_ids()
    mug = vocab.words.index("Mug")
    assert vocab.end_id in vocab.allowed_next([*start, pickup, mug])
    assert vocab.allowed_next([*start, pickup, mug, vocab.end_id]) == [vocab.pad_id]


def test_it_saves_beside_the_weights_and_loads_back(vocab: PlanVocabulary, tmp_path: Path) -> None:
    assert PlanVocabulary.load(tmp_path) is None
    vocab.save(tmp_path)
    assert PlanVocabulary.load(tmp_path) == vocab
