"""Averaging checkpoints: the soup is the weighted mean of its parts, plans, and refuses strangers."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
import torch

from models.planner.__main__ import main
from models.planner.average import IncompatibleCheckpoints, average_checkpoints
from models.planner.config import BartScratchArchitecture
from models.planner.data import DatasetFiles
from models.planner.modeling import load_planner_model, read_planner_meta
from models.planner.predict import SubgoalGenerator
from models.planner.train import train
from symbolic.ontology import load_ontology
from tests.models.planner_training_helpers import tiny_recipe, weights


@pytest.fixture
def lineage(dataset: DatasetFiles, tmp_path: Path) -> tuple[Path, Path]:
    """A first run and a second schedule started from it: the pair a soup is made of."""
    train(tiny_recipe(3), dataset, tmp_path / "first", show_progress=False, export_fp16=False)
    train(
        replace(tiny_recipe(3), train=replace(tiny_recipe(3).train, seed=8, learning_rate=1e-2)),
        dataset,
        tmp_path / "second",
        show_progress=False,
        export_fp16=False,
        init_from=tmp_path / "first" / "final",
    )
    return tmp_path / "first" / "final", tmp_path / "second" / "final"


def test_the_average_is_the_weighted_mean_of_the_parts(lineage: tuple[Path, Path], tmp_path: Path) -> None:
    first, second = lineage
    average_checkpoints([first, second], [3, 1], tmp_path / "soup", half_precision=False)
    a, b, soup = weights(first), weights(second), weights(tmp_path / "soup")
    assert soup.keys() == a.keys()
    moved = [key for key in a if a[key].is_floating_point() and not torch.equal(a[key], b[key])]
    assert moved, "the second schedule changed nothing; the test would prove nothing"
    for key in a:
        if a[key].is_floating_point():
            torch.testing.assert_close(soup[key], 0.75 * a[key] + 0.25 * b[key])
    meta = read_planner_meta(tmp_path / "soup")
    assert [part["weight"] for part in meta["averaged_from"]] == [0.75, 0.25]
    assert meta["recipe"] == read_planner_meta(first)["recipe"]


def _logits(path: Path) -> torch.Tensor:
    planner = load_planner_model(path)
    inputs = planner.tokenizer("<COM> slice the bread", return_tensors="pt")
    with torch.no_grad():
        out = planner.model(**inputs, decoder_input_ids=inputs["input_ids"][:, :4])
    return out.logits


def test_a_soup_of_one_part_answers_as_that_part_does(lineage: tuple[Path, Path], tmp_path: Path) -> None:
    """The written folder is a whole planner: configs, tokenizer and weights load and generate."""
    first, second = (_logits(part) for part in lineage)
    assert not torch.allclose(first, second), "the parts answer alike; the test would prove nothing"
    for share, expected in (("1,0", first), ("0,1", second)):
        out = tmp_path / f"soup{share}"
        argv = [
            "average",
            "--checkpoints",
            *map(str, lineage),
            "--weights",
            share,
            "--out-dir",
            str(out),
            "--fp32",
        ]
        assert main(argv) == 0
        assert read_planner_meta(out)["weights_dtype"] == "float32"
        torch.testing.assert_close(_logits(out), expected)
        SubgoalGenerator.from_directory(out, load_ontology()).predict("<COM> slice the bread")


def test_another_architecture_is_refused_and_nothing_is_written(
    lineage: tuple[Path, Path],
    dataset: DatasetFiles,
    tmp_path: Path,
) -> None:
    wider = tiny_recipe(1)
    wider = replace(wider, bart=replace(wider.bart, d_model=48, ffn_dim=96))
    assert isinstance(wider.bart, BartScratchArchitecture)
    train(wider, dataset, tmp_path / "wider", show_progress=False)
    with pytest.raises(IncompatibleCheckpoints, match="other parameters|is \\("):
        average_checkpoints([lineage[0], tmp_path / "wider" / "final"], [1, 1], tmp_path / "soup")
    assert not (tmp_path / "soup").exists()


@pytest.mark.parametrize("shares", [[1.0], [1.0, -1.0], [0.0, 0.0], [float("nan"), 1.0]])
def test_weights_must_be_one_per_checkpoint_and_non_negative(
    lineage: tuple[Path, Path], tmp_path: Path, shares: list[float]
) -> None:
    with pytest.raises(ValueError, match="weights"):
        average_checkpoints(list(lineage), shares, tmp_path / "soup")
    assert not (tmp_path / "soup").exists()


def test_the_command_line_names_a_bad_weight_list_and_writes_nothing(
    lineage: tuple[Path, Path], tmp_path: Path
) -> None:
    first, second = lineage
    argv = [
        "average",
        "--checkpoints",
        str(first),
        str(second),
        "--weights",
        "1",
        "--out-dir",
        str(tmp_path / "soup"),
    ]
    with pytest.raises(SystemExit, match="2 checkpoints need 2 weights"):
        main(argv)
    assert not (tmp_path / "soup").exists()
