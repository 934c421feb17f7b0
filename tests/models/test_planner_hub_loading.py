"""The default planner loads and decodes with plain transformers calls, as its model card shows.

The issue: ``AutoModelForSeq2SeqLM.from_pretrained`` + ``generate`` + ``tokenizer.decode`` gave garbage,
because the decoder writes plan words, not input-tokenizer pieces. The card's snippet is run here as the
card prints it, and its plans are compared with the service's planner on the same dialogues.
"""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import pytest
from transformers import AutoTokenizer

from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.config import GenerationConfig
from models.planner.hub import PLAN_TOKENIZER_DIR, plan_tokenizer
from models.planner.modeling import load_planner_model, read_planner_meta, save_planner_model
from models.planner.plan_vocab import PlanVocabulary
from models.planner.predict import SubgoalGenerator
from symbolic.data_dir import REPO_ROOT
from symbolic.ontology import load_ontology
from symbolic.subgoals import parse_subgoals

CARD = DEFAULT_CHECKPOINT_DIR / "README.md"


def card_snippet() -> str:
    """The card's first Python block."""
    match = re.search(r"```python\n(.*?)```", CARD.read_text(encoding="utf-8"), re.S)
    assert match, f"{CARD} shows no Python snippet"
    return match.group(1)


@pytest.fixture(scope="module")
def snippet_run() -> dict[str, object]:
    """The snippet's names after running it from the repository root, as a user there would."""
    namespace: dict[str, object] = {}
    printed = io.StringIO()
    with contextlib.chdir(REPO_ROOT), contextlib.redirect_stdout(printed):
        exec(compile(card_snippet(), str(CARD), "exec"), namespace)  # the card's own code, nothing else
    namespace["printed"] = printed.getvalue()
    return namespace


@pytest.mark.parametrize("engine", ["auto", "torch"])
def test_the_cards_snippet_gives_the_services_plans(snippet_run: dict[str, object], engine: str) -> None:
    dialogues = snippet_run["dialogues"]
    plans = snippet_run["plans"]
    assert isinstance(dialogues, list) and isinstance(plans, list) and len(dialogues) == len(plans) == 2
    service = SubgoalGenerator.from_directory(
        DEFAULT_CHECKPOINT_DIR,
        load_ontology(),
        GenerationConfig(engine=engine),  # type: ignore[arg-type]
    )
    expected = [service.generate_texts([dialogue])[0] for dialogue in dialogues]
    assert plans == expected
    for plan in plans:
        assert parse_subgoals(plan, load_ontology()), f"no plan in {plan!r}"
    assert str(plans) in str(snippet_run["printed"])


def test_the_coffee_request_plans_a_coffee(snippet_run: dict[str, object]) -> None:
    """What a person reading the card sees: a readable plan in §5's text form, not word pieces."""
    plans = snippet_run["plans"]
    assert isinstance(plans, list)
    assert plans[0].startswith("Navigate Mug, Pickup Mug")
    assert "ToggleOn CoffeeMachine" in plans[0]


def test_the_plan_tokenizer_reads_and_writes_the_plan_vocabulary_ids() -> None:
    vocab = PlanVocabulary.load(DEFAULT_CHECKPOINT_DIR)
    assert vocab is not None
    writer = AutoTokenizer.from_pretrained(str(DEFAULT_CHECKPOINT_DIR), subfolder=PLAN_TOKENIZER_DIR)
    plan = "Navigate Knife, Pickup Knife, Navigate Apple, Slice Apple, Place CounterTop, Pickup AppleSliced"
    ids = vocab.encode(plan, load_ontology())  # ends with the end id
    assert writer(plan, add_special_tokens=False)["input_ids"] == ids[:-1]
    generated = [vocab.start_id, *ids, vocab.pad_id, vocab.pad_id]
    assert writer.decode(generated, skip_special_tokens=True) == vocab.decode(generated) == plan
    assert writer.get_vocab() == plan_tokenizer(vocab).get_vocab()


def test_the_generation_config_holds_the_services_decoding() -> None:
    settings = json.loads((DEFAULT_CHECKPOINT_DIR / "generation_config.json").read_text())
    meta = read_planner_meta(DEFAULT_CHECKPOINT_DIR)
    assert settings["num_beams"] == GenerationConfig().num_beams
    assert settings["sequence_bias"] == [[[3], meta["navigate_bias"]]]  # 3: the Navigate word
    tokenizer = json.loads((DEFAULT_CHECKPOINT_DIR / "tokenizer_config.json").read_text())
    assert tokenizer["model_max_length"] == meta["train_config"]["max_source_tokens"]  # type: ignore[index]


def test_config_names_the_class_that_loads_it() -> None:
    config = json.loads((DEFAULT_CHECKPOINT_DIR / "config.json").read_text())
    assert config["architectures"] == ["EncoderDecoderModel"]
    assert config["model_type"] == "encoder-decoder"
    assert config["encoder"]["_name_or_path"] == "sentence-transformers/all-MiniLM-L6-v2"


def test_saving_a_planner_writes_no_machine_path_and_the_hub_files(tmp_path: Path) -> None:
    """A re-saved checkpoint (training's last/ and final/, average) brings no folder of this machine back."""
    planner = load_planner_model(DEFAULT_CHECKPOINT_DIR)
    planner.model.config.encoder.name_or_path = str(tmp_path / "somewhere" / "minilm")
    meta = {**read_planner_meta(DEFAULT_CHECKPOINT_DIR), "initialised_from": str(tmp_path / "run" / "final")}
    out = tmp_path / "saved"
    save_planner_model(planner, out, meta, half_precision=True)
    for path in out.rglob("*.json"):
        assert str(tmp_path) not in path.read_text(), f"{path.name} records {tmp_path}"
    assert read_planner_meta(out)["initialised_from"] is None
    assert (out / PLAN_TOKENIZER_DIR / "tokenizer.json").is_file()
    assert json.loads((out / "generation_config.json").read_text())["num_beams"] == 4
