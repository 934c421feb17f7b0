"""The decoder's Navigate bias: chosen on held-out sets, recorded in the checkpoint, read when planning."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from models.planner import DEFAULT_CHECKPOINT_DIR
from models.planner.__main__ import main as planner_cli
from models.planner.calibrate import BiasScore, best_bias
from models.planner.config import GenerationConfig
from models.planner.data import PlannerExample, write_examples
from models.planner.modeling import PLANNER_META_FILE, read_planner_meta
from models.planner.predict import SubgoalGenerator
from models.planner.text import format_planner_input
from symbolic.ontology import load_ontology
from symbolic.subgoals import SubgoalAction, format_subgoals, parse_subgoals

TOAST = format_planner_input(
    [("Commander", "Next toast a piece of bread"), ("Driver", "sounds good")],
    parse_subgoals("Pickup Knife, Slice Bread, Place CounterTop", load_ontology()),
)
"""An EDH cut after the bread was sliced: whether the plan walks to a slice first is not in the words."""


@pytest.fixture()
def checkpoint(tmp_path: Path) -> Path:
    """The default checkpoint's files, linked, with a planner_meta.json of its own to write to."""
    copy = tmp_path / "planner"
    copy.mkdir()
    for path in DEFAULT_CHECKPOINT_DIR.iterdir():
        if path.name == PLANNER_META_FILE:
            shutil.copy(path, copy / path.name)
        else:
            (copy / path.name).symlink_to(path)
    return copy


def _navigates(generator: SubgoalGenerator, source: str) -> int:
    return sum(s.action is SubgoalAction.NAVIGATE for s in generator.predict(source).subgoals)


def test_the_navigate_bias_decides_whether_a_plan_walks_first(checkpoint: Path) -> None:
    ontology = load_ontology()
    walking = SubgoalGenerator.from_directory(checkpoint, ontology, GenerationConfig(navigate_bias=4.0))
    staying = SubgoalGenerator(walking.planner, ontology, GenerationConfig(navigate_bias=-4.0))
    assert _navigates(walking, TOAST) > _navigates(staying, TOAST)


def test_calibrate_records_the_best_bias_and_planning_then_uses_it(checkpoint: Path, tmp_path: Path) -> None:
    ontology = load_ontology()
    walking = SubgoalGenerator.from_directory(checkpoint, ontology, GenerationConfig(navigate_bias=4.0))
    target = format_subgoals(walking.predict(TOAST).subgoals)
    data = tmp_path / "data"
    write_examples(data / "eval_walks.jsonl", [PlannerExample("toast", TOAST, target, "Breakfast", "test")])

    assert planner_cli(
        ["calibrate", "--checkpoint", str(checkpoint), "--data", str(data), "--sets", "walks",
         "--biases=-4,4", "--write"]
    ) == 0  # fmt: skip

    meta = read_planner_meta(checkpoint)
    assert meta["navigate_bias"] == 4.0
    assert meta["navigate_bias_calibration"]["sets"] == ["walks"]
    assert SubgoalGenerator.from_directory(checkpoint, ontology).navigate_bias == 4.0
    assert read_planner_meta(DEFAULT_CHECKPOINT_DIR).get("navigate_bias") != 4.0, "the default is untouched"


def test_of_equal_scores_the_bias_nearest_zero_wins() -> None:
    scores = [BiasScore(-1.0, {}, 0.7), BiasScore(0.5, {}, 0.7), BiasScore(2.0, {}, 0.6)]
    assert best_bias(scores).bias == 0.5
    assert best_bias([*scores, BiasScore(1.5, {}, 0.71)]).bias == 1.5
