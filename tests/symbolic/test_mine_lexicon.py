"""Mining the object words of ALFRED's step sentences (``symbolic.mine_lexicon``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from symbolic.mine_lexicon import LEXICON_PATH, main, mine, phrases, step_types
from symbolic.ontology import load_ontology

ONTOLOGY = load_ontology()


def _pickup(object_id: str, receptacle: str) -> dict[str, Any]:
    return {
        "discrete_action": {"action": "PickupObject", "args": [object_id.split("|")[0].lower()]},
        "planner_action": {"objectId": object_id, "coordinateReceptacleObjectId": [receptacle, []]},
    }


def test_a_step_touches_its_object_and_the_receptacle_it_comes_from() -> None:
    assert step_types(_pickup("Candle|1|2|3", "CounterTop"), ONTOLOGY) == {"Candle", "CounterTop"}
    goto = {"discrete_action": {"action": "GotoLocation", "args": ["sinkbasin"]}, "planner_action": {}}
    assert step_types(goto, ONTOLOGY) == {"SinkBasin"}


def test_phrases_neither_start_nor_end_with_a_function_word_and_know_their_article() -> None:
    found = phrases("Pick up the candlestick from the counter.")
    assert found["candlestick"] is True and found["counter"] is True
    assert "pick up" not in found and "the candlestick" not in found


def test_a_phrase_is_mined_when_its_steps_nearly_always_touch_one_type_the_ontology_cannot_name() -> None:
    candle = frozenset({"Candle", "CounterTop"})
    pairs = [("Pick up the candlestick on the counter.", candle)] * 9
    pairs += [("Grab the candlestick.", frozenset({"Candle"}))]
    pairs += [("Take the gizmo.", frozenset({"Mug"})), ("Take the gizmo.", frozenset({"Pan"}))] * 5
    mined = mine(iter(pairs), ONTOLOGY, min_count=8, min_precision=0.8)
    assert list(mined) == ["candlestick"]  # "counter" the ontology reads; "gizmo" is half Mug, half Pan
    assert (mined["candlestick"].object_type, mined["candlestick"].count) == ("Candle", 10)


@pytest.mark.data
def test_the_shipped_lexicon_is_what_the_script_makes_from_alfred(
    shared_data_dir: Path, tmp_path: Path
) -> None:
    out = tmp_path / "lexicon.json"
    assert main(["--train", str(shared_data_dir / "alfred" / "train.jsonl.gz"), "--out", str(out)]) == 0
    shipped = json.loads(LEXICON_PATH.read_text(encoding="utf-8"))
    made = json.loads(out.read_text(encoding="utf-8"))
    assert made == shipped, (
        "object_lexicon.json differs from a fresh run: rerun python -m symbolic.mine_lexicon"
    )
