"""The default planner checkpoint: it loads offline, stays within its size budget and plans sensibly."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.__main__ import main as planner_cli
from models.planner.modeling import read_planner_meta
from models.planner.predict import SubgoalGenerator
from models.planner.text import format_instruction
from symbolic.ontology import load_ontology
from symbolic.subgoals import Subgoal, SubgoalAction

A = SubgoalAction
MAX_CHECKPOINT_BYTES = 40 * 1024 * 1024  # the budget for the default planner


@pytest.fixture(scope="module")
def generator() -> SubgoalGenerator:
    return SubgoalGenerator.from_directory(DEFAULT_CHECKPOINT_DIR, load_ontology())


def test_the_default_checkpoint_is_complete_and_within_budget() -> None:
    files = {path.name for path in DEFAULT_CHECKPOINT_DIR.iterdir()}
    assert {
        "config.json",
        "model.safetensors",
        "tokenizer.json",
        "planner_meta.json",
        "README.md",
        "HISTORY.md",
    } <= files
    assert "optimizer.pt" not in files
    size = sum(path.stat().st_size for path in DEFAULT_CHECKPOINT_DIR.rglob("*") if path.is_file())
    assert size <= MAX_CHECKPOINT_BYTES, f"default planner is {size / 2**20:.1f} MiB"
    meta = read_planner_meta(DEFAULT_CHECKPOINT_DIR)
    assert meta["weights_dtype"] == "float16"
    assert meta["step"] == meta["train_config"]["max_steps"]


def test_the_model_card_quotes_the_written_evaluation() -> None:
    card = (DEFAULT_CHECKPOINT_DIR / "README.md").read_text(encoding="utf-8")
    results = json.loads((DEFAULT_CHECKPOINT_DIR / "evaluation.json").read_text(encoding="utf-8"))
    for report in results["sets"]:
        assert report["name"] in card
        assert f"{report['overall']['exact_match']:.1%}" in card


def test_the_default_checkpoint_reads_the_instruction_mark(generator: SubgoalGenerator) -> None:
    """Trained with ``<INS>``, it is given ALFRED goals under their own mark, not rewritten as a commander's
    turn (the fallback for checkpoints trained before the mark)."""
    assert generator.reads_instruction_mark
    source = format_instruction("Put a cell phone on the bed.")
    assert source.startswith("<INS>")
    assert generator.readable(source) == source


def test_an_alfred_instruction_becomes_its_plan(generator: SubgoalGenerator) -> None:
    prediction = generator.predict(format_instruction("Put a cell phone on the bed."))
    assert list(prediction.subgoals) == [
        Subgoal(A.NAVIGATE, "CellPhone"),
        Subgoal(A.PICKUP, "CellPhone"),
        Subgoal(A.NAVIGATE, "Bed"),
        Subgoal(A.PLACE, "Bed"),
    ]
    assert prediction.notes == ()


def test_a_chilling_instruction_goes_through_the_fridge(generator: SubgoalGenerator) -> None:
    prediction = generator.predict(format_instruction("Put a chilled apple on the counter."))
    plan = list(prediction.subgoals)
    assert Subgoal(A.PICKUP, "Apple") in plan
    assert plan.index(Subgoal(A.PLACE, "Fridge")) < plan.index(Subgoal(A.PLACE, "CounterTop"))


def test_evaluate_refuses_a_handwritten_file_that_is_not_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A mistyped path once skipped the hand-written set without a word; the metrics file then lacked it.
    Now it is one line naming the file, and exit code 2, before anything loads."""
    with pytest.raises(SystemExit) as stopped:
        planner_cli(["evaluate", "--handwritten", str(tmp_path / "missing.jsonl")])
    assert stopped.value.code == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "missing.jsonl" in error
